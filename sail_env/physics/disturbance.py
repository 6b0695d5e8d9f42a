"""Random disturbances of the sail behind one small interface: a base class and a registry (the
pattern of safe-control-gym's disturbances), so that a new disturbance is one module and its test.

A disturbance is a frozen dataclass whose fields are the env keywords that set it (validated in
``__post_init__``: finite and ``>= 0`` unless the class says more), registered by :func:`register`.
It acts through one of two **channels** that the compiled window step, the coast's moment
propagation and the classical designs already carry; the plant (:class:`~sail_env.physics.linear_plant.LinearPlant`)
combines the active disturbances of each channel, and nothing else needs to know them:

| channel | what each control step draws | what the disturbance declares |
|---|---|---|
| ``beam`` | a white offset of the beam at the sail [m], held over the step, on each of the plant's ``jitter_inputs`` | :meth:`BeamDisturbance.std_m`: its standard deviation at flight times ``t`` |
| ``impulse`` | a Poisson number of random kicks on some state rows (a compound Poisson process) | :meth:`ImpulseDisturbance.rows`, :meth:`ImpulseDisturbance.rate_and_kick`: the rows, the rate and one kick's standard deviation per row |

Independent beam offsets add in variance (the plant's ``jitter_std`` is their ``hypot``). Over the
coast each acts as white noise of the same intensity: ``σ² dt`` for a beam offset, ``rate × σ²``
for the impulses (docs/physics.md §11, §15). The push noise, the sensor noise, the cut-off's
jitter and the parameter spread are the rest of the episode's randomisation
(:mod:`sail_env.physics.randomisation`, the one table of every random keyword): each has its own place in the step.

The registered disturbances are in :mod:`sail_env.physics.disturbances` (one module each), which
imports them and reads the filled registry (:func:`~sail_env.physics.disturbances.split_keywords`):
this base imports none of them.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from sail_env.physics.checks import real_number

#: Every registered disturbance class by each keyword it takes, in registration order.
REGISTRY: dict[str, type[Disturbance]] = {}


@dataclasses.dataclass(frozen=True)
class Disturbance:
    """A random disturbance set by its fields (env keywords, SI); off when every field is zero."""

    channel: ClassVar[str]
    #: Whether it reads the flight's distance from the ground (the plant must integrate the flight).
    needs_distance: ClassVar[bool] = False

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = real_number(getattr(self, field.name), field.name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{field.name} must be finite and >= 0, got {value}")
            object.__setattr__(self, field.name, value)  # NumPy scalars and ints stored as float

    @property
    def active(self) -> bool:
        """Whether it draws anything (every field nonzero; a subclass with one field: that one)."""
        return all(getattr(self, field.name) > 0 for field in dataclasses.fields(self))

    def check(self, plant: Any) -> None:
        """Refuse, with one ``ValueError`` naming the keyword and its range, a size the plant's model
        cannot carry (called by the plant once it knows its sail, before the costly tables)."""


class BeamDisturbance(Disturbance):
    """A white offset of the beam at the sail, drawn afresh each control step and held over it."""

    channel = "beam"

    def std_m(self, plant: Any, p: Any, t: np.ndarray) -> np.ndarray | float:
        """Standard deviation [m] of the offset in a step at flight times ``t`` ((k,) or a grid
        (k, s)) of the environments whose parameter draws are ``p``: a float, or shaped as ``t``."""
        return self.std_along(plant.distance_flown(p, t) if self.needs_distance else None)

    def std_along(self, distance: Any, xp: Any = np) -> Any:
        """The same at the sail's ``distance`` [m] from the array (None where it needs none): the law
        itself, in the array module ``xp`` (the JAX backend reads it along a flight)."""
        raise NotImplementedError


class ImpulseDisturbance(Disturbance):
    """Random kicks of some state rows, a Poisson number of them per control step."""

    channel = "impulse"

    def rows(self, plant: Any) -> tuple[int, ...]:
        """The state rows a kick changes."""
        raise NotImplementedError

    def rate_and_kick(self, plant: Any, p: Any, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean rate [1/s] (k,) of the kicks at flight times ``t`` (k,) and one kick's standard
        deviation (k, r) on each of :meth:`rows` (SI rates)."""
        return self.at_speed(plant, plant.speed(p, t))

    def at_speed(self, plant: Any, speed: Any, xp: Any = np) -> tuple[Any, Any]:
        """The same at the sail's axial ``speed`` [m/s] (..., ): the law itself, in the array module ``xp``
        (the JAX backend reads it along a flight)."""
        raise NotImplementedError


def register(cls: type[Disturbance]) -> type[Disturbance]:
    """Class decorator: make ``cls`` settable by its fields' names (each keyword names one class)."""
    for field in dataclasses.fields(cls):
        if field.name in REGISTRY:
            raise ValueError(f"keyword {field.name!r} is already taken by {REGISTRY[field.name].__name__}")
        REGISTRY[field.name] = cls
    return cls
