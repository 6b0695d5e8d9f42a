"""LightSail-v0 and its planar siblings: keep a laser-driven light sail on its beam."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from sail_env.core.episode import OBSERVATION_LIMIT, EpisodeCore
from sail_env.core.spec import EpisodeSpec, task_spec
from sail_env.core.state import EpisodeState
from sail_env.envs.options import parse_reset
from sail_env.envs.params import PlanarParams
from sail_env.envs.rendering import SailRenderer, axis_views
from sail_env.physics.planar.config import SailConfig

_ONE = np.zeros(1, dtype=np.int64)
#: Half-widths of the default uniform start distribution, ``(X, Vx, θ, ω)`` in SI.
DEFAULT_START_HALF_WIDTHS = (5e-3, 0.1, 2e-3, 1e-5)


def planar_spec(config: SailConfig | str = "seed", **keywords: Any) -> EpisodeSpec:
    """The :class:`EpisodeSpec` of the planar keywords (see :class:`LightSailEnv`): the sail's
    ``config`` (:class:`~sail_env.envs.params.PlanarParams`) and the episode keywords of
    :func:`~sail_env.core.spec.task_spec`; a bad value is a ``ValueError`` naming its keyword."""
    return task_spec(PlanarParams(config).make_plant, DEFAULT_START_HALF_WIDTHS, **keywords)


class LightSailEnv(gym.Env[np.ndarray, np.ndarray]):
    """
    ## Description

    A gram-scale light sail is pushed by a laser to 0.2 c (Breakthrough Starshot). It
    must leave the beam flying within 10 nrad of its target line, or it misses Proxima b
    by more than the Earth-Moon distance. The sail is the seed paper's spherical dish
    with a payload on struts (Team 258, MCM Problem A, eqs 16-19, corrected as in
    ``sail_env.physics.planar.model``); in the plane it has four states, and a curved dish
    makes a restoring force but never damps: the passive sail never forgets a
    perturbation. The agent steers the beam during the early flight (the *control
    window*), the rest of the beam time to cut-off is propagated exactly with the last
    command held, and the episode is scored by the flight direction at cut-off.

    The oscillation period is ~0.09 s and the beam time 600 s; stepping through all of
    it would take 10⁵ steps, so an episode is the window (default 200 steps of 5 ms,
    about 11 periods) plus one exact propagation. Because V⊥ keeps oscillating after
    control, the only way to score well at an uncertain cut-off time is to damp it.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``, scaled inside:

    | Num | Action | Physical range |
    |-----|--------|----------------|
    | 0 | beam lateral offset ``d`` at the sail | ± ``max_beam_offset_m`` (2 cm) |
    | 1 | beam tilt ``ψ`` | ± ``max_beam_tilt_rad`` (2 mrad) |

    Actions outside [-1, 1] are clipped; a NaN or infinite action raises ``ValueError``.
    In this planar model both act through the beam's landing point on the sail,
    ``d + Lc ψ`` (see ``sail_env.physics.planar.model``); the 3D model separates them.

    ## Observation Space

    ``Box(-1e3, 1e3, (5 + 2 n,), float32)`` (clipped to that range):

    | Num | Observation | Scale |
    |-----|-------------|-------|
    | 0 | lateral offset X of the CoM | / 1 cm |
    | 1 | lateral speed Vx | / (1 cm · ω₀) |
    | 2 | tilt θ of the sail axis | / 1 mrad |
    | 3 | tilt rate ω | / (1 mrad · ω₀) |
    | 4 | progress through the control window | -1 at start, +1 at the end |
    | 5.. | the last ``n`` commands sent, newest first (normalised, 2 each) | as actions |

    ω₀ is the model's fastest rate (70.7 rad/s for the seed sail). ``n`` is 0 without
    light delay; with it, ``n`` is the largest round trip in control steps, so the
    commands still in flight are part of the observation (what a delay-compensating
    controller would predict with). With ``light_delay`` entries 0-3 are the state
    as seen ``D/c`` ago, and with ``sensor_noise_std`` they are noisy.

    ## Rewards

    With ``ρ(p) = clip(log10(p / 10 nrad), -2, 3)``:

    - each step: ``-ρ(envelope) / N`` where *envelope* is the largest ``|V⊥|/Vz`` the
      sail would reach with the current beam command held (``N`` = steps in the window);
    - at the last step, in addition: ``-ρ(pointing at cut-off) + 1`` if it succeeds;
    - on divergence: ``-10`` and the episode terminates.

    On LightSail-v0 LQR collects about ``+4.9`` per episode, the passive sail ``+0.9``.

    ## Starting State

    At launch, uniform in ``X ∈ ±5 mm, Vx ∈ ±0.1 m/s, θ ∈ ±2 mrad, ω ∈ ±10 µrad/s``
    (``start_half_widths``; the deep-dish tasks use ±3 cm and ±0.6 m/s laterally, see
    ``sail_env.tasks``); ``reset(options={"initial_state": {...}})`` sets it instead
    (missing keys are zero; it must lie inside ``episode_spec.start_limits``, as must
    ``start_half_widths``: ``|X|`` within the aperture, ``|θ|`` within the small-angle regime
    and the beam, and speeds that do not leave them within one step). With ``control_start_s > 0`` the state is propagated, with
    the disturbances, from launch to the start of control. At the seed sail, a tilt θ
    moves the equilibrium to ``X = θ (2R − Lc)`` = 2 cm per 2 mrad, so the passive sail
    fails on about 40 % of these starts.

    ## Episode End

    1. Termination: the end of the control window; the flight is then scored at cut-off.
       ``info["terminal_pointing_rad"]``, ``info["terminal_envelope_rad"]`` and
       ``info["is_success"]`` (pointing ≤ 10 nrad) are set; with ``expected_paths=K``,
       ``info["expected_success"]`` too: the share of ``K`` further coasts from the window's end
       that succeed, an unbiased estimate of the probability of success given it (0 after a
       divergence in the window; the episode's own numbers are the same with it or without).
    2. Termination: divergence: the sail leaves the beam (``|X|`` or ``|Lc θ|`` beyond
       the aperture radius) or the small-angle regime (``|θ| > 0.05 rad``), during the
       window or the coast. ``info["diverged"] = True``, ``is_success = False``.

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``config`` | ``"seed"`` | a :class:`SailConfig` or a preset name (``seed``, ``deep_dish``, ``flat``) |
    | ``max_beam_offset_m`` | 0.02 | beam offset at action +1 |
    | ``max_beam_tilt_rad`` | 0.002 | beam tilt at action +1 |
    | ``start_half_widths`` | see above | uniform start half-widths ``(X, Vx, θ, ω)`` |
    | ``expected_paths`` | 0 | further coasts behind ``info["expected_success"]`` (0 … 1024; 0: not given) |
| ``sensor_noise_std``, ``beam_jitter_m``, ``push_noise``, ``cutoff_jitter_s``, ``light_delay``, ``parameter_spread`` | off | see :class:`~sail_env.physics.randomisation.Randomisation`; ``light_delay``: :class:`~sail_env.core.EpisodeSpec` |
    | ``render_mode`` | None | ``"rgb_array"``; ``gym.make(..., render_mode="human")`` shows its frames in a window through Gymnasium's ``HumanRendering`` (needs pygame) |

    ``info["state"]`` holds the true state in SI (``x``, ``vx``, ``theta``, ``omega``) and
    ``info["t"]`` the flight time, at every step.

    ## Reset Options

    ``reset(seed=..., options={...})``, every key optional (:mod:`sail_env.envs.options`):

    - ``"initial_state"``: the launch state, a dict by state name (see Starting State).
    - ``"params"``: domain randomisation: a dict of the keywords above (or a params dataclass,
      :mod:`sail_env.envs.params`, which sets all of its family's own keywords) over the env's current
      ones, for this episode **and the later ones** (``env.unwrapped.keywords`` holds them; give the
      old values to go back). The env then plays exactly as ``gym.make(id, **keywords)`` would, the
      same seed giving the same numbers, and ``env.unwrapped.episode_spec`` is the new task's (a
      controller designed on the old one should design again). Each randomisation keyword
      (:mod:`sail_env.physics.randomisation`) and the sail's own may change; a change of the spaces is
      refused with one ``ValueError`` naming the keywords (``light_delay``, whose commands in flight
      are part of the observation; with light delay, anything that changes the largest round trip;
      the 3D ``power_control`` on or off, an action). A refused reset changes nothing. Such a reset
      builds the task again as ``gym.make`` does: about 1–3 ms for a planar task and 20–50 ms for a 3D
      one (its sail tables memoised), against 0.1–3 ms for a reset without params.

    ``env.unwrapped.episode_spec`` (:class:`~sail_env.core.EpisodeSpec`) is what controllers
    design on: the nominal model, the step, the scales and the light-delay rule. The episode
    itself runs in :class:`~sail_env.core.EpisodeCore`, the same code as
    :class:`~sail_env.envs.vector.LightSailVectorEnv` with one environment.

    ## Version History

    * v0 (lightsail-gym 0.2.0): the end state of a noisy coast (and of the pre-control flight) is
      drawn with the symmetric square root of its correlation matrix instead of ``V √Λ`` from an
      eigen-decomposition, whose eigenvector signs depended on the LAPACK driver and the CPU's BLAS
      kernel (docs/physics.md §3). Episodes with beam jitter or push noise over the coast
      (``LightSailRealistic-v0``) draw other end states for the same seed, from the same
      distribution; noise-free episodes are unchanged to the last bit.
    * v0 (lightsail-gym 0.1.0): initial release.
    """

    # No window of its own: gym.make(..., render_mode="human") wraps the rgb_array frames in Gymnasium's
    # HumanRendering, where pygame and a display are (a matplotlib window showed nothing on a machine without one).
    metadata = {"render_modes": ["rgb_array"], "render_fps": 30}
    #: What builds the spec of the family's keywords (the 3D env's: ``rigid3d_spec``).
    make_spec = staticmethod(planar_spec)

    def __init__(self, config: SailConfig | str = "seed", render_mode: str | None = None, **keywords: Any) -> None:
        self._start({"config": config, **keywords}, render_mode)

    def _start(self, keywords: dict[str, Any], render_mode: str | None) -> None:
        """Set up the spaces and the core of the task of ``keywords`` (every task's env is this one with its spec)."""
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        spec = self.make_spec(**keywords)
        self.render_mode = render_mode
        self.action_space = spaces.Box(-1.0, 1.0, (spec.plant.n_inputs,), np.float32)
        self.observation_space = spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT, (spec.observation_size,),
                                            np.float32)
        self._action_shape = self.action_space.shape
        self._renderer: SailRenderer | None = None
        self._trajectory: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._play(keywords, spec)

    def _play(self, keywords: dict[str, Any], spec: EpisodeSpec) -> None:
        """Play the task of ``keywords``, whose spec is ``spec`` (at construction, and at a reset with
        ``options["params"]``: its spaces are the env's)."""
        self.keywords, self.episode_spec = keywords, spec
        self.core = EpisodeCore(spec, 1)
        # What the step's hot path reads (an attribute lookup each, not a chain).
        self._state_names = spec.plant.state_names
        self._batch_observation = (1, spec.observation_size)
        self._start_s, self._dt = spec.config.control_start_s, spec.dt

    @property
    def state(self) -> EpisodeState:
        """The episode's arrays (:class:`~sail_env.core.state.EpisodeState`): all the env reads of the core."""
        return self.core.state

    def reset(self, *, seed: int | None = None,
              options: Mapping[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        # Every argument checked before anything changes: a refused reset leaves the env as it was.
        checked = parse_reset(seed, options, 1, False, self.episode_spec, self.keywords, self.make_spec)
        if checked.keywords is not None:
            self._play(checked.keywords, checked.spec)
        super().reset(seed=checked.seeds[0])
        self.core.reset(_ONE, [self.np_random], checked.states)
        if self.render_mode is not None:
            self._trajectory = [(self._time(), self.state.x[0].copy(), np.zeros(self.episode_spec.plant.n_inputs))]
        return self.core.observe()[0], self._info()

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        # The kernel refuses a non-finite action (ValueError) and a finished episode (RuntimeError)
        # before it changes anything.
        action = np.asarray(action)
        if action.shape != self._action_shape or action.dtype.kind not in "fiu":
            size = self._action_shape[0]
            raise ValueError(f"action must be {size} real numbers (shape ({size},)), got {action!r}")
        core, obs = self.core, np.empty(self._batch_observation, dtype=np.float32)
        try:
            ended = core.advance(action[None], obs)  # the batch of one (the shape was checked above)
        except ValueError:
            raise ValueError(f"action must be finite, got {action}") from None
        state = core.state
        info = {"state": dict(zip(self._state_names, state.x.tolist()[0])),  # no view of the row: ~0.3 µs less
                "t": self._start_s + state.step.item(0) * self._dt}
        if ended:
            result = core.score()
            info.update(terminal_pointing_rad=float(result.terminal_pointing_rad[0]),
                        terminal_envelope_rad=float(result.terminal_envelope_rad[0]),
                        is_success=bool(result.success[0]), diverged=bool(state.diverged[0]),
                        cutoff_s=float(state.cutoff_s[0]))
            if result.expected_success is not None:
                info["expected_success"] = float(result.expected_success[0])
            if not state.diverged[0]:
                info.update(envelope_rad=float(state.envelope[0]), terminal_state=self._named(result.terminal_state[0]))
        else:
            info["envelope_rad"] = state.envelope.item(0)
        if self.render_mode is not None:
            self._trajectory.append((info["t"], state.x[0].copy(), state.applied[0].copy()))
        return obs[0], state.reward.item(0), ended > 0, False, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; set render_mode='rgb_array'")
            return None
        if self._renderer is None:
            self._renderer = SailRenderer(len(axis_views(self.episode_spec)))
        return self._renderer.draw(self.episode_spec, self._trajectory, float(self.state.speed_at_cutoff[0]))

    def close(self) -> None:
        self._renderer = None

    @property
    def dt(self) -> float:
        """The control step [s]."""
        return self.episode_spec.dt

    def _time(self) -> float:
        spec = self.episode_spec
        return spec.config.control_start_s + int(self.state.step[0]) * spec.dt  # as the step's info["t"]

    def _info(self) -> dict[str, Any]:
        return {"state": self._named(self.state.x[0]), "t": self._time()}

    def _named(self, state: np.ndarray) -> dict[str, float]:
        return dict(zip(self._state_names, state.tolist()))
