"""The episode core: light delay, commands in flight, observation, reward, coast and scoring,
written once over N environments as arrays. ``LightSailEnv`` is the core with N = 1 and
``LightSailVectorEnv`` the core with N environments: the same code runs both.

Randomness. Each environment has its own ``numpy.random.Generator``. At reset it draws,
in this order: the parameter factors (with spread), the cut-off time (with jitter), the
launch state (unless given), then in one call every standard normal the episode's window
can need (pre-control propagation, per-step beam jitter and push noise, sensor noise, the
plant's random impacts), then the impacts' Poisson count of each step (if the plant has
impacts); the coast draws its normals when it comes. A batch of environments therefore plays
exactly the episodes each would play alone with the same seed, whatever N is.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from sail_env.core.spec import EpisodeSpec
from sail_env.physics.linear import sample_uniform
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD

#: Reward: log10 of (pointing / tolerance) is clipped to this range.
LOG_RATIO_RANGE = (-2.0, 3.0)
SUCCESS_BONUS = 1.0
DIVERGENCE_PENALTY = -10.0
OBSERVATION_LIMIT = 1e3


def log_ratio(pointing: np.ndarray) -> np.ndarray:
    """``log10(pointing / tolerance)`` clipped to :data:`LOG_RATIO_RANGE` (zero pointing: the low end)."""
    low, high = LOG_RATIO_RANGE
    ratio = np.log10(np.maximum(pointing, 1e-300) / POINTING_TOLERANCE_RAD)
    return np.minimum(np.maximum(ratio, low), high)


def take(array: np.ndarray, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``array[rows, columns]`` as one flat ``np.take``: the same elements, several times faster
    than NumPy's two-array fancy indexing for the per-environment columns the core gathers."""
    flat = array.reshape(-1, *array.shape[2:])
    return np.take(flat, rows * array.shape[1] + columns, axis=0)


@dataclasses.dataclass
class StepResult:
    """What one step of the core returns, per environment (arrays of length N)."""

    observation: np.ndarray  # (N, D) float32
    reward: np.ndarray
    terminated: np.ndarray  # end of the window (scored) or divergence
    diverged: np.ndarray
    envelope_rad: np.ndarray  # largest |V⊥|/Vz with the applied command held
    applied: np.ndarray  # (N, m) beam input that acted during the step [SI]
    # Only when an episode terminated (else None): at cut-off; inf if diverged, NaN if still running.
    terminal_pointing_rad: np.ndarray | None = None
    terminal_envelope_rad: np.ndarray | None = None
    terminal_state: np.ndarray | None = None  # (N, n), NaN where not scored


class EpisodeCore:
    """N episodes of one :class:`EpisodeSpec`, stepped together.

    Buffers are sized for the worst parameter draw: ``commands`` holds the sent commands
    in a ring (newest at ``step − 1``), ``states`` the true states in a ring indexed by
    ``step + lag0`` (the first shows the state ``lag0`` steps before control, which the
    first delayed observation sees).
    """

    def __init__(self, spec: EpisodeSpec, num_envs: int) -> None:
        self.spec, self.num_envs = spec, num_envs
        plant, n, dist = spec.plant, num_envs, spec.disturbances
        self.params = plant.params(np.ones((n, plant.n_factors)))
        self.rngs: list[np.random.Generator | None] = [None] * n
        self.x = np.zeros((n, plant.n_states))
        self.last_command = np.zeros((n, plant.n_inputs))
        self.step_index = np.zeros(n, dtype=np.int64)
        self.cutoff_s = np.full(n, spec.config.beam_cutoff_s)
        self.speed_at_cutoff = plant.speed(self.params, self.cutoff_s)
        self.finished = np.ones(n, dtype=bool)
        self.delayed = dist.light_delay
        if self.delayed:
            self.lag0 = np.zeros(n, dtype=np.int64)
            self.delay = np.zeros((n, spec.n_steps + spec.max_delay + 2), dtype=np.int64)
            self.commands = np.zeros((n, max(spec.history_length, spec.max_delay + 1) + 1, plant.n_inputs))
            self.states = np.zeros((n, spec.max_delay + 2, plant.n_states))
        # Standard normals of the window, drawn at reset: jitter and push per step, sensor per observation.
        # Steps run from lag0 before control to the last command's arrival: at most n + 2 max_delay.
        self.noise_steps = spec.n_steps + 2 * spec.max_delay + 2
        self.jitter = np.zeros((n, self.noise_steps, len(plant.jitter_inputs))) if plant.jittered else None
        self.push = np.zeros((n, self.noise_steps)) if dist.push_noise else None
        self.sensor = np.zeros((n, spec.n_steps + 1, plant.n_states)) if dist.any_sensor_noise else None
        # Random impacts (compound Poisson): a count per step and Gaussian kicks given the count, whose
        # sum is √count · std · normal; rate and std are the plant's at the window's middle.
        impacts = len(plant.impulse_rows)
        self.impact_counts = np.zeros((n, self.noise_steps)) if impacts else None
        self.impact_normals = np.zeros((n, self.noise_steps, impacts)) if impacts else None
        self.impact_std = np.zeros((n, impacts)) if impacts else None
        self._rows = np.arange(n)

    # ------------------------------------------------------------------ reset
    def reset(self, index: np.ndarray, rngs: Sequence[np.random.Generator],
              initial_states: np.ndarray | None = None) -> None:
        """Start new episodes in environments ``index``, each drawing from its generator ``rngs[i]``.

        ``initial_states`` (k, n) replaces the drawn launch states.
        """
        spec, plant, dist = self.spec, self.spec.plant, self.spec.disturbances
        k, n_states = len(index), plant.n_states
        factors, cutoff = np.ones((k, plant.n_factors)), np.full(k, spec.config.beam_cutoff_s)
        launch, rest = np.empty((k, n_states)), np.zeros((k, plant.n_inputs))
        for i, rng in enumerate(rngs):
            factors[i] = plant.draw(rng)
            if dist.cutoff_jitter_s:
                cutoff[i] += sample_uniform(rng, -dist.cutoff_jitter_s, dist.cutoff_jitter_s, 1)[0]
            if initial_states is None:
                launch[i] = sample_uniform(rng, -spec.start_half_widths, spec.start_half_widths, n_states)
        if initial_states is not None:
            launch[:] = initial_states
        params = plant.params(factors)
        if not params.shared:
            self.params.put(index, params)
        for i, rng in zip(index, rngs):
            self.rngs[i] = rng
        self.cutoff_s[index] = cutoff
        self.speed_at_cutoff[index] = plant.speed(params, cutoff)
        lag0 = spec.delay_steps(0, params.acceleration) * np.ones(k, dtype=np.int64)
        pre_control = spec.config.control_start_s - lag0 * spec.dt
        pre_pieces = np.zeros(k, dtype=np.int64)
        if plant.noisy:
            pre_pieces[:] = plant.coast_pieces(params, pre_control)
        if self.impact_counts is not None:
            middle = spec.config.control_start_s + 0.5 * spec.n_steps * spec.dt
            impact_rate, self.impact_std[index] = plant.impact_rate_and_std(params, np.full(k, middle))
        # Each environment draws only what it needs alone, whatever the others' pre-control pieces.
        pre_normals = np.zeros((k, int(pre_pieces.max(initial=0)), n_states))
        for row, (i, rng) in enumerate(zip(index, rngs)):
            sizes = self._normal_sizes(int(pre_pieces[row]))
            if not sum(sizes):
                continue
            pre, jitter, push, sensor, impacts = np.split(rng.standard_normal(sum(sizes)), np.cumsum(sizes)[:-1])
            pre_normals[row, :pre_pieces[row]] = pre.reshape(-1, n_states)
            if self.jitter is not None:
                self.jitter[i] = jitter.reshape(self.noise_steps, -1)
            if self.push is not None:
                self.push[i] = push
            if self.sensor is not None:
                self.sensor[i] = sensor.reshape(-1, n_states)
            if self.impact_counts is not None:
                self.impact_normals[i] = impacts.reshape(self.noise_steps, -1)
                self.impact_counts[i] = rng.poisson(impact_rate[row] * spec.dt, self.noise_steps)

        x = launch
        if np.any(pre_control > 0):
            x, _ = plant.coast(params, launch, rest, pre_control, pre_normals, np.zeros(k))
        self.step_index[index] = 0
        self.finished[index] = False
        if self.delayed:
            self.lag0[index] = lag0
            self.delay[index] = spec.delay_steps(np.arange(self.delay.shape[1]), params.acceleration[:, None])
            self.commands[index] = 0.0
            self.states[index, 0] = x
            # The light-delayed first observation shows the state lag0 steps before control.
            for s in range(int(lag0.max(initial=0))):
                moving = s < lag0
                x = np.where(moving[:, None], self._physics_step(index, params, x, rest, s), x)
                self.states[index[moving], s + 1] = x[moving]
        self.x[index] = x

    def _normal_sizes(self, pre_pieces: int) -> tuple[int, int, int, int, int]:
        """Standard normals per environment: pre-control, jitter, push, sensor, impacts."""
        return (self.spec.plant.n_states * pre_pieces, 0 if self.jitter is None else self.jitter[0].size,
                0 if self.push is None else self.noise_steps, 0 if self.sensor is None else self.sensor[0].size,
                0 if self.impact_normals is None else self.impact_normals[0].size)

    # ------------------------------------------------------------------ step
    def _physics_step(self, index: np.ndarray, params, x: np.ndarray, u: np.ndarray,
                      noise_column: np.ndarray | int) -> np.ndarray:
        """One plant step of environments ``index`` with the per-step noise of column ``noise_column``."""
        if self.jitter is not None:
            u = u.copy()
            lag = self.lag0[index] if self.delayed else 0
            middle = self.spec.config.control_start_s + (noise_column - lag + 0.5) * self.spec.dt
            std = self.spec.plant.jitter_std(params, middle * np.ones(len(index)))
            u[:, list(self.spec.plant.jitter_inputs)] += std * take(self.jitter, index, noise_column)
        push = None if self.push is None else self.spec.disturbances.push_noise * take(self.push, index, noise_column)
        x = self.spec.plant.step(params, x, u, push)
        if self.impact_counts is not None:
            # The step's impacts land at its end (the exact moments of the kicks are not resolved).
            kick = np.sqrt(take(self.impact_counts, index, noise_column))[:, None] * self.impact_std[index]
            x = x.copy()
            x[:, list(self.spec.plant.impulse_rows)] += kick * take(self.impact_normals, index, noise_column)
        return x

    def _applied(self, index: np.ndarray, step: np.ndarray, newest: np.ndarray | int) -> np.ndarray:
        """The command acting during ``step``: the newest arrived (at most ``newest``, the last
        sent), zero before any arrives."""
        sent = np.minimum(step - take(self.delay, index, step), newest)
        command = take(self.commands, index, sent % self.commands.shape[1])
        return np.where((sent >= 0)[:, None], command, 0.0)

    def step(self, action: np.ndarray) -> StepResult:
        """Advance every environment by one control step with ``action`` (N, m) in [-1, 1] (clipped)."""
        spec, plant = self.spec, self.spec.plant
        command = np.minimum(np.maximum(action, -1.0), 1.0) * spec.action_scale  # np.clip: 3× the overhead
        rows, step = self._rows, self.step_index
        if self.delayed:
            self.commands[rows, step % self.commands.shape[1]] = command
            applied = self._applied(rows, step, step)
        else:
            applied = command
        self.last_command = command
        noise_column = step + self.lag0 if self.delayed else step
        x = self._physics_step(rows, self.params, self.x, applied, noise_column)
        self.x = x
        self.step_index = step = step + 1
        if self.delayed:
            self.states[rows, (step + self.lag0) % self.states.shape[1]] = x

        diverged = plant.diverged(self.params, x)
        envelope = plant.peak_speed(self.params, x, applied) / self.speed_at_cutoff
        reward = -log_ratio(envelope) / spec.n_steps
        terminated = diverged | (step >= spec.n_steps)
        result = StepResult(None, reward, terminated, diverged, envelope, applied)
        if terminated.any():
            self._score(result)
        self.finished |= terminated
        result.observation = self.observe()
        return result

    def _score(self, result: StepResult) -> None:
        """Coast the environments whose window has ended and score them; penalise divergence."""
        plant, reward, diverged = self.spec.plant, result.reward, result.diverged
        pointing, terminal_envelope = np.full(self.num_envs, np.nan), np.full(self.num_envs, np.nan)
        terminal_state = np.full((self.num_envs, plant.n_states), np.nan)
        scored = np.flatnonzero(result.terminated & ~diverged)
        if len(scored):
            final, final_input, coast_diverged = self._coast(scored)
            params = self.params.take(scored)
            pointing[scored] = plant.pointing(params, final, self.cutoff_s[scored])
            terminal_envelope[scored] = plant.peak_speed(params, final, final_input) / self.speed_at_cutoff[scored]
            terminal_state[scored] = final
            success = pointing[scored] <= POINTING_TOLERANCE_RAD
            reward[scored] += -log_ratio(pointing[scored]) + np.where(success, SUCCESS_BONUS, 0.0)
            diverged[scored] = coast_diverged
        pointing[diverged] = terminal_envelope[diverged] = np.inf
        reward[diverged] = DIVERGENCE_PENALTY
        result.terminal_pointing_rad, result.terminal_envelope_rad = pointing, terminal_envelope
        result.terminal_state = terminal_state

    # ------------------------------------------------------------------ coast and observation
    def _coast(self, index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """From the end of the window to cut-off: the commands still in flight step by step, then
        the last command held to cut-off. Returns the end states, the held inputs and divergence."""
        spec, plant = self.spec, self.spec.plant
        params = self.params.take(index)
        x, step = self.x[index], self.step_index[index].copy()
        if self.delayed:
            last = spec.n_steps - 1
            while True:
                in_flight = step - self.delay[index, step] < last
                if not in_flight.any():
                    break
                applied = self._applied(index, step, last)
                moved = self._physics_step(index, params, x, applied, step + self.lag0[index])
                x = np.where(in_flight[:, None], moved, x)
                step = step + in_flight
        held = self.last_command[index]
        remaining = np.maximum(self.cutoff_s[index] - (spec.config.control_start_s + step * spec.dt), 0.0)
        normals = None
        if plant.noisy:
            # Each environment draws its own pieces' normals: a batch plays the single episodes.
            pieces = plant.coast_pieces(params, remaining)
            normals = np.zeros((len(index), int(pieces.max()), plant.n_states))
            for row, (i, count) in enumerate(zip(index, pieces)):
                normals[row, :count] = self.rngs[i].standard_normal((count, plant.n_states))
        final, diverged = plant.coast(params, x, held, remaining, normals, self.cutoff_s[index] - remaining)
        return final, held, diverged

    def observe(self, index: np.ndarray | None = None) -> np.ndarray:
        """Observations (k, D) of environments ``index`` (default all) at their current step."""
        spec, n = self.spec, self.spec.plant.n_states
        step = self.step_index if index is None else self.step_index[index]
        index = self._rows if index is None else index
        if self.delayed:
            shown = np.maximum(step - take(self.delay, index, step) + self.lag0[index], 0)
            measured = take(self.states, index, shown % self.states.shape[1])
        else:
            measured = self.x if index is self._rows else self.x[index]
        if self.sensor is not None:
            measured = measured + spec.sensor_noise_std * take(self.sensor, index, step)
        # One buffer filled in place: the parts' concatenation and a gather of every row cost a
        # tenth of the step at N = 1024.
        obs = np.empty((len(step), spec.observation_size))
        np.divide(measured, spec.state_scale, out=obs[:, :n])
        obs[:, n] = 2.0 * step / spec.n_steps - 1.0
        if spec.history_length:
            sent = step[:, None] - 1 - np.arange(spec.history_length)
            recent = take(self.commands, index[:, None], sent % self.commands.shape[1])
            obs[:, n + 1:] = np.where((sent >= 0)[..., None], recent / spec.action_scale, 0.0).reshape(len(step), -1)
        np.maximum(obs, -OBSERVATION_LIMIT, out=obs)
        return np.minimum(obs, OBSERVATION_LIMIT, out=obs).astype(np.float32)
