"""Gymnasium environments of lightsail-gym: the single env and the NumPy-batched vector env
(planar and 3D)."""

from sail_env.envs.planar import LightSailEnv
from sail_env.envs.rigid3d import LightSail3DEnv
from sail_env.envs.vector import LightSailVectorEnv

__all__ = ["LightSail3DEnv", "LightSailEnv", "LightSailVectorEnv"]
