"""Pure physics of laser-propelled light sails (numpy/scipy only, no gymnasium).

Siblings, none the base of another: the generic linear machinery (:mod:`.linear`,
:mod:`.linear_plant`, :mod:`.noise`, :mod:`.pointing`), the validators (:mod:`.checks`), the seed's
design point (:mod:`.seed`), an episode's randomisation (:mod:`.randomisation`, with the random
disturbances: :mod:`.disturbance`, :mod:`.disturbances`),
and one package per sail model: :mod:`.planar` and :mod:`.rigid3d`. The names below are the
planar model's, kept here for short imports.
"""

from sail_env.physics.noise import WhiteNoise
from sail_env.physics.planar.config import DEEP_DISH, FLAT, PRESETS, SEED, SailConfig, push_force_from_laser
from sail_env.physics.planar.model import PlanarModel, Stability, StabilityKind, pointing_error, propagate_moments
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

__all__ = [
    "DEEP_DISH", "FLAT", "PRESETS", "SEED", "SailConfig", "push_force_from_laser",
    "WhiteNoise", "propagate_moments", "PlanarModel", "Stability", "StabilityKind",
    "POINTING_TOLERANCE_RAD", "pointing_error",
]
