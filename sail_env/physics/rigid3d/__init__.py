"""Rigid 3D light sail: radiation force and torque integrated over real sail shapes and beams,
Euler's equations with the full inertia tensor, and the linearisation about the centred
equilibrium (docs/physics.md §6–§9). Pure numpy/scipy, batched over sails."""

from sail_env.physics.rigid3d.body import RigidSail, state_from_small, tilts
from sail_env.physics.rigid3d.config import BEAM_PROFILES, SHAPES, RigidSailConfig
from sail_env.physics.rigid3d.linearise import Linearisation, linearise

__all__ = ["RigidSail", "state_from_small", "tilts", "BEAM_PROFILES", "SHAPES", "RigidSailConfig",
           "Linearisation", "linearise"]
