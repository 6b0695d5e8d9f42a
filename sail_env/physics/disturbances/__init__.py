"""The registered random disturbances (:mod:`sail_env.physics.disturbance`), one module each.

| keyword(s) | module | channel | plants |
|---|---|---|---|
| ``beam_jitter_m`` | :mod:`.landing_jitter` | beam | all |
| ``ground_jitter_rad`` | :mod:`.ground_jitter` | beam | those that integrate the flight (3D) |
| ``dust_density_m3``, ``dust_grain_mass_kg`` | :mod:`.dust` | impulse | the rigid 3D sail |

A new one: a module here with a registered :class:`~sail_env.physics.disturbance.BeamDisturbance` or
:class:`~sail_env.physics.disturbance.ImpulseDisturbance` (its limits in its own module), imported
below, and its test; its keywords then reach every env whose plant accepts it (its ``check``).
The imports below fill the registry in this order, before anything reads it from here.
"""

from __future__ import annotations

from collections.abc import Mapping

from sail_env.physics.disturbance import REGISTRY, Disturbance
from sail_env.physics.disturbances.landing_jitter import LandingJitter
from sail_env.physics.disturbances.ground_jitter import GroundJitter
from sail_env.physics.disturbances.dust import Dust

__all__ = ["Dust", "GroundJitter", "LandingJitter", "keywords", "split_keywords"]


def split_keywords(keywords: Mapping[str, object]) -> tuple[tuple[Disturbance, ...], dict[str, object]]:
    """The active registered disturbances set by ``keywords`` (in registration order; each validates
    its values, active or not) and the keywords that are not theirs."""
    classes: dict[type[Disturbance], dict[str, object]] = {}
    rest = {}
    for name, value in keywords.items():
        if name in REGISTRY:
            classes.setdefault(REGISTRY[name], {})[name] = value
        else:
            rest[name] = value
    order = list(dict.fromkeys(REGISTRY.values()))
    made = (cls(**classes[cls]) for cls in order if cls in classes)
    return tuple(d for d in made if d.active), rest


def keywords() -> tuple[str, ...]:
    """Every registered keyword."""
    return tuple(REGISTRY)
