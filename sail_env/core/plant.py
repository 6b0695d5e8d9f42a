"""The plant contract: every member of a sail model that the episode core, the task spec, the envs
and the controllers use, and nothing else.

The core never looks behind this interface, so a new sail model is a class with these members
(``PlanarPlant`` and ``RigidPlant`` in ``sail_env.physics`` are the two today).
``tests/core/test_plant_contract.py`` checks both against it, and checks that the core, the envs
and the agents use no member it does not declare.

All arrays are batched over ``k`` environments: states ``x`` (k, n), inputs ``u`` (k, m), flight
times ``t`` (k,). ``p`` is the :class:`~sail_env.physics.linear_plant.PlantParams` of those environments'
parameter draws. SI units throughout.

| member | what the core asks |
|---|---|
| ``config`` | the configuration, whose timing the core reads: ``control_start_s``, ``control_step_s``, ``control_steps``, ``beam_cutoff_s`` |
| ``light_speed_settings`` | the settings that set the fastest flight (named when a task would pass light speed) |
| ``state_names``, ``state_units`` | the state's components and their units (``m``, ``m/s``, ``rad``, ``rad/s``: the observation's scales) |
| ``input_names``, ``input_units``, ``input_ranges`` | the beam inputs; ``m``/``rad`` scale with the task's beam limits, other units by ``input_ranges`` (the input at action +1) |
| ``fixed_state`` | quantities a start may name but not change (the 3D sail's spin) |
| ``radial_pairs`` | pairs of state rows limited together at the start, in their length ``√(a² + b²)`` (the 3D sail's x and y axes; none in the plane) |
| ``n_states``, ``n_inputs`` | their counts |
| ``nominal`` | the nominal :class:`~sail_env.physics.linear.LinearModel` controllers design on |
| ``constant_term`` | the nominal model's constant drive ``c`` in ``ds/dt = A s + B u + c`` (n,) |
| ``rate_scale()`` | the nominal model's fastest rate [1/s]: the time scale of the observation |
| ``start_limits()`` | the largest start (n,) inside the beam for every draw |
| ``acceleration_m_s2``, ``max_acceleration_m_s2`` | the nominal and the largest axial acceleration (light delay, light-speed check) |
| ``spread_fields``, ``n_factors``, ``n_draws``, ``draw(rng)``, ``factors(uniforms)``, ``params(factors)`` | the per-episode parameter draw: the factors' names, their count, ``n_draws`` uniform numbers of a generator made factors in a batch, and the arrays they give |
| ``step(p, x, u, push)`` | one control step with ``u`` held and a relative push error per environment (``p.step``'s rows: the compiled step's matrix) |
| ``divergence_groups``, ``diverged(p, x)`` | the divergence rule as data (groups of at most two state rows whose norm must stay within the matching column of ``p.limits``; the compiled step applies it) and the same test in NumPy |
| ``velocity_rows``, ``with_bias(u)``, ``peak_speed(p, x, u)`` | the lateral velocity rows of ``p.envelope``, the inputs with the constant term's 1, the largest lateral speed with ``u`` held (the reward's envelope) |
| ``speed(p, t)``, ``pointing(p, x, t)`` | the axial speed and the flight direction ``|V⊥|/Vz`` if the beam is cut at ``t`` |
| ``noisy``, ``jittered``, ``jitter_inputs``, ``jitter_std(p, t)`` | whether noise acts over the coast; the inputs a beam offset moves and the size of the active beam disturbances together (``sail_env.physics.disturbance``'s beam channel) |
| ``impulse_rows``, ``impact_rate_and_std(p, t)`` | random impacts (the impulse channel, e.g. dust): the rows they kick, their rate and size |
| ``flight_model(p)`` | what a coast along the flight reads of draws ``p`` (the 3D plant's tables and per-draw arrays; None for a model that does not change along it): the JAX backend's coast |
| ``jitter_std_along(distance, xp)``, ``impacts_along(speed, xp)`` | the beam offsets' size and the impacts' rate and size as laws of the sail's distance and speed, in an array module (what the JAX backend reads along a flight) |
| ``coast_pieces(p, duration)``, ``coast(p, x, u, duration, normals, start_s)``, ``coast_with_paths(…, normals, paths, start_s)`` | the propagation to cut-off with the noise's exact moments, and how many normals it draws; with further paths through the same propagators (the score's expectation) |
| ``time_varying``, ``piece_propagators(p, u, start_s, duration)``, ``held_input_generator(p, t)`` | whether the coast's model changes along the flight; one coast piece's propagator, and the moment generator of every held input at once (what the JAX backend is handed to coast as the compiled core does) |
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol, runtime_checkable

import numpy as np

from sail_env.physics.linear import LinearModel
from sail_env.physics.linear_plant import PlantParams


class Timing(Protocol):
    """A plant configuration's timing, as the core reads it [s]."""

    control_start_s: float
    control_step_s: float
    control_steps: int
    beam_cutoff_s: float


@runtime_checkable
class Plant(Protocol):
    """A batched linear sail model, as the episode core uses it (the module's table)."""

    config: Timing
    light_speed_settings: str
    state_names: tuple[str, ...]
    state_units: tuple[str, ...]
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]
    input_ranges: Mapping[str, float]
    fixed_state: Mapping[str, float]
    radial_pairs: tuple[tuple[int, int], ...]
    spread_fields: tuple[str, ...]
    jitter_inputs: tuple[int, ...]
    impulse_rows: tuple[int, ...]
    velocity_rows: tuple[int, ...]
    divergence_groups: tuple[tuple[int, ...], ...]
    nominal: LinearModel
    noisy: bool
    time_varying: bool

    @property
    def n_states(self) -> int: ...

    @property
    def n_inputs(self) -> int: ...

    @property
    def n_factors(self) -> int: ...

    @property
    def n_draws(self) -> int: ...

    @property
    def constant_term(self) -> np.ndarray: ...

    @property
    def jittered(self) -> bool: ...

    @property
    def acceleration_m_s2(self) -> float: ...

    @property
    def max_acceleration_m_s2(self) -> float: ...

    def rate_scale(self) -> float: ...

    def start_limits(self) -> np.ndarray: ...

    def draw(self, rng: np.random.Generator) -> np.ndarray: ...

    def factors(self, uniforms: np.ndarray) -> np.ndarray: ...

    def params(self, factors: np.ndarray) -> PlantParams: ...

    def with_bias(self, u: np.ndarray) -> np.ndarray: ...

    def step(self, p: PlantParams, x: np.ndarray, u: np.ndarray, push: np.ndarray | None = None) -> np.ndarray: ...

    def diverged(self, p: PlantParams, x: np.ndarray) -> np.ndarray: ...

    def peak_speed(self, p: PlantParams, x: np.ndarray, u: np.ndarray) -> np.ndarray: ...

    def speed(self, p: PlantParams, t: np.ndarray) -> np.ndarray: ...

    def pointing(self, p: PlantParams, x: np.ndarray, t: np.ndarray) -> np.ndarray: ...

    def jitter_std(self, p: PlantParams, t: np.ndarray) -> np.ndarray | float: ...

    def impact_rate_and_std(self, p: PlantParams, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def jitter_std_along(self, distance: object, xp: object = np) -> object: ...

    def flight_model(self, p: PlantParams) -> object | None: ...

    def impacts_along(self, speed: object, xp: object = np) -> tuple[object, object]: ...

    def coast_pieces(self, p: PlantParams, duration: np.ndarray) -> np.ndarray: ...

    def coast(self, p: PlantParams, x: np.ndarray, u: np.ndarray, duration: np.ndarray,
              normals: np.ndarray | None, start_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def coast_with_paths(self, p: PlantParams, x: np.ndarray, u: np.ndarray, duration: np.ndarray,
                         normals: np.ndarray | None, paths: np.ndarray | None, start_s: np.ndarray) -> tuple: ...

    def piece_propagators(self, p: PlantParams, u: np.ndarray, start_s: np.ndarray,
                          duration: np.ndarray) -> np.ndarray | tuple[np.ndarray, np.ndarray]: ...

    def held_input_generator(self, p: PlantParams, t: np.ndarray) -> np.ndarray: ...
