"""The ground station's pointing angle jitters: the spot moves by ``D(t)·δ`` at the sail
(docs/physics.md §12), on both lateral axes, ``D`` the draw's distance from the array."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from sail_env.physics.disturbance import BeamDisturbance, register


@register
@dataclasses.dataclass(frozen=True)
class GroundJitter(BeamDisturbance):
    """Attributes:
        ground_jitter_rad: Standard deviation of the ground station's pointing angle per control
            step (white, held for the step). The spot must stay on the sail at the farthest cut-off
            (``D·δ ≤ a``); the plant must integrate the flight (the 3D tasks).
    """

    ground_jitter_rad: float = 0.0
    needs_distance = True

    def check(self, plant: Any) -> None:
        if not hasattr(plant, "distance_flown"):
            raise ValueError(f"ground_jitter_rad needs a plant that integrates its flight's distance (the 3D tasks); "
                             f"{type(plant).__name__} does not, got {self.ground_jitter_rad}")
        farthest = plant.farthest_distance_m
        if self.ground_jitter_rad > plant.aperture_radius_m / farthest:
            raise ValueError(f"ground_jitter_rad must be in [0, {plant.aperture_radius_m / farthest:.4g}] rad (the "
                             f"spot's jitter D·δ at the farthest cut-off, D <= {farthest:.4g} m, at most the aperture "
                             f"radius, as beam_jitter_m), got {self.ground_jitter_rad}")

    def std_along(self, distance: Any, xp: Any = np) -> Any:
        return distance * self.ground_jitter_rad
