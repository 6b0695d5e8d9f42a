"""The beam's landing offset jitters: white, per control step, on each lateral axis."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from sail_env.physics.disturbance import BeamDisturbance, register


@register
@dataclasses.dataclass(frozen=True)
class LandingJitter(BeamDisturbance):
    """Attributes:
        beam_jitter_m: Standard deviation of the beam's landing offset per control step (white,
            held for the step; over the coast the same spectral density ``σ² dt`` acts as
            continuous white noise). At most the aperture radius: the linear model assumes the
            beam lands on the sail.
    """

    beam_jitter_m: float = 0.0

    def check(self, plant: Any) -> None:
        radius = plant.aperture_radius_m
        if self.beam_jitter_m > radius:
            raise ValueError(f"beam_jitter_m must be in [0, {radius:g}] m (at most the aperture radius: the beam "
                             f"must land on the sail), got {self.beam_jitter_m}")

    def std_along(self, distance: Any, xp: Any = np) -> float:
        return self.beam_jitter_m
