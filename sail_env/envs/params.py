"""Each sail model family's keywords, declared once: a frozen dataclass whose fields are the family's
own ``gym.make`` keywords with their defaults (as Gymnasium's ``phys2d`` params), validated in
``__post_init__`` (one ``ValueError`` naming the keyword and its range, the physics configurations
checking the ranges they define) and documented by the env's ``## Arguments`` table, which
``tests/envs/test_rigid3d_keywords.py`` holds against these fields and defaults.

The episode keywords every family shares (:func:`sail_env.core.spec.task_spec`: the action scale,
the start box, the light delay) and the randomisation's (:mod:`sail_env.physics.randomisation`: the
parameter spread, the noise, the cut-off jitter, the registered random disturbances) are declared
where they act, not here; ``model_uncertainty``, which changes the sail model, is the 3D params'.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from sail_env.physics.checks import real_number
from sail_env.physics.planar.config import PRESETS, SailConfig
from sail_env.physics.planar.plant import PlanarPlant
from sail_env.physics.rigid3d.config import SHAPES, RigidSailConfig, check_choice
from sail_env.physics.rigid3d.plant import RigidPlant, RigidTaskConfig
from sail_env.physics.rigid3d.uncertainty import ModelUncertainty, UncertainPlant, UncertainTaskConfig

#: Relative beam power at action ±1 of the power input with ``power_control=True``.
DEFAULT_POWER_CONTROL = 0.1


def keywords(params: type) -> tuple[str, ...]:
    """The ``gym.make`` keywords a params class declares (its init fields)."""
    return tuple(field.name for field in dataclasses.fields(params) if field.init)


def split(params: type, given: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``given`` split into the keywords of ``params`` and the rest (the episode's)."""
    own = keywords(params)
    return ({name: value for name, value in given.items() if name in own},
            {name: value for name, value in given.items() if name not in own})


@dataclasses.dataclass(frozen=True)
class PlanarParams:
    """The planar sail's keywords (``LightSail-v0`` and the ids on it).

    Attributes:
        config: A :class:`~sail_env.physics.planar.config.SailConfig` or a preset's name
            (``seed``, ``deep_dish``, ``flat``); stored as the configuration.
    """

    config: SailConfig | str = "seed"

    def __post_init__(self) -> None:
        config = PRESETS[self.config] if isinstance(self.config, str) and self.config in PRESETS else self.config
        if type(config) is not SailConfig:
            raise ValueError(f"config must be a SailConfig or one of {sorted(PRESETS)}, got {self.config!r} "
                             f"(SailConfig(**fields) builds one from a dict)")
        object.__setattr__(self, "config", config)

    @property
    def make_plant(self) -> Callable[..., PlanarPlant]:
        """What builds the task's plant from its physical disturbances (:func:`~sail_env.core.spec.task_spec`)."""
        return functools.partial(PlanarPlant, self.config)


@dataclasses.dataclass(frozen=True)
class Rigid3DParams:
    """The rigid 3D sail's keywords (``LightSail3D-v0`` and the ids on it; their table:
    :class:`~sail_env.envs.rigid3d.LightSail3DEnv`). ``power_control`` is stored as the relative
    power at action ±1 and ``model_uncertainty`` as a
    :class:`~sail_env.physics.rigid3d.uncertainty.ModelUncertainty` or None; ``task`` is the
    validated :class:`~sail_env.physics.rigid3d.plant.RigidTaskConfig` they make (an
    :class:`~sail_env.physics.rigid3d.uncertainty.UncertainTaskConfig` with a model uncertainty).
    """

    # The defaults are the physics configurations' (the seed's dish in its flat-top beam).
    sail_shape: str = RigidSailConfig.shape
    beam_profile: str = RigidSailConfig.beam_profile
    curvature_radius_m: float = RigidSailConfig.curvature_radius_m
    com_distance_m: float = RigidSailConfig.com_distance_m
    absorptivity: float = RigidSailConfig.absorptivity
    beam_radius_m: float | None = RigidSailConfig.beam_radius_m
    spin_rad_s: float = RigidTaskConfig.spin_rad_s
    relativistic: bool = RigidTaskConfig.relativistic
    diffraction_length_m: float = RigidTaskConfig.diffraction_length_m
    payload_offset_m: float = RigidTaskConfig.payload_offset_m
    velocity_terms: bool = RigidTaskConfig.velocity_terms
    power_control: bool | float = False
    control_start_s: float = RigidTaskConfig.control_start_s
    model_uncertainty: ModelUncertainty | dict[str, float] | None = None
    task: RigidTaskConfig = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # The sail's shape is the configuration's ``shape``: checked here under the keyword's name.
        check_choice("sail_shape", self.sail_shape, SHAPES)
        object.__setattr__(self, "power_control", power_input(self.power_control))
        # The rest of the light is reflected: the absorptivity's range decides the reflectivity's.
        absorptivity = real_number(self.absorptivity, "absorptivity")
        if not 0 <= absorptivity <= 1:
            raise ValueError(f"absorptivity must be in [0, 1], got {self.absorptivity!r}")
        sail = RigidSailConfig(shape=self.sail_shape, beam_profile=self.beam_profile,
                               curvature_radius_m=self.curvature_radius_m, com_distance_m=self.com_distance_m,
                               absorptivity=absorptivity, reflectivity=1.0 - absorptivity,
                               beam_radius_m=self.beam_radius_m)
        uncertainty = self.model_uncertainty
        if isinstance(uncertainty, dict):
            uncertainty = ModelUncertainty(**uncertainty)
        elif not (uncertainty is None or isinstance(uncertainty, ModelUncertainty)):
            raise ValueError(f"model_uncertainty must be a ModelUncertainty, a dict of its fields or None, "
                             f"got {uncertainty!r}")
        object.__setattr__(self, "model_uncertainty", uncertainty)
        # The unobserved per-episode sail (sail_env.physics.rigid3d.uncertainty) flies as an UncertainTaskConfig.
        make_config = (RigidTaskConfig if uncertainty is None else
                       functools.partial(UncertainTaskConfig, uncertainty=uncertainty))
        object.__setattr__(self, "task", make_config(
            sail, spin_rad_s=self.spin_rad_s, power_control=self.power_control, relativistic=self.relativistic,
            diffraction_length_m=self.diffraction_length_m, payload_offset_m=self.payload_offset_m,
            velocity_terms=self.velocity_terms, control_start_s=self.control_start_s))

    @property
    def make_plant(self) -> Callable[..., RigidPlant]:
        """What builds the task's plant from its physical disturbances (:func:`~sail_env.core.spec.task_spec`)."""
        return functools.partial(RigidPlant if self.model_uncertainty is None else UncertainPlant, self.task)


def power_input(power_control: object) -> float:
    """``power_control`` as the relative power at action ±1: ``False`` or ``0`` is no power input,
    ``True`` :data:`DEFAULT_POWER_CONTROL`, a number that power (its range:
    :class:`~sail_env.physics.rigid3d.plant.RigidTaskConfig`)."""
    if isinstance(power_control, (bool, np.bool_)):
        return DEFAULT_POWER_CONTROL if power_control else 0.0
    return real_number(power_control, "power_control")
