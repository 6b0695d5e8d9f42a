"""``LightSailVectorEnv``: N light sails stepped as one NumPy batch (planar, any family's keywords
through :meth:`LightSailVectorEnv.of_keywords`, or a bare spec through :meth:`LightSailVectorEnv.from_spec`).

The same episode core (:class:`~sail_env.core.EpisodeCore`) as :class:`LightSailEnv`,
with N environments: environment ``i`` seeded with ``seed + i`` plays exactly the
episodes a ``LightSailEnv`` (or ``LightSail3DEnv``) seeded with ``seed + i`` plays, to
round-off. Every task and keyword is supported (light delay with per-environment command
queues, sensor noise, jitter, push noise, cut-off jitter, parameter spread with
per-environment models); the 3D ids reach it through ``sail_env.envs.rigid3d.rigid3d_vector_env``.

    envs = gym.make_vec("LightSail-v0", num_envs=1024, vectorization_mode="vector_entry_point")

Autoreset is ``SAME_STEP``: when an episode ends, the returned observation already
belongs to the next episode; the last one's is in ``info["final_obs"]`` and its score in
``info["final_info"]`` (``terminal_pointing_rad``, ``terminal_envelope_rad``,
``is_success``, ``diverged``, ``cutoff_s``; ``expected_success`` with ``expected_paths``), each with its ``_key`` mask, as Gymnasium's
``SyncVectorEnv`` reports them. No other info is built per step.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from sail_env.core.episode import OBSERVATION_LIMIT, EpisodeCore
from sail_env.core.spec import EpisodeSpec
from sail_env.core.state import EpisodeState
from sail_env.envs.options import SpecMaker, parse_reset
from sail_env.envs.planar import planar_spec
from sail_env.physics.planar.config import SailConfig


class LightSailVectorEnv(VectorEnv):
    """N planar light-sail episodes in one NumPy batch; the arguments are ``LightSailEnv``'s."""

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int = 1, config: SailConfig | str = "seed", render_mode: str | None = None,
                 **keywords: Any) -> None:
        self._start(num_envs, render_mode, planar_spec, {"config": config, **keywords})

    @classmethod
    def of_keywords(cls, make_spec: SpecMaker, keywords: dict[str, Any], num_envs: int = 1,
                    render_mode: str | None = None) -> LightSailVectorEnv:
        """N episodes of the task ``make_spec(**keywords)`` (how the 3D ids get their vector env)."""
        envs = cls.__new__(cls)
        envs._start(num_envs, render_mode, make_spec, keywords)
        return envs

    @classmethod
    def from_spec(cls, spec: EpisodeSpec, num_envs: int = 1, render_mode: str | None = None) -> LightSailVectorEnv:
        """N episodes of any task's :class:`EpisodeSpec`; it knows no keywords, so that ``reset`` cannot
        change them (``options["params"]`` is refused)."""
        envs = cls.__new__(cls)
        envs._start(num_envs, render_mode, None, None, spec)
        return envs

    def _start(self, num_envs: int, render_mode: str | None, make_spec: SpecMaker | None,
               keywords: dict[str, Any] | None, spec: EpisodeSpec | None = None) -> None:
        """Set up the spaces and the core of the task ``make_spec(**keywords)`` (or of a bare ``spec``)."""
        spec = make_spec(**keywords) if spec is None else spec
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise ValueError(f"LightSailVectorEnv does not render; render_mode must be None, got {render_mode!r}")
        self.make_spec, self.keywords, self.episode_spec = make_spec, keywords, spec
        self.num_envs = int(num_envs)
        self.render_mode = None
        self.single_action_space = spaces.Box(-1.0, 1.0, (spec.plant.n_inputs,), np.float32)
        self.single_observation_space = spaces.Box(-OBSERVATION_LIMIT, OBSERVATION_LIMIT,
                                                   (spec.observation_size,), np.float32)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.core = EpisodeCore(spec, self.num_envs)
        self._rngs: list[np.random.Generator] | None = None
        self._all = np.arange(self.num_envs)
        self._truncated = np.zeros(self.num_envs, dtype=bool)

    @property
    def state(self) -> EpisodeState:
        """The episodes' arrays (:class:`~sail_env.core.state.EpisodeState`): all the env reads of the core."""
        return self.core.state

    def reset(self, *, seed: int | Sequence[int | None] | None = None,
              options: Mapping[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset every environment; ``seed`` an int seeds environment ``i`` with ``seed + i``.

        ``options={"initial_state": {...}}`` starts every environment from that state
        (``LightSailEnv``'s keys), ``{"initial_state": array (N, n)}`` each from its row.
        ``options={"params": {...}}`` changes the task of every environment (one task for the batch)
        for these episodes and the later ones, the autoreset's too, as ``LightSailEnv``'s Reset Options
        say: environment ``i`` then plays as a vector env made with those keywords; a refused reset
        changes nothing. A vector env made by :meth:`from_spec` knows no keywords and refuses it.
        """
        # Every argument checked before anything changes: a refused reset leaves the envs as they were.
        checked = parse_reset(seed, options, self.num_envs, True, self.episode_spec, self.keywords, self.make_spec)
        if checked.keywords is not None:
            self.keywords, self.episode_spec = checked.keywords, checked.spec
            self.core = EpisodeCore(checked.spec, self.num_envs)
        super().reset(seed=checked.seeds[0])
        if self._rngs is None or seed is not None:
            self._rngs = [seeding.np_random(s)[0] for s in checked.seeds]
        self.core.reset(self._all, self._rngs, checked.states)
        return self.core.observe(), {"state": self.state.x.copy(), "t": self._times()}

    def _times(self) -> np.ndarray:
        """Each environment's flight time [s] (the single env's ``info["t"]``)."""
        spec = self.episode_spec
        return spec.config.control_start_s + self.state.step * spec.dt

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        # The kernel refuses non-finite actions (ValueError) before it changes anything.
        actions = np.asarray(actions)
        if actions.shape != self.action_space.shape or actions.dtype.kind not in "fiu":
            raise ValueError(f"actions must be real numbers of shape {self.action_space.shape}, got {actions.shape}")
        if self._rngs is None:
            raise RuntimeError("step() called before reset()")
        result = self.core.step(actions)
        obs, terminated = result.observation, result.terminated.astype(bool)
        reward = result.reward.copy()
        info: dict[str, Any] = {}
        if terminated.any():
            done = np.flatnonzero(terminated)
            final_obs = np.full(self.num_envs, None, dtype=object)
            final_obs[done] = list(obs[done])
            scores = {"terminal_pointing_rad": result.terminal_pointing_rad,
                      "terminal_envelope_rad": result.terminal_envelope_rad, "is_success": result.success,
                      "diverged": result.diverged.astype(bool), "cutoff_s": self.state.cutoff_s.copy()}
            if result.expected_success is not None:
                scores["expected_success"] = result.expected_success
            final_info: dict[str, Any] = {}
            for key, value in scores.items():
                final_info[key], final_info[f"_{key}"] = value, terminated
            info = {"final_obs": final_obs, "_final_obs": terminated, "final_info": final_info,
                    "_final_info": terminated}
            self.core.reset(done, [self._rngs[i] for i in done])
            obs[done] = self.core.observe(done)
        return obs, reward, terminated, self._truncated.copy(), info
