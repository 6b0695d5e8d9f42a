"""Disturbances and imperfections a planar task can switch on (all off by default)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from sail_env.physics.noise import WhiteNoise


@dataclasses.dataclass(frozen=True)
class Disturbances:
    """What a ground station faces. Every field is off (zero / False) by default.

    Attributes:
        sensor_noise_std: Standard deviation of the measurement of each state component
            ``(X [m], Vx [m/s], θ [rad], ω [rad/s])``, white, per observation.
        beam_jitter_m: Standard deviation of the beam's landing offset per control step
            (white, held for the step); over the coast the same spectral density
            ``σ² dt`` acts as continuous white noise.
        push_noise: Relative standard deviation of the push ``F`` per control step; the
            same spectral density acts over the coast.
        cutoff_jitter_s: Half-width of a uniform draw of the beam cut-off time around
            its nominal value; a few ms already randomise the oscillation's phase.
        light_delay: Delay observations and commands by the light travel time
            ``D(t)/c`` each way, rounded to whole control steps.
        parameter_spread: Relative half-width of a uniform per-episode draw of each mass,
            the strut and CoM lengths and the radius of curvature.
    """

    sensor_noise_std: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    beam_jitter_m: float = 0.0
    push_noise: float = 0.0
    cutoff_jitter_s: float = 0.0
    light_delay: bool = False
    parameter_spread: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "sensor_noise_std", tuple(float(s) for s in self.sensor_noise_std))
        if len(self.sensor_noise_std) != 4 or not all(
                math.isfinite(s) and s >= 0 for s in self.sensor_noise_std):
            raise ValueError(
                f"sensor_noise_std must be 4 finite values >= 0, got {self.sensor_noise_std}")
        for name in ("beam_jitter_m", "push_noise", "cutoff_jitter_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if not 0 <= self.parameter_spread < 0.5:
            raise ValueError(f"parameter_spread must be in [0, 0.5), got {self.parameter_spread}")

    def white_noise(self, dt: float) -> WhiteNoise:
        """The continuous-time intensities equivalent to the per-step noise."""
        return WhiteNoise.from_step_std(self.beam_jitter_m, self.push_noise, dt)

    @property
    def any_sensor_noise(self) -> bool:
        return any(s > 0 for s in self.sensor_noise_std)

    def sample_sensor_noise(self, rng: np.random.Generator) -> np.ndarray:
        return np.asarray(self.sensor_noise_std) * rng.standard_normal(4)
