"""Pure physics of laser-propelled light sails (numpy/scipy only, no gymnasium)."""

from sail_env.physics.config import DEEP_DISH, FLAT, PRESETS, SEED, SailConfig, push_force_from_laser
from sail_env.physics.noise import WhiteNoise, propagate_moments
from sail_env.physics.planar import PlanarModel, Stability, StabilityKind
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD, pointing_error

__all__ = [
    "DEEP_DISH", "FLAT", "PRESETS", "SEED", "SailConfig", "push_force_from_laser",
    "WhiteNoise", "propagate_moments", "PlanarModel", "Stability", "StabilityKind",
    "POINTING_TOLERANCE_RAD", "pointing_error",
]
