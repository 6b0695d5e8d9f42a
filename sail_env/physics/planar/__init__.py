"""The seed paper's planar sail (4 states, docs/physics.md §1): its configuration and presets
(:mod:`.config`), the linear model (:mod:`.model`) and the episode core's batched plant
(:mod:`.plant`)."""

from sail_env.physics.planar.config import DEEP_DISH, FLAT, PRESETS, SEED, SailConfig
from sail_env.physics.planar.model import PlanarModel
from sail_env.physics.planar.plant import PlanarPlant

__all__ = ["DEEP_DISH", "FLAT", "PRESETS", "SEED", "SailConfig", "PlanarModel", "PlanarPlant"]
