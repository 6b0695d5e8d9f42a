"""The episode core: light delay, commands in flight, observation, reward, coast and scoring,
written once over N environments. ``LightSailEnv`` is the core with N = 1 and
``LightSailVectorEnv`` the core with N environments: the same code runs both.

The window's step is compiled (:mod:`sail_env.core.kernels`) and reads and writes the
:class:`~sail_env.core.state.EpisodeState`; the coast to cut-off and the resets' physics (the
parameter draws, the pre-control coast) are NumPy calls of the plant.

Randomness. Each environment has its own ``numpy.random.Generator``. At reset it draws,
in this order: the parameter factors (with spread), the cut-off time (with jitter), the
launch state (unless given), then in one call every standard normal the episode's window
can need (pre-control propagation, per-step beam jitter and push noise, sensor noise, the
plant's random impacts), then the impacts' Poisson count of each step (if the plant has
impacts); the coast draws its normals when it comes. A batch of environments therefore plays
exactly the episodes each would play alone with the same seed, whatever N is. The score's further
coasts (``expected_paths``) draw from a generator of their own, made at the coast by jumping a copy
of the environment's (``bit_generator.jumped()``, which leaves it as it was): an episode's numbers
are the same with them or without.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from sail_env.core import kernels
from sail_env.core.reward import DIVERGENCE_PENALTY, SUCCESS_BONUS, log_ratio, succeeded
from sail_env.core.spec import EpisodeSpec
from sail_env.core.state import SIZES, EpisodeState, Slot, allocate

OBSERVATION_LIMIT = kernels.OBSERVATION_LIMIT


@dataclasses.dataclass
class StepResult:
    """What one step of the core returns, per environment (arrays of length N; the reward, the
    flags and the envelope are the state's fields, valid until the next step)."""

    observation: np.ndarray  # (N, D) float32, a new array
    reward: np.ndarray
    terminated: np.ndarray  # (N,) 0/1: end of the window (scored) or divergence
    diverged: np.ndarray  # (N,) 0/1
    envelope_rad: np.ndarray  # largest |V⊥|/Vz with the applied command held
    applied: np.ndarray  # (N, m) beam input that acted during the step [SI]
    # Only when an episode terminated (else None): at cut-off; inf if diverged, NaN if still running.
    terminal_pointing_rad: np.ndarray | None = None
    terminal_envelope_rad: np.ndarray | None = None
    terminal_state: np.ndarray | None = None  # (N, n), NaN where not scored
    success: np.ndarray | None = None  # (N,) bool: :func:`~sail_env.core.reward.succeeded` of the pointing
    # (N,) the share of the score's further coasts that succeed (spec.expected_paths): the probability of
    # success given the window's end, estimated; 0 after a divergence, NaN where not ended; None without paths.
    expected_success: np.ndarray | None = None


class EpisodeCore:
    """N episodes of one :class:`EpisodeSpec`, stepped together; their arrays are :attr:`state`.

    Buffers are sized for the worst parameter draw: the command ring holds the sent commands
    (newest at ``step − 1``), the state ring the true states indexed by ``step + lag0`` (the
    first shows the state ``lag0`` steps before control, which the first delayed observation sees).
    """

    def __init__(self, spec: EpisodeSpec, num_envs: int) -> None:
        self.spec, self.num_envs = spec, num_envs
        plant, n, dist = spec.plant, num_envs, spec.randomisation
        ns, m = plant.n_states, plant.n_inputs
        params = plant.params(np.ones((n, plant.n_factors)))
        cols = params.step.shape[-1]
        # Standard normals of the window, drawn at reset: jitter and push per step, sensor per observation.
        # Steps run from lag0 before control to the last command's arrival: at most n + 2 max_delay.
        self.noise_steps = w = spec.n_steps + 2 * spec.max_delay + 2
        jittered = len(plant.jitter_inputs) if plant.jittered else 0
        impacts = len(plant.impulse_rows)
        pushed = bool(dist.push_noise)
        sensed = dist.any_sensor_noise
        parts = (w * jittered, w if pushed else 0, (spec.n_steps + 1) * ns if sensed else 0, w * impacts)
        groups = plant.divergence_groups
        layout = np.zeros(int(Slot.TABLES) + jittered + impacts + 2 * len(groups), dtype=np.int64)
        ring, state_ring, delay_length = spec.ring_lengths
        power = plant.input_names.index("beam_power") if "beam_power" in plant.input_names else -1
        sizes = {"ENVS": n, "STATES": ns, "INPUTS": m, "COLUMNS": cols, "POWERS": params.step.shape[-2] // ns,
                 "SPEED_ROWS": len(plant.velocity_rows), "NOISE_STEPS": w, "JITTERED": jittered,
                 "JITTER_STEPS": w if jittered else 0, "IMPACTS": impacts, "IMPACT_STEPS": w if impacts else 0,
                 "DELAY_LENGTH": delay_length, "COMMAND_RING": ring, "STATE_RING": state_ring,
                 "HISTORY": spec.history_length, "WINDOW": spec.n_steps, "PUSHED": pushed, "SENSED": sensed,
                 "POWER_INPUT": power, "GROUPS": len(groups), "OBSERVATION": spec.observation_size,
                 "NORMALS": sum(parts), "JITTER_NORMALS": 0, "PUSH_NORMALS": parts[0],
                 "SENSOR_NORMALS": sum(parts[:2]), "IMPACT_NORMALS": sum(parts[:3])}
        assert sizes.keys() == SIZES.keys(), "every size of the layout is set here"
        for name, value in sizes.items():
            layout[Slot[name]] = value
        tables = [*(plant.jitter_inputs if jittered else ()), *plant.impulse_rows]
        for group in groups:
            tables += [group[0], group[1] if len(group) > 1 else -1]
        layout[int(Slot.TABLES):] = tables
        floats, ints, views = allocate(layout)
        self.state = EpisodeState(**views, params=params, rngs=[None] * n, floats=floats, ints=ints, layout=layout)
        self.state.finished[:] = 1
        self.state.cutoff_s[:] = spec.config.beam_cutoff_s
        self.state.speed_at_cutoff[:] = plant.speed(params, self.state.cutoff_s)
        self.consts = np.concatenate([spec.action_scale, spec.state_scale, spec.sensor_noise_std, [dist.push_noise]])
        self._set_tables(self._transposed(params.envelope))
        self._rows = np.arange(n)
        self._jittered, self._impacts, self._pushed, self._sensed = jittered, impacts, pushed, sensed

    def __getstate__(self) -> dict[str, object]:
        """What a copy or a pickle keeps: not the step's views of the tables nor the scratch, which
        :meth:`__setstate__` makes again over the copied tables (the state rebuilds its own views)."""
        return {name: value for name, value in self.__dict__.items()
                if name not in ("_step_tables", "_step_model", "_block", "_pad")}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._set_tables(self.envelope_tables)

    def _set_tables(self, tables: np.ndarray) -> None:
        """Keep the look-ahead tables (K, R·c, S) and the step's views of them and of the plant's
        step (:func:`kernels.shared_table`)."""
        self.envelope_tables = tables
        self._step_tables = kernels.shared_table(tables, self.num_envs)
        self._step_model = kernels.shared_table(self.state.params.step, self.num_envs)
        self._block, self._pad = kernels.scratch(self.state.layout, tables.shape[-1], self.num_envs)

    @staticmethod
    def _transposed(envelope: np.ndarray) -> np.ndarray:
        """The look-ahead tables (K, S, R·c) as the kernels read them, (K, R·c, S) contiguous: a
        sample's sum is then a column, and all samples' sums run at once."""
        return np.ascontiguousarray(envelope.transpose(0, 2, 1))

    # ------------------------------------------------------------------ reset
    def reset(self, index: np.ndarray, rngs: Sequence[np.random.Generator],
              initial_states: np.ndarray | None = None) -> None:
        """Start new episodes in environments ``index``, each drawing from its generator ``rngs[i]``.

        ``initial_states`` (k, n) replaces the drawn launch states.
        """
        spec, plant, dist, state = self.spec, self.spec.plant, self.spec.randomisation, self.state
        k, n_states = len(index), plant.n_states
        # One uniform call per environment (the same numbers as separate calls, in the same order):
        # the parameter factors, the cut-off's jitter, the launch state.
        widths = (plant.n_draws, 1 if dist.cutoff_jitter_s else 0, n_states if initial_states is None else 0)
        uniforms = np.empty((k, sum(widths)))
        if uniforms.shape[1]:
            for row, rng in enumerate(rngs):
                rng.random(out=uniforms[row])
        factors_u, cutoff_u, launch_u = np.split(uniforms, np.cumsum(widths)[:-1], axis=1)
        factors = plant.factors(factors_u)
        cutoff = np.full(k, spec.config.beam_cutoff_s)
        if dist.cutoff_jitter_s:
            cutoff += -dist.cutoff_jitter_s + (dist.cutoff_jitter_s - -dist.cutoff_jitter_s) * cutoff_u[:, 0]
        if initial_states is None:
            half = spec.start_half_widths
            launch = -half + (half - -half) * launch_u
        else:
            launch = np.array(initial_states, dtype=np.float64)
        params = plant.params(factors)
        if not params.shared:
            state.params.put(index, params)
            self._step_model = state.params.step  # per environment: put may replace a field
            if self.envelope_tables.shape[2] == state.params.envelope.shape[1]:
                self.envelope_tables[index] = self._transposed(state.params.envelope[index])
            else:  # the tables were padded to a longer draw's
                self._set_tables(self._transposed(state.params.envelope))
        for i, rng in zip(index, rngs):
            state.rngs[i] = rng
        state.cutoff_s[index] = cutoff
        state.speed_at_cutoff[index] = plant.speed(params, cutoff)
        lag0 = spec.delay_steps(0, params.acceleration) * np.ones(k, dtype=np.int64)
        pre_control = spec.config.control_start_s - lag0 * spec.dt
        pre_pieces = plant.coast_pieces(params, pre_control) * np.ones(k, dtype=np.int64) if plant.noisy \
            else np.zeros(k, dtype=np.int64)
        if self._impacts:
            impact_rate, state.impact_std[index] = plant.impact_rate_and_std(params, np.full(k, spec.window_middle_s))
        if self._jittered:
            columns = np.arange(self.noise_steps)
            middles = spec.config.control_start_s + (columns - lag0[:, None] + 0.5) * spec.dt
            std = plant.jitter_std(params, middles)  # one read of the (k, steps) grid: no copy of the tables per step
            state.jitter_std[index] = np.reshape(std, (k, -1)) if np.ndim(std) else std
        # Each environment draws only what it needs alone, whatever the others' pre-control pieces.
        pre_normals = np.zeros((k, int(pre_pieces.max(initial=0)), n_states))
        window = state.normals.shape[1]
        for row, (i, rng) in enumerate(zip(index, rngs)):
            pre = int(pre_pieces[row]) * n_states
            if pre:
                pre_normals[row, :pre_pieces[row]] = rng.standard_normal(pre).reshape(-1, n_states)
            if window:
                rng.standard_normal(out=state.normals[i])
            if self._impacts:
                state.impact_counts[i] = rng.poisson(impact_rate[row] * spec.dt, self.noise_steps)
        x = launch
        if np.any(pre_control > 0):
            x, _ = plant.coast(params, launch, np.zeros((k, plant.n_inputs)), pre_control, pre_normals, np.zeros(k))
        state.step[index] = 0
        state.finished[index] = 0
        state.x[index] = x
        if spec.light_delay:
            state.lag0[index] = lag0
            state.delay[index] = spec.delay_steps(np.arange(state.delay.shape[1]), params.acceleration[:, None])
            state.commands[index] = 0.0
            state.states[index, 0] = x
            # The light-delayed first observation shows the state lag0 steps before control.
            kernels.pre_control(np.asarray(index, dtype=np.int64), state.floats, state.ints, state.layout,
                                self.consts, state.params.step, self._block, self._pad)

    # ------------------------------------------------------------------ step
    def step(self, action: np.ndarray) -> StepResult:
        """Advance every environment by one control step with ``action`` (N, m) in [-1, 1] (clipped);
        ``ValueError`` if an action is not finite, ``RuntimeError`` if an episode has finished."""
        state = self.state
        obs = np.empty((self.num_envs, self.spec.observation_size), dtype=np.float32)
        result = StepResult(obs, state.reward, state.terminated, state.diverged, state.envelope, state.applied)
        if self.advance(action, obs):
            self._score(result)
        return result

    def advance(self, action: np.ndarray, out: np.ndarray) -> int:
        """The compiled step alone (:meth:`step` without the scoring): the observations into ``out``
        (N, D) float32, the rest into :attr:`state`. Returns how many episodes terminated; the caller
        then scores them (:meth:`score`). What the single env's hot path calls."""
        state = self.state
        if action.dtype.char in "eg":  # float16, longdouble: the kernels take the other real dtypes
            action = action.astype(np.float64)
        ended = kernels.step(action, out, state.floats, state.ints, state.layout, self.consts, self._step_model,
                             self._step_tables, state.params.limits, self._block, self._pad)
        if ended < 0:
            if ended == -2:
                raise RuntimeError("step() called on a finished episode; call reset() first")
            raise ValueError("actions must be finite")
        return ended

    def score(self) -> StepResult:
        """The scores of the episodes the last :meth:`advance` terminated (observation None)."""
        state = self.state
        result = StepResult(None, state.reward, state.terminated, state.diverged, state.envelope, state.applied)
        self._score(result)
        return result

    def _score(self, result: StepResult) -> None:
        """Coast the environments whose window has ended and score them; penalise divergence."""
        plant, state = self.spec.plant, self.state
        reward, diverged = state.reward, state.diverged
        pointing, terminal_envelope = np.full(self.num_envs, np.nan), np.full(self.num_envs, np.nan)
        terminal_state = np.full((self.num_envs, plant.n_states), np.nan)
        scored = np.flatnonzero(state.terminated & (1 - diverged))
        if self.spec.expected_paths:
            result.expected_success = np.where(state.terminated.astype(bool), 0.0, np.nan)
        if len(scored):
            final, final_input, coast_diverged, paths = self._coast(scored)
            params = state.params.take(scored)
            pointing[scored] = plant.pointing(params, final, state.cutoff_s[scored])
            if paths is not None:
                result.expected_success[scored] = self._expected_success(params, scored, *paths)
            terminal_envelope[scored] = self._peak_speeds(scored, final, final_input) / state.speed_at_cutoff[scored]
            terminal_state[scored] = final
            reward[scored] += -log_ratio(pointing[scored]) + np.where(succeeded(pointing[scored]), SUCCESS_BONUS, 0.0)
            diverged[scored] = coast_diverged
        lost = diverged.astype(bool)
        pointing[lost] = terminal_envelope[lost] = np.inf
        reward[lost] = DIVERGENCE_PENALTY
        result.terminal_pointing_rad, result.terminal_envelope_rad = pointing, terminal_envelope
        result.terminal_state, result.success = terminal_state, succeeded(pointing)

    def _expected_success(self, params: object, index: np.ndarray, finals: np.ndarray, lost: np.ndarray) -> np.ndarray:
        """The share of each environment's further coasts (``finals`` (k, K, n), ``lost`` (k, K)) that
        end inside the tolerance without leaving the beam."""
        won = [succeeded(self.spec.plant.pointing(params, finals[:, path], self.state.cutoff_s[index])) & ~lost[:, path]
               for path in range(finals.shape[1])]
        return np.mean(won, axis=0)

    def _peak_speeds(self, index: np.ndarray, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The envelope's lateral speed of environments ``index`` at ``x`` with ``u`` (k, m) held (the kernel's)."""
        plant = self.spec.plant
        biased = plant.with_bias(u)
        out = np.empty(len(index))
        kernels.peak_speeds(index, np.ascontiguousarray(x), np.ascontiguousarray(biased), len(plant.velocity_rows),
                            self.envelope_tables, out, self.state.layout, self._block, self._pad)
        return out

    # ------------------------------------------------------------------ coast and observation
    def _coast(self, index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple | None]:
        """From the end of the window to cut-off: the commands still in flight step by step, then
        the last command held to cut-off. Returns the end states, the held inputs, divergence and,
        with ``expected_paths``, the further coasts' end states (k, K, n) and divergences (k, K)
        from the same state after the commands in flight (a fixed coast's are its own)."""
        spec, plant, state = self.spec, self.spec.plant, self.state
        params = state.params.take(index)
        if spec.light_delay:
            x, step = np.empty((len(index), plant.n_states)), np.empty(len(index), dtype=np.int64)
            kernels.in_flight(index, x, step, state.floats, state.ints, state.layout, self.consts, state.params.step,
                              self._block, self._pad)
        else:
            x, step = state.x[index], state.step[index]
        held = state.last_command[index]
        remaining = np.maximum(state.cutoff_s[index] - (spec.config.control_start_s + step * spec.dt), 0.0)
        normals = paths = None
        count_paths = spec.expected_paths
        if plant.noisy:
            # Each environment draws its own pieces' normals: a batch plays the single episodes.
            pieces = plant.coast_pieces(params, remaining)
            normals = np.zeros((len(index), int(pieces.max()), plant.n_states))
            paths = np.zeros((len(index), count_paths, int(pieces.max()), plant.n_states)) if count_paths else None
            for row, (i, count) in enumerate(zip(index, pieces)):
                if count_paths:  # before the episode's own draws, from a jumped copy (the module's docstring)
                    own = np.random.Generator(state.rngs[i].bit_generator.jumped())
                    paths[row, :, :count] = own.standard_normal((count_paths, count, plant.n_states))
                normals[row, :count] = state.rngs[i].standard_normal((count, plant.n_states))
        final, diverged, path_x, path_lost = plant.coast_with_paths(params, x, held, remaining, normals, paths,
                                                                    state.cutoff_s[index] - remaining)
        if count_paths and path_x is None:
            path_x, path_lost = np.repeat(final[:, None], count_paths, axis=1), np.repeat(diverged[:, None], count_paths, 1)
        return final, held, diverged, None if not count_paths else (path_x, path_lost)

    def observe(self, index: np.ndarray | None = None) -> np.ndarray:
        """Observations (k, D) of environments ``index`` (default all) at their current step."""
        index = self._rows if index is None else np.asarray(index, dtype=np.int64)
        obs = np.empty((len(index), self.spec.observation_size), dtype=np.float32)
        kernels.observe(index, obs, self.state.floats, self.state.ints, self.state.layout, self.consts)
        return obs
