"""Gymnasium environments of lightsail-gym: the single env and the NumPy-batched vector env."""

from sail_env.envs.planar import LightSailEnv
from sail_env.envs.vector import LightSailVectorEnv

__all__ = ["LightSailEnv", "LightSailVectorEnv"]
