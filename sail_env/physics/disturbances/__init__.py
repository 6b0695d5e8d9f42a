"""The registered random disturbances (:mod:`sail_env.physics.disturbance`), one module each.

| keyword(s) | module | channel | plants |
|---|---|---|---|
| ``beam_jitter_m`` | :mod:`.landing_jitter` | beam | all |
| ``ground_jitter_rad`` | :mod:`.ground_jitter` | beam | those that integrate the flight (3D) |
| ``dust_density_m3``, ``dust_grain_mass_kg`` | :mod:`.dust` | impulse | the rigid 3D sail |

A new one: a module here with a registered :class:`~sail_env.physics.disturbance.BeamDisturbance` or
:class:`~sail_env.physics.disturbance.ImpulseDisturbance`, imported below, and its test; its keywords
then reach every env whose plant accepts it (its ``check``).
"""

from sail_env.physics.disturbances.landing_jitter import LandingJitter
from sail_env.physics.disturbances.ground_jitter import GroundJitter
from sail_env.physics.disturbances.dust import Dust

__all__ = ["Dust", "GroundJitter", "LandingJitter"]
