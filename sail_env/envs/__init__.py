"""Gymnasium environments of lightsail-gym."""

from sail_env.envs.disturbances import Disturbances
from sail_env.envs.planar import LightSailEnv

__all__ = ["Disturbances", "LightSailEnv"]
