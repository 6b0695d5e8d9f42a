"""The randomisation of an episode, in one home and one vocabulary: every keyword that makes one
episode differ from the next by chance, what it draws and where it acts.

| keyword(s) | draws | declared in | acts in |
|---|---|---|---|
| ``parameter_spread`` | per episode, the plant's ``spread_fields`` in ``1 ± s`` (planar: masses, strut and CoM lengths, curvature; 3D: mass, inertia, beam power) | :class:`Randomisation` | :meth:`~sail_env.physics.linear_plant.LinearPlant.draw` |
| ``model_uncertainty`` (3D only) | per episode, unobserved: curvature, absorptivity, power at the sail, a constant beam offset | :class:`~sail_env.physics.rigid3d.uncertainty.ModelUncertainty` (a :class:`~sail_env.envs.params.Rigid3DParams` keyword: it changes the sail model) | :class:`~sail_env.physics.rigid3d.uncertainty.UncertainPlant` |
| ``cutoff_jitter_s`` | per episode, the beam's cut-off time | :class:`Randomisation` | the episode core's reset |
| ``push_noise`` | per control step, the push's relative error | :class:`Randomisation` | the window's step and the coast |
| ``sensor_noise_std`` | per observation, white measurement noise on each state | :class:`Randomisation` | the observation |
| ``beam_jitter_m``, ``ground_jitter_rad``, ``dust_density_m3``, ``dust_grain_mass_kg`` | per control step, beam offsets or impacts | the registered disturbances (:mod:`sail_env.physics.disturbances`, base :mod:`sail_env.physics.disturbance`) | the plant's two channels, the step and the coast |

Every one of them is off by default, and none changes an env's observation or action space, so
each may also be given at ``reset(options={"params": {...}})`` (domain randomisation,
``sail_env.envs.options``). The light delay is no randomness (a fixed law of the flight, which sets the
observation's command history): it is an episode keyword of :func:`sail_env.core.spec.task_spec`.

:func:`randomisation` reads the keywords: the :class:`Randomisation` (the registered
disturbances among its ``sources``) and the keywords that are not randomisation.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from sail_env.physics.checks import real_number
from sail_env.physics.disturbance import Disturbance
from sail_env.physics.disturbances import split_keywords

#: Largest relative push noise per step: a laser cannot pull, and beyond 0.25 a 4σ step would
#: reverse the push (the per-step expansion in the push error, docs/physics.md §4, also loses
#: its accuracy there).
MAX_PUSH_NOISE = 0.25
#: Largest ``parameter_spread`` (exclusive): a factor ``1 − s`` must leave every length and mass positive.
MAX_PARAMETER_SPREAD = 0.5


def finite_nonnegative(values: object, name: str, count: int | None = None) -> tuple[float, ...]:
    """Finite real numbers ``>= 0`` (``count`` of them if given: one per state), or ``ValueError``."""
    items = list(values) if isinstance(values, (Sequence, np.ndarray)) and not isinstance(values, str) else None
    if items is None or (count is not None and len(items) != count):
        raise ValueError(f"{name} must be {count or 'a sequence of'} real numbers, got {values!r}")
    numbers = tuple(real_number(v, f"{name}[{i}]") for i, v in enumerate(items))
    if not all(math.isfinite(v) and v >= 0 for v in numbers):
        raise ValueError(f"{name} must be finite values >= 0, got {numbers}")
    return numbers


@dataclasses.dataclass(frozen=True)
class Randomisation:
    """What makes a task's episodes differ by chance (the table above). Every field is off (zero) by default.

    Attributes:
        sensor_noise_std: Standard deviation of the measurement of each state component
            (planar ``(X [m], Vx [m/s], θ [rad], ω [rad/s])``; one per state of the plant),
            white, per observation (any finite size: the observation saturates at ±1e3).
        push_noise: Relative standard deviation of the push ``F`` per control step; the
            same spectral density acts over the coast. At most :data:`MAX_PUSH_NOISE`.
        cutoff_jitter_s: Half-width of a uniform draw of the beam cut-off time around
            its nominal value; a few ms already randomise the oscillation's phase. The
            earliest cut-off must come after the last command has arrived.
        parameter_spread: Relative half-width of a uniform per-episode draw of each of the plant's
            ``spread_fields`` (planar: each mass, the strut and CoM lengths and the radius of
            curvature), in ``[0, 0.5)``; every draw must be a valid sail (checked at the corners of the box).
        sources: The registered random disturbances (:mod:`sail_env.physics.disturbances`: the
            beam's landing jitter ``beam_jitter_m``, the ground's pointing jitter, dust), which
            the plant carries; :func:`randomisation` makes them of their keywords.

    Numbers may be ints, floats or NumPy real scalars; bools and strings are refused.
    """

    sensor_noise_std: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    push_noise: float = 0.0
    cutoff_jitter_s: float = 0.0
    parameter_spread: float = 0.0
    sources: tuple[Disturbance, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "sensor_noise_std", finite_nonnegative(self.sensor_noise_std, "sensor_noise_std"))
        for name in ("push_noise", "cutoff_jitter_s", "parameter_spread"):
            value = real_number(getattr(self, name), name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
            object.__setattr__(self, name, value)
        if self.push_noise > MAX_PUSH_NOISE:
            raise ValueError(f"push_noise must be <= {MAX_PUSH_NOISE} (a 4σ step would reverse the push), "
                             f"got {self.push_noise}")
        if not self.parameter_spread < MAX_PARAMETER_SPREAD:
            raise ValueError(f"parameter_spread must be in [0, {MAX_PARAMETER_SPREAD}), got {self.parameter_spread}")
        if not all(isinstance(source, Disturbance) for source in self.sources):
            raise ValueError(f"sources must be Disturbance instances (sail_env.physics.disturbances), got {self.sources!r}")
        object.__setattr__(self, "sources", tuple(self.sources))

    @property
    def any_sensor_noise(self) -> bool:
        return any(s > 0 for s in self.sensor_noise_std)


#: The keywords of :class:`Randomisation`'s own fields (the registered disturbances' come from their registry).
FIELDS = tuple(field.name for field in dataclasses.fields(Randomisation) if field.name != "sources")


def randomisation(keywords: Mapping[str, object]) -> tuple[Randomisation, dict[str, object]]:
    """The :class:`Randomisation` that ``keywords`` set (its fields and the registered disturbances'
    keywords, each validated) and the keywords that are not randomisation."""
    sources, rest = split_keywords(keywords)
    own = {name: rest.pop(name) for name in FIELDS if name in rest}
    return Randomisation(**own, sources=sources), rest
