"""Gymnasium environments of lightsail-gym: the single env and the NumPy-batched vector env."""

from sail_env.envs.planar import LightSailEnv

__all__ = ["LightSailEnv"]
