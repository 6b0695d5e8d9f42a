"""The tasks as pure JAX functions: gymnax's ``Environment`` over an explicit state pytree.

The task's matrices and tables come from the same NumPy/SciPy code the Numba core uses (the
:class:`~sail_env.core.spec.EpisodeSpec` built from the same keywords), handed over once as the
arrays of :class:`EnvParams`; this module holds only the episode logic of
:mod:`sail_env.core.kernels` and :mod:`sail_env.core.episode`: the clip and scale of the action, the
command ring and the light delay, the beam jitter, the push noise and the random impacts of each step,
the constant drive (a payload off the axis), the divergence rule, the envelope, the reward, the
termination, the (delayed, noisy) observation, the commands still in flight after the window, and the
coast and scoring at cut-off. Every function works on one environment; ``jax.vmap`` batches them (over
states, and over params for per-environment tasks). The logic is the linear plant's, whatever the sail
model: the planar tasks, ``LightSail3D-v0``, the realistic 3D tasks and the uncertain ones (:data:`~sail_env.tasks.JAX_TASKS`);
:func:`bank_of` refuses, by name, what it does not carry yet (power control).

**Randomness.** The public ``reset``/``step`` draw from their keys: at reset the parameter draw,
the cut-off time, the launch state and the pre-control noise (:class:`EpisodeStart`); at each step
that step's normals (:class:`StepNoise`). :meth:`SailEnv.reset_from` and
:meth:`SailEnv.advance` take those draws as inputs instead: fed the Numba core's draws, both
backends play the same episodes (``tests/jax/test_same_draws.py``).

**Parameter spread** (``LightSailRealistic-v0``'s ±10 %). Each parameter draw changes the step's
matrix exponentials, the look-ahead table and the moment generators. Built per reset inside JAX
they would cost ~100 times a step, and gymnax's autoreset builds a reset at every step; so the
task's NumPy code builds them once for a bank of :data:`DRAWS` draws of the same distribution
(``draws=`` in :func:`~sail_env.jax.make`), and a reset picks one uniformly. An episode's other
draws (cut-off, launch, noise) are continuous, as the Numba core's.

**The noisy coast** (one piece: the realistic planar task's coast grows less than e^20 over its length,
checked at construction) is the Numba core's: the exact second moments of the state under the push noise and
the beam jitter with the last command held, then a Gaussian draw by the symmetric root of the
correlation. The moment generator depends on the held command; the bank holds, per draw, the
generator of every held input at once (:func:`~sail_env.physics.noise.held_input_generator`), reduced
to the episode's input at its end.

**Along the flight** (the realistic 3D tasks: the relativistic push, the spot widening beyond ``L0``, the
ground jitter growing with the distance, the dust with the speed) the model changes over the coast, and
both the pre-control flight and the coast to cut-off go piece by piece as the plant's do
(:mod:`sail_env.jax.along`: each piece's model, generator and exponential built in JAX from the plant's
tables). The window's steps are the Numba core's operation for operation, but each backend's coast is its
own exponential of each piece, so these episodes agree to ~1e-7, not to the bit
(``tests/jax/test_same_draws.py``).
"""

from __future__ import annotations

import functools
from typing import Any

import jax
import jax.numpy as jnp
import jax.scipy.linalg
import numpy as np
from flax import struct
from gymnax.environments import environment, spaces

from sail_env.core.episode import OBSERVATION_LIMIT
from sail_env.core.reward import DIVERGENCE_PENALTY, SUCCESS_BONUS, succeeded
from sail_env.core.spec import EpisodeSpec, check_expected_paths
from sail_env.jax import along as along_module
from sail_env.jax.along import AlongFlight, Coast, along_of
from sail_env.jax.arith import divide, log_ratio, ordered_dot
from sail_env.jax.fast_coast import FAST_DRAWS, FastCoast, fast_coast, fast_coast_of, fast_launch
from sail_env.physics.linear import sample_gaussian
from sail_env.physics.noise import balancing, held_input_maps, mean_and_covariance, second_moment

#: Parameter draws a task with spread holds (:func:`params_of`'s ``draws``): 4,096 draws cover
#: ``LightSailRealistic-v0``'s box of five factors finely (the success rate of a fixed controller over
#: them matches the continuous draw's within its interval: ``tests/jax/test_samplers.py``).
DRAWS = 4096
#: The bank's NumPy generator seed: a task's bank is the same on every machine.
BANK_SEED = 0
#: Most squarings of the coast's matrix exponential (``jax.scipy.linalg.expm`` returns NaN beyond its
#: limit, 16 by default): the realistic coast's generator has a 1-norm of ~5e5, 16.5 squarings;
#: :func:`bank_of` checks that every draw's, with any command held, stays within this limit. Under
#: ``vmap`` every squaring up to the limit is computed, so it is not set higher than needed.
MAX_SQUARINGS = 20
#: Environments :meth:`SailEnv.step_batch` coasts or resets together (:func:`_on_rows`), by JAX platform.
#: A chunk costs its full size however few of its rows need the work, so on a CPU a small chunk wastes
#: least when a few episodes end on a step, as in training once the episodes' ends drift apart: 8 against
#: 256 on ``LightSailUncertain-v2`` at N = 256 under the LQR, on one core, 10x as many env-steps/s with
#: the ends spread over the window, 19x with every episode started together (``benchmarks/gather_chunk.py``).
#: An accelerator runs a chunk's rows side by side: 256 there (not measured against other sizes).
CHUNK = {"cpu": 8}
ACCELERATOR_CHUNK = 256
#: The coasts a JAX env plays (``coast=``): the default, the Numba core's piece by piece; ``fast``, each draw's
#: pieces built once (:mod:`sail_env.jax.fast_coast`), the same in law.
COASTS = ("default", "fast")
#: The terminal rewards (``terminal_reward=``): the sampled coast's, or its mean over ``expected_paths`` coasts.
TERMINAL_REWARDS = ("sampled", "expected")
#: θ₁₃ of the Padé approximant ``jax.scipy.linalg.expm`` uses: it squares ``log2(‖A‖₁ / θ₁₃)`` times.
_PADE13_THETA = 5.371920351148152


@struct.dataclass
class EnvState(environment.EnvState):
    """One episode (SI units). ``time`` counts the control steps taken (gymnax's field)."""

    x: jax.Array  # (n,) the true state
    last_command: jax.Array  # (m,) the beam input sent at the last step, held over the coast
    reward: jax.Array  # the last step's reward
    envelope: jax.Array  # the last step's envelope: largest |V⊥|/Vz with the applied input held [rad]
    terminated: jax.Array  # the last step ended the episode
    diverged: jax.Array  # the sail left the beam (in the window or the coast)
    pointing: jax.Array  # the flight direction at cut-off [rad]: NaN before the end, inf after a divergence
    draw: jax.Array  # the episode's parameter draw: its row of the params' bank (0 without spread)
    cutoff: jax.Array  # the episode's beam cut-off time [s]
    speed: jax.Array  # the axial speed at that cut-off [m/s]: what the envelope and the pointing divide by
    commands: jax.Array  # (C, m) ring of the sent commands, step s's at s % C (C = 1 without light delay)
    states: jax.Array  # (S, n) ring of true states, step s's at (s + lag0) % S (the delayed observation's source)
    sensor: jax.Array  # (n,) the standard normals of the current observation's sensor noise
    #: The probability of success given the window's end, estimated over the score's paths (``expected_paths``
    #: of :func:`~sail_env.jax.make`): NaN before the end or without paths, 0 after a divergence in the window.
    expected_success: jax.Array


@struct.dataclass
class EpisodeStart:
    """An episode's draws at reset: what :meth:`SailEnv.reset_from` takes (the Numba core's
    draws, in the cross-backend tests)."""

    launch: jax.Array  # (n,) the launch state
    draw: jax.Array  # row of the params' bank
    cutoff: jax.Array  # the beam cut-off time [s]
    pre_coast: jax.Array  # (Q, n) normals of the coast's pieces from launch to the first pre-control step
    pre_steps: jax.Array  # (D, J + 1 + r) normals of the pre-control steps: beam jitter (J), push, impacts (r)
    pre_counts: jax.Array  # (D,) the pre-control steps' impact counts
    sensor: jax.Array  # (n,) normals of the first observation's sensor noise


@struct.dataclass
class StepNoise:
    """One step's standard normals: what :meth:`SailEnv.advance` takes."""

    jitter: jax.Array  # (J,) the beam offsets' of this step
    push: jax.Array  # the push's of this step
    impacts: jax.Array  # (r,) the impacts' kicks of this step, one per kicked row
    count: jax.Array  # this step's number of impacts
    sensor: jax.Array  # (n,) the next observation's sensor noise
    in_flight: jax.Array  # (D + 2, J + 1 + r) the steps after the window while commands are in flight
    in_flight_counts: jax.Array  # (D + 2,) their impact counts
    coast: jax.Array  # (P, n) the coast's draws, one per piece
    #: (K, P, n) the draws of the score's K further coasts (``expected_paths``); None without them
    paths: jax.Array | None = None


@struct.dataclass
class EnvParams:
    """A task's arrays, built by the NumPy/SciPy physics (:func:`params_of`); ``vmap`` over a batch
    of them gives each environment its own task. The first axis of the per-draw arrays is the bank of
    parameter draws (one row without spread). (gymnax's ``EnvParams`` is not the base: its field with
    a default would have to come first.)"""

    # per parameter draw (K, ...)
    step_matrix: jax.Array  # (K, P·n, c): the exact control step, rows of [Φ Γ] per power of the push error ε
    envelope: jax.Array  # (K, c, S): the look-ahead table of the lateral speed, transposed
    limits: jax.Array  # (K, G): the divergence groups' limits
    acceleration: jax.Array  # (K,): axial acceleration [m/s²]
    speed_at_cutoff: jax.Array  # (K,): the axial speed at the nominal cut-off [m/s] (the plant's flight law)
    jitter_std: jax.Array  # (K, W): the beam offset's standard deviation [m] in each noise step (step + lag0)
    impact_rate: jax.Array  # (K,): the impacts' rate [1/s] in the window
    impact_std: jax.Array  # (K, r): one impact's kick on each kicked row (SI rates)
    delay: jax.Array  # (K, T): one-way light delay [steps] at each control step (zeros without delay)
    launch_phi: jax.Array  # (K, n, n) noise-free tasks: launch to the start of control; noisy: (K, 0, 0)
    pre_propagator: jax.Array  # (K, h, h) noisy tasks: the pre-control coast's second-moment propagator
    coast_phi: jax.Array  # (K, n, n) noise-free tasks: one coast piece's propagator
    coast_gamma: jax.Array  # (K, n, m) noise-free tasks: one coast piece's input matrix
    coast_generator: jax.Array  # (K, h, h') noisy tasks: the held-input moment generator, its rows of (s, 1)
    # per task
    action_scale: jax.Array  # (m,): the beam input at action +1
    state_scale: jax.Array  # (n,): divides the state in the observation
    start_half_widths: jax.Array  # (n,): the uniform launch box
    sensor_std: jax.Array  # (n,): the sensor noise's standard deviation
    push_noise: jax.Array  # the push's relative standard deviation per step
    into_units: jax.Array  # (h, h) and back: the moment propagator's exact change of units
    from_units: jax.Array
    control_start_s: jax.Array
    dt: jax.Array
    beam_cutoff_s: jax.Array
    cutoff_jitter_s: jax.Array
    #: (K, F): each draw's parameter factors, the plant's ``spread_fields`` in order (multiples of the
    #: nominal; a beam offset's factor 1 ± 1 spans its range). No episode reads them: they say what
    #: each row of the bank is, which a learner's privileged critic sees in training (agents/jax_ppo.py).
    factors: jax.Array
    #: A model that changes along the flight (:mod:`sail_env.jax.along`): its tables and per-draw arrays.
    along: AlongFlight | None = None
    #: Each draw's coast pieces built once (``coast="fast"``, :mod:`sail_env.jax.fast_coast`); None: the default coast.
    fast: FastCoast | None = None
    max_steps_in_episode: int = struct.field(pytree_node=False, default=200)
    #: Pieces of a noise-free coast to cut-off (divergence is checked after each): static, so that the
    #: coast unrolls (one matrix product for a stable sail) instead of a loop of data-dependent length.
    #: Along the flight: the most pieces any coast to cut-off takes (the draws' normals per episode).
    coast_pieces: int = struct.field(pytree_node=False, default=1)
    #: The most pieces of the coast from launch to the first pre-control step.
    pre_pieces: int = struct.field(pytree_node=False, default=1)
    #: What the env's functions are compiled for (:func:`variant_of`): params of another variant are refused.
    #: A noise the env was not made with is not drawn, so the arrays that size it (``sensor_std``,
    #: ``push_noise``, ``cutoff_jitter_s``) do nothing there: make the env with the keyword instead.
    variant: tuple = struct.field(pytree_node=False, default=())


def params_of(spec: EpisodeSpec, dtype: jnp.dtype = jnp.float64, draws: int = DRAWS) -> EnvParams:
    """The :class:`EnvParams` of a task's spec, its arrays (and so the episode's arithmetic)
    in ``dtype``: float64 is the Numba core's; float32 is faster on accelerators, its error measured
    in ``tests/jax/test_same_draws.py`` and docs/performance.md. With parameter spread, a bank of
    ``draws`` draws (generator seed :data:`BANK_SEED`)."""
    plant, dist = spec.plant, spec.randomisation
    if draws < 1:
        raise ValueError(f"draws must be >= 1, got {draws}")
    factors = plant.factors(np.random.default_rng(BANK_SEED).random((draws if dist.parameter_spread else 1,
                                                                     plant.n_draws)))
    return bank_of(spec, factors, dtype)


def bank_of(spec: EpisodeSpec, factors: np.ndarray, dtype: jnp.dtype = jnp.float64) -> EnvParams:
    """:func:`params_of` with the bank of the given parameter factors (K, n_factors): the Numba core's
    draws, in the cross-backend tests."""
    plant, dist = spec.plant, spec.randomisation
    along_flight = plant.time_varying and plant.flight_model(plant.params(factors[:1])) is not None
    unsupported = [name for name, on in (("power control", "beam_power" in plant.input_names),
                                         ("a coast along the flight without noise",
                                          plant.time_varying and not plant.noisy),
                                         ("a coast along the flight the plant does not hand over (its flight_model)",
                                          plant.time_varying and not along_flight),
                                         ("light delay without noise", spec.light_delay and not plant.noisy),
                                         ("cutoff_jitter_s without noise", dist.cutoff_jitter_s and not plant.noisy),
                                         ("parameter_spread without noise", dist.parameter_spread and not plant.noisy))
                   if on]
    if unsupported:
        raise ValueError(f"the JAX backend does not carry {', '.join(unsupported)} yet: it has the tasks of "
                         f"sail_env.tasks.JAX_TASKS")
    p = plant.params(factors)  # shared (one row) without spread
    k, n, m = len(p.acceleration), plant.n_states, plant.n_inputs
    config = spec.config
    cutoff, window_end = config.beam_cutoff_s, config.control_start_s + spec.n_steps * spec.dt
    _, _, delay_length = spec.ring_lengths
    delay = spec.delay_steps(np.arange(max(delay_length, 1)), p.acceleration[:, None]) * np.ones((k, 1), np.int64)
    lag0 = delay[:, 0]
    pre_control = config.control_start_s - lag0 * spec.dt
    longest = np.full(k, cutoff + dist.cutoff_jitter_s - window_end)  # the latest cut-off, no command in flight
    h = (n + 1) * (n + 2) // 2
    empty = np.zeros((k, 0, 0))
    along, pre_pieces = None, 1
    launch_phi = coast_phi = coast_gamma = empty
    pre_propagator, coast_generator = np.zeros((k, h, h)), np.zeros((k, h, 0))
    if plant.time_varying:  # piece by piece along the flight (sail_env.jax.along)
        model = plant.flight_model(p)
        latest = cutoff + dist.cutoff_jitter_s
        along = along_of(model, dtype, latest)
        pieces = int(plant.coast_pieces(p, longest).max())
        _check_along_squarings(plant, spec, model, along_of(model, jnp.float64, latest),
                               float((longest / pieces).max()))
        pre_pieces = int(plant.coast_pieces(p, pre_control).max())
    elif plant.noisy:
        # The longest coast must be one piece, as the JAX coast of a fixed model is.
        if np.any(plant.coast_pieces(p, longest) > 1) or np.any(plant.coast_pieces(p, pre_control) > 1):
            raise ValueError("the JAX backend coasts a noisy sail in one piece; this task's sail grows too fast "
                             "over its coast (an unstable or parametrically excited sail)")
        pre_propagator = plant.piece_propagators(p, np.zeros((k, m)), np.zeros(k), pre_control)
        pick = held_input_maps(n, m)[0]
        # The noise's intensity at the coast's middle (constant for the planar landing jitter).
        generator = plant.held_input_generator(p, np.full(k, 0.5 * (window_end + cutoff)))
        coast_generator = pick @ generator
        _check_squarings(plant, spec, p, generator, longest)
        pieces = 1
    else:
        remaining = max(cutoff - window_end, 0.0)
        pieces = int(plant.coast_pieces(p, np.array([remaining]))[0])
        coast_phi, coast_gamma = (matrix[None] for matrix in plant.nominal.discretize(remaining / pieces))
        pre = config.control_start_s
        launch_phi = (plant.nominal.discretize(pre)[0] if pre > 0 else np.eye(n))[None]
    if dist.cutoff_jitter_s and along is None:  # the episode's speed at its cut-off is then a t: Newton's
        for time in (cutoff - dist.cutoff_jitter_s, cutoff + dist.cutoff_jitter_s):
            if not np.array_equal(plant.speed(p, np.full(k, time)), p.acceleration * time):
                raise ValueError("the JAX backend does not carry cutoff_jitter_s on a flight that is not Newtonian "
                                 "without the flight's table")
    into, back = balancing(plant.start_limits())
    # Each noise step's beam jitter (column c acts from control_start + (c − lag0) dt), as the core's reset.
    columns = np.arange(spec.n_steps + 2 * spec.max_delay + 2)
    middles = config.control_start_s + (columns - lag0[:, None] + 0.5) * spec.dt
    std = plant.jitter_std(p, middles)
    jitter = (np.reshape(std, (k, -1)) if np.ndim(std) else std) * np.ones((k, len(columns)))
    impact_rate, impact_std = np.zeros(k), np.zeros((k, 0))
    if plant.impulse_rows:
        impact_rate, impact_std = plant.impact_rate_and_std(p, np.full(k, spec.window_middle_s))

    def array(values: Any) -> jax.Array:
        return jnp.asarray(values, dtype=dtype)

    return EnvParams(
        step_matrix=array(p.step), envelope=array(np.swapaxes(p.envelope, 1, 2)), limits=array(p.limits),
        acceleration=array(p.acceleration), speed_at_cutoff=array(plant.speed(p, np.full(k, cutoff))),
        jitter_std=array(jitter), impact_rate=array(impact_rate), impact_std=array(impact_std),
        delay=jnp.asarray(delay, jnp.int32), launch_phi=array(launch_phi),
        pre_propagator=array(pre_propagator), coast_phi=array(coast_phi), coast_gamma=array(coast_gamma),
        coast_generator=array(coast_generator), action_scale=array(spec.action_scale),
        state_scale=array(spec.state_scale), start_half_widths=array(spec.start_half_widths),
        sensor_std=array(spec.sensor_noise_std), push_noise=array(dist.push_noise), into_units=array(into),
        from_units=array(back), control_start_s=array(config.control_start_s), dt=array(spec.dt),
        beam_cutoff_s=array(cutoff), cutoff_jitter_s=array(dist.cutoff_jitter_s), factors=array(factors), along=along,
        max_steps_in_episode=spec.n_steps, coast_pieces=pieces, pre_pieces=pre_pieces, variant=variant_of(spec))


def variant_of(spec: EpisodeSpec) -> tuple[tuple[str, object], ...]:
    """The choices of a task that decide what its JAX functions compute (each with its keyword's name):
    the params of one variant play on the env of another only where these agree. The sizes within a
    variant (how strong a noise is) are arrays of the params, and may change."""
    plant, dist = spec.plant, spec.randomisation
    return (("light_delay", spec.light_delay), ("sensor_noise_std", dist.any_sensor_noise),
            ("push_noise", bool(dist.push_noise)), ("cutoff_jitter_s", bool(dist.cutoff_jitter_s)),
            ("parameter_spread", bool(dist.parameter_spread)), ("noisy coast", plant.noisy),
            ("beam jitter", tuple(plant.jitter_inputs) if plant.jittered else ()),
            ("impacts", tuple(plant.impulse_rows)), ("states", plant.n_states), ("inputs", plant.n_inputs),
            ("steps", spec.n_steps), ("delay steps", spec.max_delay))


def arrived_command(step: jax.Array, delay: jax.Array, newest: jax.Array | int) -> jax.Array:
    """:func:`sail_env.core.delay.arrived_command` in JAX: the index of the command acting during
    ``step`` (one-way delay ``delay`` steps), at most ``newest``; negative before any has arrived."""
    return jnp.minimum(step - delay, newest)


def _on_rows(need: jax.Array, function: Any, inputs: tuple) -> Any:
    """``vmap(function)(*inputs)`` where ``need`` (N,), its outputs elsewhere zero: the rows that need
    it gathered :data:`CHUNK` at a time (the last chunk padded with row 0, whose value is written
    again unchanged), as many chunks as ``need`` has rows: none on most steps of a batch whose
    episodes end together."""
    envs = need.shape[0]
    if envs == 0:  # an empty batch: nothing to compute (the chunk's size would be zero)
        return jax.tree.map(lambda leaf: jnp.zeros(leaf.shape, leaf.dtype), jax.eval_shape(jax.vmap(function), *inputs))
    chunk = min(envs, CHUNK.get(jax.default_backend(), ACCELERATOR_CHUNK))
    rows = jnp.nonzero(need, size=-(-envs // chunk) * chunk, fill_value=0)[0]
    count = jnp.sum(need)
    batched = jax.vmap(function)
    template = jax.tree.map(lambda leaf: jnp.zeros((envs, *leaf.shape[1:]), leaf.dtype),
                            jax.eval_shape(batched, *inputs))

    def one(carry: tuple[jax.Array, Any]) -> tuple[jax.Array, Any]:
        start, out = carry
        # Tied to the loop's counter: with one chunk (N <= the chunk) the slice is the whole array, and XLA
        # would hoist the work out of the loop and do it on every step (measured: a 3D coast per step).
        taken, _ = jax.lax.optimization_barrier((jax.lax.dynamic_slice(rows, (start,), (chunk,)), start))
        done = batched(*jax.tree.map(lambda leaf: leaf[taken], inputs))
        return start + chunk, jax.tree.map(lambda whole, part: whole.at[taken].set(part), out, done)

    return jax.lax.while_loop(lambda carry: carry[0] < count, one, (jnp.zeros((), rows.dtype), template))[1]


def _box_commands(spec: EpisodeSpec, m: int) -> np.ndarray:
    """The beam commands (2^m + 1, m) at the action box's corners and its centre: where a coast's exponential
    is checked (its generator is a polynomial of degree 2 in the held command)."""
    corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * m)).reshape(m, -1).T
    return np.vstack([corners, np.zeros(m)]) * spec.action_scale


def _check_squarings(plant: Any, spec: EpisodeSpec, p: Any, generator: np.ndarray, longest: np.ndarray) -> None:
    """Refuse a bank whose coast needs more than :data:`MAX_SQUARINGS` − 1 squarings of its
    exponential with a command held at a corner or the centre of the action box. The generator's
    entries are polynomials of degree 2 in the command, dominated by the sail's own dynamics, and
    the one squaring of margin covers a norm twice as large."""
    n, m = plant.n_states, plant.n_inputs
    pick, lift0, lift1, lift2 = held_input_maps(n, m)
    into, _ = balancing(plant.start_limits())
    worst = 0.0
    for corner in _box_commands(spec, m):
        lift = lift0 + np.tensordot(corner, lift1, 1) + np.tensordot(np.outer(corner, corner), lift2, 2)
        coast = (pick @ generator @ lift) * (longest[:, None, None] * into)
        worst = max(worst, float(np.abs(coast).sum(axis=-2).max()))
    if np.log2(worst / _PADE13_THETA) > MAX_SQUARINGS - 1:
        raise ValueError(f"the JAX backend's coast exponential would need {np.log2(worst / _PADE13_THETA):.1f} "
                         f"squarings (at most {MAX_SQUARINGS - 1} with a margin): this task's coast is too long")


def _check_along_squarings(plant: Any, spec: EpisodeSpec, model: Any, along: AlongFlight, piece_s: float) -> None:
    """Refuse a bank whose coast pieces (``piece_s`` long at most) need more than
    :data:`~sail_env.jax.along.MAX_SQUARINGS` − 1 squarings of their exponential (``along.expm`` gives NaN
    beyond its squarings, which would end the episode as a divergence): the pieces' own generators
    (:meth:`~sail_env.jax.along.Coast.generator`) for the 32 draws of the fastest dynamics, from the start of
    control to the latest cut-off, with the commands at the action box's corners and centre."""
    m = plant.n_inputs
    fastest = np.argsort(np.abs(model.window_a).sum(axis=1).max(axis=1))[-32:]
    corners = _box_commands(spec, m)
    latest = spec.config.beam_cutoff_s + spec.randomisation.cutoff_jitter_s
    times = np.array([spec.config.control_start_s, spec.window_middle_s, 0.5 * (spec.window_middle_s + latest), latest])
    grid = np.meshgrid(fastest, np.arange(len(corners)), times, indexing="ij")
    d, corner, t = (a.ravel() for a in grid)
    into, _ = balancing(plant.start_limits())
    generators = jax.vmap(Coast(plant, model).generator, in_axes=(None, 0, 0, 0))(
        along, jnp.asarray(d), jnp.asarray(corners[corner]), jnp.asarray(t))
    worst = float(np.abs(np.asarray(generators) * (piece_s * into)).sum(axis=-2).max())
    needed = np.log2(worst / along_module.THETA13)
    if needed > along_module.MAX_SQUARINGS - 1:
        raise ValueError(f"the JAX backend's coast pieces would need {needed:.1f} squarings of their exponential "
                         f"(at most {along_module.MAX_SQUARINGS - 1} with a margin): this task's sail is too fast "
                         f"for its {piece_s:.3g} s pieces")


class SailEnv(environment.Environment[EnvState, EnvParams]):
    """A light-sail task in gymnax's API (``reset(key, params)``, ``step(key, state,
    action, params)`` with autoreset, the spaces); :func:`sail_env.jax.make` builds one.

    The episode is the Numba core's (:mod:`sail_env.core.kernels`, :mod:`sail_env.core.episode`):
    fed the same draws, both give the same episodes (``tests/jax/test_same_draws.py``: observations
    to the bit on a CPU under the XLA flag of :mod:`sail_env.jax.arith`, rewards within 1e-12,
    terminal pointing within 1e-9, after a noisy coast within 1e-8 or 1e-16 rad; along the flight,
    everything within 1e-6, measured 2e-7). At an episode's end ``info`` carries the
    Gym envs' scores: ``is_success``, ``terminal_pointing_rad`` (NaN before the end, inf after a
    divergence) and ``diverged``.
    """

    def __init__(self, spec: EpisodeSpec, env_id: str = "LightSail", dtype: jnp.dtype = jnp.float64,
                 draws: int | None = None, coast: str = "default", expected_paths: int = 0,
                 terminal_reward: str = "sampled") -> None:
        super().__init__()
        plant, dist = spec.plant, spec.randomisation
        if coast not in COASTS:
            raise ValueError(f"coast must be one of {', '.join(COASTS)}, got {coast!r}")
        if coast == "fast" and not plant.time_varying:
            raise ValueError("coast='fast' is for the tasks whose coast follows the flight (the realistic 3D and "
                             "uncertain tasks); this task's coast is one piece already")
        expected_paths = check_expected_paths(expected_paths)
        if terminal_reward not in TERMINAL_REWARDS:
            raise ValueError(f"terminal_reward must be one of {', '.join(TERMINAL_REWARDS)}, got {terminal_reward!r}")
        if terminal_reward == "expected" and not expected_paths:
            raise ValueError("terminal_reward='expected' averages the score over paths: give expected_paths >= 1")
        #: The score's further coasts from the window's end, and whether the terminal reward is their mean.
        self.expected_paths, self.expected_reward = int(expected_paths), terminal_reward == "expected"
        if draws is None:
            draws = FAST_DRAWS if coast == "fast" else DRAWS
        self.spec = spec  # what controllers design on, as the Gym envs' ``episode_spec``
        self._id = env_id
        self.n_states, self.n_inputs = plant.n_states, plant.n_inputs
        self.observation_size = spec.observation_size
        self.divergence_groups = plant.divergence_groups
        self.velocity_rows = plant.velocity_rows
        self.jitter_inputs = tuple(plant.jitter_inputs) if plant.jittered else ()
        self.delayed, self.noisy, self.sensed = spec.light_delay, plant.noisy, dist.any_sensor_noise
        self.pushed = bool(dist.push_noise)
        self.jittered_cutoff = bool(dist.cutoff_jitter_s)
        #: Whether an episode draws more than its launch (parameters, cut-off, noise).
        self.randomised = bool(self.noisy or self.sensed or dist.parameter_spread or dist.cutoff_jitter_s)
        self.max_delay, self.history = spec.max_delay, spec.history_length
        self.command_ring, self.state_ring, _ = spec.ring_lengths
        # The step's and the envelope's constant term (its input 1): a last column of B.
        self.biased = plant.with_bias(np.zeros((1, self.n_inputs))).shape[1] > self.n_inputs
        self.impulse_rows = tuple(plant.impulse_rows)
        self._params = params_of(spec, dtype, draws)  # first: it refuses, by name, what the backend lacks
        self.variant = self._params.variant
        #: The coast of a model that changes along the flight (None: one fixed model).
        self.along = Coast(plant, plant.flight_model(plant.params(np.ones((1, plant.n_factors))))) if (
            plant.time_varying) else None
        if coast == "fast":
            self._params = self._with_fast_coast(self._params)

    def _with_fast_coast(self, params: EnvParams) -> EnvParams:
        """``params`` with each draw's coast pieces built (:func:`~sail_env.jax.fast_coast.fast_coast_of`),
        from each draw's coast start to the latest cut-off."""
        draws = params.acceleration.shape[0]
        start = np.asarray(jax.jit(jax.vmap(lambda d: self._coast_start(params, d)))(jnp.arange(draws)), np.float64)
        scale = np.asarray(self.spec.action_scale, np.float64)
        units = np.concatenate([self.spec.plant.start_limits(), np.where(scale > 0, scale, 1.0)])
        cutoff, jitter = float(params.beam_cutoff_s), float(params.cutoff_jitter_s)
        pre_control = np.asarray(params.control_start_s - params.delay[:, 0] * params.dt, np.float64)
        fast = fast_coast_of(self.along, params.along, start, (cutoff - jitter, cutoff + jitter), units, pre_control,
                             params.pre_pieces, params.into_units, params.from_units)
        return params.replace(fast=fast, coast_pieces=max(params.coast_pieces, fast.maps.shape[1] + 1))

    @property
    def name(self) -> str:
        return self._id

    @property
    def default_params(self) -> EnvParams:
        return self._params

    @property
    def num_actions(self) -> int:
        return self.n_inputs

    def action_space(self, params: EnvParams | None = None) -> spaces.Box:
        return spaces.Box(-1.0, 1.0, (self.n_inputs,), jnp.float32)

    def observation_space(self, params: EnvParams | None = None) -> spaces.Box:
        return spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT, (self.observation_size,), jnp.float32)

    # ------------------------------------------------------------------ draws
    def draw_start(self, key: jax.Array, params: EnvParams, launch: jax.Array | None = None) -> EpisodeStart:
        """An episode's draws (:class:`EpisodeStart`): the launch state uniformly in
        ``params.start_half_widths`` (unless given), and where the task has them the parameter draw (a
        row of the bank), the cut-off within its jitter and the pre-control noise. A task without them
        spends ``key`` on the launch alone."""
        half, dtype = params.start_half_widths, params.start_half_widths.dtype
        n, impacts = self.n_states, len(self.impulse_rows)
        pre_shape = (self.max_delay, len(self.jitter_inputs) + 1 + impacts)
        keys = jax.random.split(key, 7 if self.impulse_rows else 6) if self.randomised else [key]
        if launch is None:
            launch = -half + (half - -half) * jax.random.uniform(keys[0], half.shape, dtype=dtype)
        if not self.randomised:
            zeros = jnp.zeros(n, dtype)
            return EpisodeStart(launch=launch, draw=jnp.zeros((), jnp.int32), cutoff=params.beam_cutoff_s,
                                pre_coast=jnp.zeros((params.pre_pieces, n), dtype),
                                pre_steps=jnp.zeros(pre_shape, dtype), pre_counts=jnp.zeros(self.max_delay, dtype),
                                sensor=zeros)
        jitter = params.cutoff_jitter_s
        u_cut = jax.random.uniform(keys[2], (), dtype=dtype)
        draw = jax.random.randint(keys[1], (), 0, params.acceleration.shape[0])
        return EpisodeStart(
            launch=launch, draw=draw, cutoff=params.beam_cutoff_s + (-jitter + (jitter - -jitter) * u_cut),
            pre_coast=jax.random.normal(keys[3], (params.pre_pieces, n), dtype),
            pre_steps=jax.random.normal(keys[4], pre_shape, dtype),
            pre_counts=self._impact_counts(keys[6], params, draw, (self.max_delay,)),
            sensor=jax.random.normal(keys[5], (n,), dtype))

    def _impact_counts(self, key: jax.Array, params: EnvParams, draw: jax.Array, shape: tuple[int, ...]) -> jax.Array:
        """Poisson numbers of impacts in steps of ``shape`` at draw ``draw``'s window rate (zeros without
        impacts; no key spent)."""
        dtype = params.impact_rate.dtype
        if not self.impulse_rows:
            return jnp.zeros(shape, dtype)
        return jax.random.poisson(key, params.impact_rate[draw] * params.dt, shape).astype(dtype)

    def draw_noise(self, key: jax.Array, params: EnvParams, draw: jax.Array | int = 0) -> StepNoise:
        """One step's normals (:class:`StepNoise`) for an episode of parameter draw ``draw``, zero where
        the task has no such noise (no key is spent on a noise-free task): the window step's from one
        half of ``key``, those of an episode's end (the commands in flight, the coast) from the other."""
        step_key, end_key = jax.random.split(key)
        return self._with_end_noise(self._step_noise(step_key, params, draw), end_key, params, draw)

    def _step_noise(self, key: jax.Array, params: EnvParams, draw: jax.Array | int = 0) -> StepNoise:
        """The window step's normals (beam jitter, push, impacts, sensor) in one draw, its impact count
        from the other half of ``key``; the end's left zero."""
        dtype, jittered, n, impacts = params.state_scale.dtype, len(self.jitter_inputs), self.n_states, len(
            self.impulse_rows)
        size = jittered + 1 + impacts + n
        normal_key, count_key = jax.random.split(key)
        normals = jax.random.normal(normal_key if impacts else key, (size,), dtype) if self.randomised else (
            jnp.zeros(size, dtype))
        plant_noise = jittered + 1 + impacts
        return StepNoise(jitter=normals[:jittered], push=normals[jittered], impacts=normals[jittered + 1:plant_noise],
                         count=self._impact_counts(count_key, params, draw, ()), sensor=normals[plant_noise:],
                         in_flight=jnp.zeros((self.max_delay + 2, plant_noise), dtype),
                         in_flight_counts=jnp.zeros(self.max_delay + 2, dtype),
                         coast=jnp.zeros((params.coast_pieces, n), dtype))

    def _with_end_noise(self, noise: StepNoise, key: jax.Array, params: EnvParams,
                        draw: jax.Array | int = 0) -> StepNoise:
        """``noise`` with the normals of an episode's end drawn from ``key`` (in one draw; the impact
        counts of the steps in flight from the other half of it)."""
        if not self.randomised:
            return noise
        flight, coast = noise.in_flight.shape, noise.coast.shape
        normal_key, count_key = jax.random.split(key) if self.impulse_rows else (key, key)
        normals = jax.random.normal(normal_key, (flight[0] * flight[1] + coast[0] * coast[1],),
                                    params.state_scale.dtype)
        split = flight[0] * flight[1]
        # The score's paths from a key of their own: the episode's draws are those without them.
        paths = jax.random.normal(jax.random.fold_in(key, 1), (self.expected_paths, *coast), noise.coast.dtype) if (
            self.expected_paths) else None
        return noise.replace(in_flight=normals[:split].reshape(flight), coast=normals[split:].reshape(coast),
                             in_flight_counts=self._impact_counts(count_key, params, draw, (flight[0],)), paths=paths)

    # ------------------------------------------------------------------ reset
    def reset_env(self, key: jax.Array, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """A new episode from the draws of :meth:`draw_start`."""
        return self.reset_from(self.draw_start(key, params), params)

    def reset_from(self, start: EpisodeStart, params: EnvParams) -> tuple[jax.Array, EnvState]:
        """An episode from given draws (:class:`EpisodeStart`): the launch propagated to the start of
        control (beam off; with light delay, the last ``lag0`` steps one by one, kept for the delayed
        observations). The same-draws entry the cross-backend tests feed both backends through."""
        self._check_params(params)
        d, n, dtype = start.draw, self.n_states, params.state_scale.dtype
        if self.along is not None:  # piece by piece along the flight from launch, beam off
            pre_control = params.control_start_s - params.delay[d, 0].astype(dtype) * params.dt
            if params.fast is not None:
                x, _ = fast_launch(params.fast, d, start.launch, start.pre_coast,
                                   lambda state: self._diverged(state, params.limits[d]))
            else:
                x, _ = self._coast_along(params, d, start.launch, jnp.zeros(self.n_inputs, dtype),
                                         jnp.zeros((), dtype), pre_control, start.pre_coast)
            x = jnp.where(pre_control > 0, x, start.launch)
        elif self.noisy:
            x = self._sample(params.pre_propagator[d] @ self._moments(start.launch), start.pre_coast[0])
        else:
            x = ordered_dot(params.launch_phi[d], start.launch)
        states = jnp.zeros((self.state_ring, n), dtype).at[0].set(x)
        if self.delayed:
            lag0 = params.delay[d, 0]

            def pre_step(s: int, carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
                x, states = carry
                moved = self._physics(params, d, x, jnp.zeros(self.n_inputs, dtype), start.pre_steps[s],
                                      start.pre_counts[s], s)
                active = s < lag0
                x = jnp.where(active, moved, x)
                return x, jnp.where(active, states.at[(s + 1) % self.state_ring].set(moved), states)

            x, states = jax.lax.fori_loop(0, self.max_delay, pre_step, (x, states))
        zero = jnp.zeros((), dtype)
        state = EnvState(time=jnp.zeros((), jnp.int32), x=x, last_command=jnp.zeros(self.n_inputs, dtype),
                         reward=zero, envelope=zero, terminated=jnp.array(False), diverged=jnp.array(False),
                         pointing=jnp.full((), jnp.nan, dtype), draw=jnp.asarray(d, jnp.int32),
                         cutoff=jnp.asarray(start.cutoff, dtype), speed=self._speed_at(params, d, start.cutoff),
                         commands=jnp.zeros((self.command_ring, self.n_inputs), dtype), states=states,
                         sensor=jnp.asarray(start.sensor, dtype), expected_success=jnp.full((), jnp.nan, dtype))
        return self.observe_state(state, params), state

    # ------------------------------------------------------------------ step
    def step_env(self, key: jax.Array, state: EnvState, action: jax.Array,
                 params: EnvParams) -> tuple[jax.Array, EnvState, jax.Array, jax.Array, dict[str, Any]]:
        """One control step with this step's noise drawn from ``key`` (:meth:`advance`)."""
        return self.advance(state, action, self.draw_noise(key, params, state.draw), params)

    def advance(self, state: EnvState, action: jax.Array, noise: StepNoise,
                params: EnvParams) -> tuple[jax.Array, EnvState, jax.Array, jax.Array, dict[str, Any]]:
        """One control step with given normals (the compiled kernel's order), then at the window's
        end the commands in flight, the coast and the score. A NaN action makes the state NaN and the
        episode diverge (JAX cannot raise)."""
        state = self._score(self._window_step(state, action, noise, params), noise, params)
        return self.observe_state(state, params), state, state.reward, state.terminated, self.scores(state)

    def advance_batch(self, state: EnvState, action: jax.Array, noise: StepNoise,
                      params: EnvParams) -> tuple[jax.Array, EnvState, jax.Array, jax.Array, dict[str, Any]]:
        """``vmap(advance)`` over a batch (states, actions and noise lead with N; ``params`` shared), with
        the same results, the coasts computed only for the episodes whose window has ended
        (:func:`_on_rows`): the same-draws entry at the scale of a batch."""
        state = jax.vmap(self._window_step, in_axes=(0, 0, 0, None))(state, action, noise, params)
        final, lost, paths = _on_rows(state.terminated & ~state.diverged,
                                      lambda state, noise: self._coast(state, noise, params), (state, noise))
        state = jax.vmap(self._finish, in_axes=(0, 0, 0, 0, None))(state, final, lost, paths, params)
        obs = jax.vmap(self.observe_state, in_axes=(0, None))(state, params)
        return obs, state, state.reward, state.terminated, jax.vmap(self.scores)(state)

    def step_batch(self, keys: jax.Array, state: EnvState, action: jax.Array,
                   params: EnvParams) -> tuple[jax.Array, EnvState, jax.Array, jax.Array, jax.Array, dict[str, Any]]:
        """``vmap(step)`` over a batch (keys, states and actions lead with N; ``params`` shared), with
        the same results (``tests/jax/test_api.py``), but the costly work only where it is needed: the
        coast of the episodes whose window has ended and the resets of the episodes that end, gathered
        :data:`CHUNK` at a time (:func:`_on_rows`). ``vmap(step)`` computes both for every
        environment at every step, as ``vmap`` turns a per-environment ``cond`` into a select: for a
        noisy task the coast's matrix exponential then costs most of every step. Under an outer
        ``vmap`` (over seeds, say) the gathering's loop runs, for every seed, as many chunks as the
        busiest seed needs: nothing where no episode ends, as with one seed (a PPO of 4 seeds on
        ``LightSailRealistic-v0`` with all their environments in one call trained bit for bit alike,
        not measurably faster: measured, not kept)."""
        split = jax.vmap(jax.random.split)(keys)
        reset_keys, noise_keys = split[:, 1], jax.vmap(jax.random.split)(split[:, 0])  # as draw_noise splits
        noise = jax.vmap(self._step_noise, in_axes=(0, None, 0))(noise_keys[:, 0], params, state.draw)
        state = jax.vmap(self._window_step, in_axes=(0, 0, 0, None))(state, action, noise, params)

        def coast(state: EnvState, noise: StepNoise, end_key: jax.Array) -> tuple:
            return self._coast(state, self._with_end_noise(noise, end_key, params, state.draw), params)

        final, lost, paths = _on_rows(state.terminated & ~state.diverged, coast, (state, noise, noise_keys[:, 1]))
        state = jax.vmap(self._finish, in_axes=(0, 0, 0, 0, None))(state, final, lost, paths, params)
        obs_st = jax.vmap(self.observe_state, in_axes=(0, None))(state, params)
        done = state.terminated
        obs_re, state_re = _on_rows(done, lambda key: self.reset_env(key, params), (reset_keys,))

        def pick(new: jax.Array, old: jax.Array) -> jax.Array:
            return jnp.where(done.reshape(done.shape + (1,) * (new.ndim - 1)), new, old)

        truncated = jnp.zeros_like(done)
        info = {**jax.vmap(self.scores)(state), "terminated": done, "truncated": truncated, "final_observation": obs_st}
        return pick(obs_re, obs_st), jax.tree.map(pick, state_re, state), state.reward, done, truncated, info

    def _check_params(self, params: EnvParams) -> None:
        """``ValueError`` for params of another variant (:func:`variant_of`; static, so decided when traced)."""
        if params.variant != self.variant:
            differ = [f"{name} {theirs!r} (this env: {ours!r})" for (name, theirs), (_, ours) in
                      zip(params.variant, self.variant) if theirs != ours] or ["params built by another version"]
            raise ValueError(f"params: made for another variant of the task ({'; '.join(differ)}): make the env and "
                             f"its params together, env, params = sail_env.jax.make(env_id, **keywords)")

    def _window_step(self, state: EnvState, action: jax.Array, noise: StepNoise, params: EnvParams) -> EnvState:
        """The window's step alone (:meth:`advance` without the coast and the score); ``ValueError`` for an
        action that is not (m,) (decided when traced: JAX would broadcast it) or params of another variant."""
        if jnp.shape(action) != (self.n_inputs,):
            raise ValueError(f"action must have shape ({self.n_inputs},), got {jnp.shape(action)}")
        self._check_params(params)
        d, now = state.draw, state.time
        lag0 = params.delay[d, 0] if self.delayed else 0
        command = jnp.clip(jnp.asarray(action, params.action_scale.dtype), -1.0, 1.0) * params.action_scale
        commands, applied = state.commands, command
        if self.delayed:
            commands = commands.at[now % self.command_ring].set(command)
            applied = self._arrived(params, d, now, now, commands)
        plant_noise = jnp.concatenate([noise.jitter, noise.push[None], noise.impacts])
        x = self._physics(params, d, state.x, applied, plant_noise, noise.count, now + lag0)
        peak = self._peak_speed(params.envelope[d], jnp.concatenate([x, self._with_bias(applied)]))
        envelope = divide(peak, state.speed)
        window = params.max_steps_in_episode
        time = now + 1
        states = state.states
        if self.delayed:
            states = states.at[(time + params.delay[d, 0]) % self.state_ring].set(x)
        diverged = self._diverged(x, params.limits[d])
        terminated = diverged | (time >= window)
        reward = jnp.where(diverged, DIVERGENCE_PENALTY, divide(-log_ratio(envelope), window))
        return state.replace(time=time, x=x, last_command=command, reward=reward, envelope=envelope,
                             terminated=terminated, diverged=diverged, commands=commands, states=states,
                             sensor=noise.sensor)

    @staticmethod
    def scores(state: EnvState) -> dict[str, jax.Array]:
        """What the Gym envs report at an episode's end (meaningful once ``terminated``)."""
        return {"is_success": succeeded(state.pointing), "terminal_pointing_rad": state.pointing,
                "diverged": state.diverged, "envelope_rad": state.envelope, "expected_success": state.expected_success}

    def is_truncated(self, state: EnvState, params: EnvParams) -> jax.Array:
        """Never: the window's end terminates the episode (it is scored at cut-off)."""
        return jnp.array(False)

    # ------------------------------------------------------------------ physics
    def _arrived(self, params: EnvParams, d: jax.Array, step: jax.Array, newest: jax.Array | int,
                 commands: jax.Array) -> jax.Array:
        """The command acting during ``step``: the newest sent by ``newest`` that has arrived, zero
        before any has (:func:`sail_env.core.delay.arrived_command`)."""
        sent = arrived_command(step, params.delay[d, step], newest)
        return jnp.where(sent >= 0, commands[sent % self.command_ring], 0.0)

    def _with_bias(self, inputs: jax.Array) -> jax.Array:
        """The inputs with the constant term's 1 where the plant has one (its last column of ``B``)."""
        return jnp.concatenate([inputs, jnp.ones(1, inputs.dtype)]) if self.biased else inputs

    def _physics(self, params: EnvParams, d: jax.Array, x: jax.Array, inputs: jax.Array, normals: jax.Array,
                 count: jax.Array, column: jax.Array | int) -> jax.Array:
        """One plant step from ``x`` with ``inputs`` held in noise step ``column`` (step + lag0): the beam
        offsets jittered by ``normals[:J]`` times that step's size, the push's relative error
        ``push_noise · normals[J]`` (Horner's scheme over the push expansion's rows, highest power first),
        then ``count`` impacts' kicks ``√count · σ_j · normals[J + 1 + j]`` on the kicked rows (the
        kernels' ``_physics``)."""
        jittered = len(self.jitter_inputs)
        for j, input_column in enumerate(self.jitter_inputs):
            kick = params.jitter_std[d, column] * normals[j]
            inputs = inputs.at[input_column].set(inputs[input_column] + kick)
        rows = ordered_dot(params.step_matrix[d], jnp.concatenate([x, self._with_bias(inputs)]))
        n, powers = self.n_states, params.step_matrix.shape[1] // self.n_states
        result = rows[(powers - 1) * n:]
        if powers > 1:
            eps = params.push_noise * normals[jittered] if self.pushed else 0.0
            for p in range(powers - 2, -1, -1):
                result = rows[p * n:(p + 1) * n] + eps * result
        for j, row in enumerate(self.impulse_rows):
            kick = jnp.sqrt(count) * params.impact_std[d, j]
            result = result.at[row].set(result[row] + kick * normals[jittered + 1 + j])
        return result

    def _speed_at(self, params: EnvParams, d: jax.Array, cutoff: jax.Array) -> jax.Array:
        """The axial speed at an episode's cut-off: the flight's (the plant's ``speed``) along a
        flight, the plant's at the nominal cut-off, or ``a t`` at a jittered one (a Newtonian flight,
        checked in :func:`bank_of`)."""
        if self.along is not None:
            return self.along.speed(params.along, d, jnp.asarray(cutoff, params.dt.dtype))
        if self.jittered_cutoff:
            return params.acceleration[d] * cutoff
        return params.speed_at_cutoff[d]

    def _diverged(self, x: jax.Array, limits: jax.Array) -> jax.Array:
        """The plant's divergence rule (:attr:`~sail_env.core.plant.Plant.divergence_groups`); NaN diverges."""
        out = jnp.array(False)
        for column, rows in enumerate(self.divergence_groups):
            size = jnp.abs(x[rows[0]]) if len(rows) == 1 else jnp.hypot(x[rows[0]], x[rows[1]])
            out = out | ~(size <= limits[column])
        return out

    def _peak_speed(self, envelope: jax.Array, z: jax.Array) -> jax.Array:
        """Largest lateral speed over the look-ahead samples with the input held (the kernels'
        ``_peak_speed``: each sample's sum over the columns in order)."""
        width = z.shape[0]
        squares = None
        for r in range(len(self.velocity_rows)):
            speeds = ordered_dot(envelope[r * width:(r + 1) * width].T, z)
            squares = speeds * speeds if squares is None else squares + speeds * speeds
        if len(self.velocity_rows) == 1:
            return jnp.max(jnp.abs(speeds))
        return jnp.sqrt(jnp.max(squares))

    @staticmethod
    def _moments(x: jax.Array) -> jax.Array:
        """The second moments of a known state ``x`` (``vech`` of ``E[(x, 1)(x, 1)ᵀ]``)."""
        return second_moment(x, jnp.zeros((x.shape[0], x.shape[0]), x.dtype), xp=jnp)

    @staticmethod
    def _sample(moments: jax.Array, normals: jax.Array) -> jax.Array:
        """The state drawn from its exact second ``moments`` with ``normals``; NaN where they overflow
        (the sail has left the beam)."""
        mean, cov = mean_and_covariance(moments)
        finite = jnp.all(jnp.isfinite(mean)) & jnp.all(jnp.isfinite(cov))
        safe_cov = jnp.where(finite, cov, 0.0)
        return jnp.where(finite, sample_gaussian(mean, safe_cov, normals, xp=jnp), jnp.nan)

    def _coast_along(self, params: EnvParams, d: jax.Array, x: jax.Array, u: jax.Array, start: jax.Array,
                     duration: jax.Array, normals: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The plant's coast of a model that changes along the flight (:class:`~sail_env.jax.along.Coast`)."""
        return self.along.coast(params.along, d, x, u, start, duration, normals, params.into_units,
                                params.from_units, lambda moments, _, drawn: self._sample(moments, drawn),
                                lambda state: self._diverged(state, params.limits[d]))

    def _in_flight(self, params: EnvParams, d: jax.Array, now: jax.Array) -> jax.Array:
        """Whether a command sent in the window still acts during step ``now`` after it (light delay)."""
        return now - params.delay[d, now] < params.max_steps_in_episode - 1

    def _coast_start(self, params: EnvParams, d: jax.Array) -> jax.Array:
        """The flight time [s] draw ``d``'s coast with the last command held starts at: the window's end and
        the steps while commands are in flight (the draw's alone)."""
        reached = jnp.asarray(params.max_steps_in_episode, jnp.int32)
        if self.delayed:
            reached = jax.lax.fori_loop(0, self.max_delay + 2, lambda _, now: jnp.where(
                self._in_flight(params, d, now), now + 1, now), reached)
        return params.control_start_s + reached.astype(params.dt.dtype) * params.dt

    def _coast(self, state: EnvState, noise: StepNoise,
               params: EnvParams) -> tuple[jax.Array, jax.Array, tuple[jax.Array, jax.Array] | None]:
        """From the end of the window to cut-off: the commands still in flight step by step, then the
        last command held to cut-off. Returns the state at cut-off, whether the coast diverged, and the
        score's paths' (``noise.paths``: K further coasts from the same state after the commands in
        flight; None without them)."""
        d = state.draw
        limits = params.limits[d]
        if not self.noisy:  # a fixed coast: its pieces unrolled (one for a stable sail)
            final, lost = state.x, jnp.array(False)
            drive = params.coast_gamma[d] @ state.last_command
            for _ in range(params.coast_pieces):
                final = jnp.where(lost, final, params.coast_phi[d] @ final + drive)
                lost = lost | self._diverged(final, limits)
            paths = None if noise.paths is None else (
                jnp.broadcast_to(final, (noise.paths.shape[0], *final.shape)), jnp.broadcast_to(lost, noise.paths.shape[:1]))
            return final, lost, paths
        x, reached = state.x, state.time
        if self.delayed:
            last, lag0 = params.max_steps_in_episode - 1, params.delay[d, 0]

            def in_flight(k: int, carry: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
                x, now = carry
                moving = self._in_flight(params, d, now)
                applied = self._arrived(params, d, now, last, state.commands)
                moved = self._physics(params, d, x, applied, noise.in_flight[k], noise.in_flight_counts[k],
                                      now + lag0)
                return jnp.where(moving, moved, x), jnp.where(moving, now + 1, now)

            x, reached = jax.lax.fori_loop(0, self.max_delay + 2, in_flight, (x, reached))
        remaining = jnp.maximum(state.cutoff - (params.control_start_s + reached.astype(x.dtype) * params.dt), 0.0)
        held = state.last_command
        if params.fast is not None:
            coast = functools.partial(fast_coast, self.along, params.along, params.fast, d, x, held, state.cutoff,
                                      into=params.into_units, back=params.from_units,
                                      diverged=lambda state: self._diverged(state, limits))
            final, lost = coast(noise.coast)
            return final, lost, None if noise.paths is None else coast(noise.paths)

        if self.along is None:  # one piece: its propagator serves the episode's coast and every path's
            pick, lift0, lift1, lift2 = (jnp.asarray(a, x.dtype) for a in held_input_maps(self.n_states, self.n_inputs))
            lift = lift0 + jnp.tensordot(held, lift1, 1) + jnp.tensordot(jnp.outer(held, held), lift2, 2)
            generator = params.coast_generator[d] @ lift
            balanced = generator * (remaining * params.into_units)
            moments = (jax.scipy.linalg.expm(balanced, max_squarings=MAX_SQUARINGS) * params.from_units) @ self._moments(x)

        def coast_from(normals: jax.Array) -> tuple[jax.Array, jax.Array]:
            if self.along is not None:
                return self._coast_along(params, d, x, held, state.cutoff - remaining, remaining, normals)
            final = self._sample(moments, normals[0])
            return final, self._diverged(final, limits)

        final, lost = coast_from(noise.coast)
        return final, lost, None if noise.paths is None else jax.vmap(coast_from)(noise.paths)

    def _score(self, state: EnvState, noise: StepNoise, params: EnvParams) -> EnvState:
        """Coast a finished window to cut-off and score it (computed every step and selected, as
        ``vmap`` would run both branches anyway)."""
        return self._finish(state, *self._coast(state, noise, params), params)

    def _finish(self, state: EnvState, final: jax.Array, coast_lost: jax.Array,
                paths: tuple[jax.Array, jax.Array] | None, params: EnvParams) -> EnvState:
        """The score of a finished window from its state at cut-off and whether the coast diverged
        (read only where the window ended inside the beam): the terminal reward, the divergence
        penalty, the pointing; with the score's paths (their states at cut-off and divergences), the
        expected success and, for ``terminal_reward="expected"``, the terminal reward as their mean."""
        scored = state.terminated & ~state.diverged
        pointing, terminal = self._terminal(state, final, coast_lost)
        diverged = state.diverged | (scored & coast_lost)
        reward = jnp.where(diverged, DIVERGENCE_PENALTY, jnp.where(scored, terminal, state.reward))
        expected = state.expected_success
        if self.expected_paths:
            finals, losts = (final[None], coast_lost[None]) if paths is None else paths
            pointings, terminals = jax.vmap(self._terminal, in_axes=(None, 0, 0))(state, finals, losts)
            won = jnp.mean((succeeded(pointings) & ~losts).astype(final.dtype))
            expected = jnp.where(scored, won, jnp.where(state.diverged, 0.0, expected))
            if self.expected_reward:
                reward = jnp.where(state.diverged, DIVERGENCE_PENALTY, jnp.where(scored, jnp.mean(terminals), state.reward))
        pointing = jnp.where(diverged, jnp.inf, jnp.where(scored, pointing, jnp.nan))
        return state.replace(reward=reward, diverged=diverged, pointing=pointing, expected_success=expected)

    def _terminal(self, state: EnvState, final: jax.Array, lost: jax.Array) -> tuple[jax.Array, jax.Array]:
        """The pointing of a state at cut-off and the last step's reward it gives: the window's last reward,
        the pointing's and the success bonus, or the divergence penalty where the coast left the beam."""
        velocity = final[jnp.array(self.velocity_rows)]
        pointing = divide(jnp.sqrt(jnp.sum(velocity * velocity)), state.speed)
        bonus = jnp.where(succeeded(pointing), SUCCESS_BONUS, 0.0)
        return pointing, jnp.where(lost, DIVERGENCE_PENALTY, state.reward + (-log_ratio(pointing) + bonus))

    # ------------------------------------------------------------------ observation
    def observe_state(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The (delayed, noisy) state over its scales (clipped to the observation's limit), the
        progress through the window and the commands sent, newest first, as float32 (the kernels'
        ``_observe``)."""
        d, time, source = state.draw, state.time, state.x
        if self.delayed:
            shown = jnp.maximum(time - params.delay[d, time] + params.delay[d, 0], 0)
            source = state.states[shown % self.state_ring]
        if self.sensed:
            source = source + params.sensor_std * state.sensor
        scaled = jnp.clip(divide(source, params.state_scale), -OBSERVATION_LIMIT, OBSERVATION_LIMIT)
        progress = divide(2.0 * time.astype(params.state_scale.dtype), params.max_steps_in_episode) - 1.0
        parts = [scaled, progress[None]]
        for h in range(self.history):
            sent = time - 1 - h
            shown_command = jnp.where(sent >= 0, divide(state.commands[sent % self.command_ring], params.action_scale),
                                      0.0)
            parts.append(jnp.clip(shown_command, -OBSERVATION_LIMIT, OBSERVATION_LIMIT))
        return jnp.concatenate(parts).astype(jnp.float32)

    def get_obs(self, state: EnvState, params: EnvParams | None = None, key: jax.Array | None = None) -> jax.Array:
        return self.observe_state(state, self.default_params if params is None else params)

    def draw_factors(self, state: EnvState, params: EnvParams) -> jax.Array:
        """The episode's parameter factors (:attr:`EnvParams.factors`' row of its draw): what the
        observation hides on a task with spread, for a privileged critic in training."""
        return params.factors[state.draw]
