"""PPO written for the JAX backend: the training loop is jitted whole (rollout by ``lax.scan`` over
``vmap``-ed environments, GAE by a reverse scan, minibatch epochs with ``optax``), so ``vmap`` over
keys trains many seeds at once (PureJaxRL's design; Lu et al. 2022). The method is PPO with the
clipped objective (Schulman et al. 2017) as CleanRL's continuous-action script runs it: separate tanh
actor and critic networks, a state-independent log standard deviation, advantages normalised per
minibatch, the learning rate annealed linearly (to 0, or to a floor: ``final_learning_rate``).

A task whose unknowns must be read from the observation stream needs a policy with memory; three kinds:

- ``history = H``: actor and critic see the last H observations side by side (zeros before the
  episode's first), a wrapper of the observation stream in the loop's carry (:class:`Memory`);
- ``recurrent = R``: actor and critic each put a GRU of R units between their tanh layers and their
  output, its state carried through the rollout and zeroed at each episode's start; the update
  re-runs it over each environment's whole rollout from the state it began with, so its minibatches
  are sets of environments (PureJaxRL's recurrent PPO does the same). Actor and critic keep separate
  GRUs as they keep separate layers: the value loss then cannot pull the actor's memory towards
  what predicts the return (separate networks did better in Andrychowicz et al. 2021's study of
  on-policy choices), and the exported actor stands alone.

- ``episode_mean``: actor and critic also see the mean of the episode's observations so far (the
  newest included), a memory that integrates: of the commands shown in the observation, the mean is
  what the sail needed on average, a constant force's estimate (a PI controller's integral, which a
  window of H observations cannot form).

All may be combined; ``history = 1, recurrent = 0, episode_mean = False`` is the memoryless MLP.

On a task with spread the episode's unknowns are drawn at reset (:attr:`sail_env.jax.env.EnvParams.factors`).
``privileged_critic`` lets the critic see them beside its memory: the asymmetric actor-critic (Pinto et
al. 2018), whose value, no longer an average over the draws the observations cannot tell apart, gives
each episode's advantages less noise. Only the critic sees them, and only in training: the actor, what
is exported and played, sees what any controller sees. ``privileged_actor`` gives them to the actor too:
a diagnostic (what the learner reaches when it need not infer them), whose actor no env can play.

The Gaussian's log std is one learnt vector, the same in every state (CleanRL's), unless
``state_dependent_std``: the actor then also outputs each action's variation about it (brax's PPO
outputs its scale so), clipped to :data:`LOG_STD_RANGE`. A task scored at an episode's end to 10 nrad
may need the noise of exploration large while the sail's start is being damped and small at the
end: with one σ for both, the rollouts' stochastic success on ``LightSailUncertain-v2`` stayed at 7–14 %
where the deterministic policy scored 70–80 %. A σ per state raised it to 63 %, and left the deterministic
policy where it was (docs/learners.md, sixth points). Only the mean is exported.

The env clips each action to [-1, 1]. By default, as CleanRL's and PureJaxRL's PPO, the likelihood
is the Gaussian's at the unclipped sample, blind to the clip: the objective is then not the policy
the env plays, and here the deterministic actor got worse late in a run while its mean drifted out
of the box (a 10⁷-step run on ``LightSailUncertain-v2``: beyond the box 22 % of the time at its
best, 43 % at the end, its success 77 % → 31 %; docs/learners.md). ``clipped_likelihood`` uses the
likelihood of the action the env plays instead, the clipped Gaussian's: the density inside the box,
the tail's mass at a bound (the clipped action policy gradient, Fujita & Maeda 2018). With it, the
runs' deterministic actors still drifted out of the box as they fell (five seeds of the uncertain task,
the 3D task); ``tanh_mean`` keeps the actor's mean inside it (the Gaussian's mean is the tanh of the
last layer; the sample is still clipped, so a bound keeps its mass), and the deterministic action
``mean`` then needs no clip.

The loop runs in chunks of updates (:func:`make_chunks`), whose state (:class:`RunState`) is all a
run needs to continue, so ``train_jax.py`` checkpoints between chunks; the annealing reads the
optimiser's own step count, which that state carries.

The trained actor is plain arrays (:func:`actor_arrays`): :class:`agents.mlp_policy.MlpPolicyAgent`
plays it in NumPy, so ``evaluate.py`` reports it on the Gym envs beside the other agents.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

#: The two networks, each with its own layers (and GRU).
PARTS = ("actor", "critic")


@dataclasses.dataclass(frozen=True)
class PPOConfig:
    """The hyperparameters (CleanRL's names; the defaults train ``LightSail-v0``)."""

    total_timesteps: int = 200_000  # LightSail-v0: 16 of 16 seeds at 100 % from 150k (deterministic, 1,000 episodes)
    num_envs: int = 64
    num_steps: int = 64  # steps per environment per rollout
    update_epochs: int = 4
    num_minibatches: int = 8
    learning_rate: float = 1e-3
    anneal_lr: bool = True
    final_learning_rate: float = 0.0  # where the annealing ends (a floor keeps a long run learning to its end)
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_coef: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    hidden: tuple[int, ...] = (64, 64)
    log_std_init: float = -1.0
    history: int = 1  # observations the networks see, the newest last (1: the current one alone)
    recurrent: int = 0  # units of each network's GRU (0: none)
    episode_mean: bool = False  # the networks also see the mean of the episode's observations so far
    clipped_likelihood: bool = False  # the likelihood of the clipped action the env plays (Fujita & Maeda 2018)
    tanh_mean: bool = False  # the actor's mean is the tanh of its last layer: inside [-1, 1]
    privileged_critic: bool = False  # the critic also sees the episode's parameter factors (training only)
    privileged_actor: bool = False  # the actor too (a diagnostic: no env shows them to a policy)
    state_dependent_std: bool = False  # the actor also outputs each action's log std's variation about log_std

    def __post_init__(self) -> None:
        for name in ("total_timesteps", "num_envs", "num_steps", "update_epochs", "num_minibatches", "history"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if not (isinstance(self.recurrent, int) and self.recurrent >= 0):
            raise ValueError(f"recurrent must be an integer >= 0 (0: no GRU), got {self.recurrent!r}")
        if not (isinstance(self.hidden, tuple) and self.hidden
                and all(isinstance(size, int) and size >= 1 for size in self.hidden)):
            raise ValueError(f"hidden must be a tuple of one or more layer sizes >= 1, got {self.hidden!r}")
        if self.recurrent and self.num_envs % self.num_minibatches:
            raise ValueError(f"num_envs ({self.num_envs}) must be a multiple of num_minibatches "
                             f"({self.num_minibatches}): a recurrent policy's minibatches are sets of environments")
        if self.batch_size % self.num_minibatches:
            raise ValueError(f"num_envs * num_steps ({self.batch_size}) must be a multiple of num_minibatches "
                             f"({self.num_minibatches})")
        if self.total_timesteps < self.batch_size:
            raise ValueError(f"total_timesteps must be >= num_envs * num_steps ({self.batch_size}), "
                             f"got {self.total_timesteps}")
        for name, low, high in (("gamma", 0.0, 1.0), ("gae_lambda", 0.0, 1.0), ("clip_coef", 0.0, 1.0)):
            if not low < getattr(self, name) <= high:
                raise ValueError(f"{name} must be in ({low}, {high}], got {getattr(self, name)}")
        for name in ("learning_rate", "max_grad_norm"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0 <= self.final_learning_rate <= self.learning_rate:
            raise ValueError(f"final_learning_rate must be in [0, learning_rate = {self.learning_rate}], "
                             f"got {self.final_learning_rate}")
        if self.final_learning_rate and not self.anneal_lr:
            raise ValueError("final_learning_rate is where the annealing ends: it needs anneal_lr")
        if not self.ent_coef >= 0:
            raise ValueError(f"ent_coef must be >= 0, got {self.ent_coef}")
        if not np.isfinite(self.log_std_init):
            raise ValueError(f"log_std_init must be a finite number, got {self.log_std_init}")

    @property
    def batch_size(self) -> int:
        return self.num_envs * self.num_steps

    @property
    def num_updates(self) -> int:
        return self.total_timesteps // self.batch_size


def _mlp_init(key: jax.Array, sizes: tuple[int, ...], last_scale: float) -> list[dict[str, jax.Array]]:
    """Orthogonal weights (gain √2, the last layer ``last_scale``) and zero biases."""
    layers = []
    for i, (fan_in, fan_out) in enumerate(zip(sizes[:-1], sizes[1:])):
        key, sub = jax.random.split(key)
        gain = last_scale if i == len(sizes) - 2 else np.sqrt(2.0)
        layers.append({"w": jax.nn.initializers.orthogonal(gain)(sub, (fan_in, fan_out), jnp.float32),
                       "b": jnp.zeros(fan_out, jnp.float32)})
    return layers


def _gru_init(key: jax.Array, in_size: int, size: int) -> dict[str, jax.Array]:
    """A GRU's weights, its three gates' (reset, update, candidate) side by side: orthogonal, each
    gate's recurrent block on its own; zero biases."""
    in_key, *gate_keys = jax.random.split(key, 4)
    orthogonal = jax.nn.initializers.orthogonal()
    return {"wx": orthogonal(in_key, (in_size, 3 * size), jnp.float32),
            "wh": jnp.concatenate([orthogonal(k, (size, size), jnp.float32) for k in gate_keys], axis=1),
            "bx": jnp.zeros(3 * size, jnp.float32), "bh": jnp.zeros(3 * size, jnp.float32)}


def _gru(cell: dict[str, jax.Array], hidden: jax.Array, x: jax.Array) -> jax.Array:
    """One GRU step (Cho et al. 2014, in the form where the reset gate scales the recurrent part of
    the candidate, bias included)."""
    reset_x, update_x, candidate_x = jnp.split(x @ cell["wx"] + cell["bx"], 3, axis=-1)
    reset_h, update_h, candidate_h = jnp.split(hidden @ cell["wh"] + cell["bh"], 3, axis=-1)
    reset = jax.nn.sigmoid(reset_x + reset_h)
    update = jax.nn.sigmoid(update_x + update_h)
    candidate = jnp.tanh(candidate_x + reset * candidate_h)
    return (1.0 - update) * candidate + update * hidden


def init_network(key: jax.Array, obs_size: int, action_size: int, config: PPOConfig,
                 factors: int = 0) -> dict[str, Any]:
    """Actor and critic for observations of ``obs_size`` entries (each sees ``config.history`` of them,
    and their episode's mean with ``config.episode_mean``), and a privileged one the ``factors``
    parameter factors of the episode's draw."""
    def part(key: jax.Array, out_size: int, last_scale: float, privileged: bool) -> dict[str, Any]:
        in_size = (config.history + config.episode_mean) * obs_size + privileged * factors
        if not config.recurrent:
            return {"layers": _mlp_init(key, (in_size, *config.hidden, out_size), last_scale)}
        body_key, gru_key, head_key = jax.random.split(key, 3)
        body = _mlp_init(body_key, (in_size, *config.hidden), np.sqrt(2.0))
        head = _mlp_init(head_key, (config.recurrent, out_size), last_scale)
        return {"layers": body + head, "gru": _gru_init(gru_key, config.hidden[-1], config.recurrent)}

    actor_key, critic_key = jax.random.split(key)
    actor_out = 2 * action_size if config.state_dependent_std else action_size
    return {"actor": part(actor_key, actor_out, 0.01, config.privileged_actor),
            "critic": part(critic_key, 1, 1.0, config.privileged_critic),
            "log_std": jnp.full(action_size, config.log_std_init, jnp.float32)}


def apply(part: dict[str, Any], x: jax.Array, hidden: jax.Array | None,
          start: jax.Array | None) -> tuple[jax.Array, jax.Array | None]:
    """One step of the actor or the critic (``part``) on inputs ``x`` (…, in): its tanh layers, its GRU
    if it has one (from ``hidden`` (…, R), zeroed where ``start`` (…): an episode's first input), its
    linear output. Returns the output and the GRU's state after ``x`` (``hidden`` without a GRU)."""
    layers = part["layers"]
    for layer in layers[:-1]:
        x = jnp.tanh(x @ layer["w"] + layer["b"])
    if "gru" in part:
        hidden = _gru(part["gru"], jnp.where(start[..., None], 0.0, hidden), x)
        x = hidden
    return x @ layers[-1]["w"] + layers[-1]["b"], hidden


#: With ``state_dependent_std``, the range the Gaussian's log std is clipped to (σ from 0.0067 to 2.7 in
#: action units): a state's σ cannot vanish, where the likelihood ratios of its actions would explode.
LOG_STD_RANGE = (-5.0, 1.0)


def _gaussian(output: jax.Array, log_std: jax.Array, config: PPOConfig) -> tuple[jax.Array, jax.Array]:
    """The actor's ``output`` as the Gaussian's mean and log std. The mean: its first outputs, squashed
    into (-1, 1) with ``config.tanh_mean``. The log std: ``log_std`` (the network's own, learnt), plus
    with ``config.state_dependent_std`` the actor's other outputs, each action's variation about it
    (clipped to :data:`LOG_STD_RANGE`)."""
    size = log_std.shape[-1]
    mean = output[..., :size]
    if config.state_dependent_std:
        log_std = jnp.clip(log_std + output[..., size:], *LOG_STD_RANGE)
    return (jnp.tanh(mean) if config.tanh_mean else mean), log_std


def _factors(env, env_params, state, config: PPOConfig) -> jax.Array:
    """The parameter factors (N, F) of the episodes in ``state`` where a network is privileged; without,
    (N, 0): nothing to gather on every step or to carry through the update."""
    if not (config.privileged_actor or config.privileged_critic):
        return jnp.zeros((state.draw.shape[0], 0), jnp.float32)
    return env.draw_factors(state, env_params).astype(jnp.float32)


def _seen(config: PPOConfig, part: str, inputs: jax.Array, factors: jax.Array) -> jax.Array:
    """What network ``part`` sees: the memory's ``inputs``, then the episode's parameter ``factors``
    where it is privileged (``config.privileged_actor``, ``config.privileged_critic``)."""
    privileged = config.privileged_actor if part == "actor" else config.privileged_critic
    return jnp.concatenate([inputs, factors], axis=-1) if privileged else inputs


def _unroll(part: dict[str, Any], hidden: jax.Array | None, x: jax.Array, start: jax.Array) -> jax.Array:
    """``part``'s outputs over a rollout's inputs ``x`` (T, n, in) with their ``start`` flags (T, n),
    from the GRU's state before them (n, R); without a GRU, all at once, whatever ``x``'s shape."""
    if "gru" not in part:
        return apply(part, x, None, None)[0]

    def step(hidden: jax.Array, inputs: tuple[jax.Array, jax.Array]) -> tuple[jax.Array, jax.Array]:
        out, hidden = apply(part, inputs[0], hidden, inputs[1])
        return hidden, out

    return jax.lax.scan(step, hidden, (x, start))[1]


class Memory(NamedTuple):
    """What the networks carry from one step to the next, per environment (leading axis N)."""

    obs: jax.Array  # (N, history * D): the last observations, the newest last, zeros before the episode's first
    start: jax.Array  # (N,): the newest observation is its episode's first
    hidden: dict[str, jax.Array | None]  # per part, its GRU's state (N, R) before the newest observation
    mean: jax.Array | None  # (N, D) with episode_mean: the mean of the episode's observations, the newest included
    seen: jax.Array | None  # (N,) with episode_mean: how many observations that mean is of

    @classmethod
    def first(cls, obs: jax.Array, config: PPOConfig) -> Memory:
        """The memory of episodes that begin with ``obs`` (N, D)."""
        count, size = obs.shape
        zeros = jnp.zeros((count, config.recurrent), jnp.float32) if config.recurrent else None
        hidden = {part: zeros for part in PARTS}
        mean, seen = (jnp.zeros_like(obs), jnp.zeros(count, obs.dtype)) if config.episode_mean else (None, None)
        empty = cls(jnp.zeros((count, config.history * size), obs.dtype), jnp.ones(count, bool), hidden, mean, seen)
        return empty.next(obs, empty.start, hidden)

    @property
    def inputs(self) -> jax.Array:
        """What the networks see: the last observations, then the episode's mean if kept."""
        return self.obs if self.mean is None else jnp.concatenate([self.obs, self.mean], axis=-1)

    def next(self, obs: jax.Array, start: jax.Array, hidden: dict[str, jax.Array | None]) -> Memory:
        """After a step: ``obs`` (N, D) appended and the oldest dropped, all older ones zeroed where
        ``start`` (the env reset there: its autoreset's first observation), and taken into the
        episode's mean (which restarts there); ``hidden`` the GRUs' states after the previous observation."""
        kept = jnp.where(start[:, None], 0.0, self.obs)[:, obs.shape[-1]:]
        mean, seen = self.mean, self.seen
        if mean is not None:
            seen = jnp.where(start, 1.0, seen + 1.0)
            mean = jnp.where(start[:, None], obs, mean + (obs - mean) / seen[:, None])
        return Memory(jnp.concatenate([kept, obs], axis=-1), start, hidden, mean, seen)


def _log_prob(mean: jax.Array, log_std: jax.Array, action: jax.Array, clipped: bool = False) -> jax.Array:
    """The log-likelihood of ``action`` under the diagonal Gaussian (``mean``, e^``log_std``), or with
    ``clipped`` under that Gaussian clipped to [-1, 1]: an action at a bound then has the mass of
    the tail beyond it."""
    std = jnp.exp(log_std)
    z = (action - mean) / std
    density = -0.5 * z * z - log_std - 0.5 * jnp.log(2 * jnp.pi)
    if clipped:
        density = jnp.where(action >= 1.0, jax.scipy.special.log_ndtr((mean - 1.0) / std),
                            jnp.where(action <= -1.0, jax.scipy.special.log_ndtr((-1.0 - mean) / std), density))
    return jnp.sum(density, axis=-1)


class Transition(NamedTuple):
    obs: jax.Array  # what the networks saw (:attr:`Memory.inputs`)
    factors: jax.Array  # the episode's parameter factors a privileged network saw beside them ((…, 0) if none)
    start: jax.Array  # that step began an episode
    action: jax.Array
    log_prob: jax.Array
    std: jax.Array  # the Gaussian's standard deviations the action was drawn with
    value: jax.Array
    reward: jax.Array
    done: jax.Array
    success: jax.Array  # 1 where an episode ended with success, else 0


class RunState(NamedTuple):
    """Everything a run carries from one update to the next: what a checkpoint holds."""

    network: dict[str, Any]
    opt_state: Any
    env_state: Any
    memory: Memory
    key: jax.Array
    update: jax.Array  # updates done


class Chunks(NamedTuple):
    """A run in pieces: ``run(init(key), n)`` makes ``n`` updates; ``run(run(s, a)[0], b)`` is bit for bit
    ``run(s, a + b)`` (on a CPU: ``train_jax.py``'s resume test). ``rollout(state)``: the state after one rollout, its transitions,
    and the GRUs' states before it, from which the update re-runs them (the start of an update)."""

    init: Callable[[jax.Array], RunState]
    run: Callable[[RunState, int], tuple[RunState, dict[str, jax.Array]]]
    rollout: Callable[[RunState], tuple[RunState, Transition, dict[str, jax.Array | None]]]


def learning_rate_at(config: PPOConfig, count: jax.Array) -> jax.Array:
    """The annealed learning rate of Adam's ``count``-th step: constant through each update's minibatch
    steps, from ``learning_rate`` at the first update linearly towards ``final_learning_rate`` at the
    end of the run."""
    done = count // (config.num_minibatches * config.update_epochs)
    return config.learning_rate - (config.learning_rate - config.final_learning_rate) * done / config.num_updates


def make_chunks(env, env_params, config: PPOConfig) -> Chunks:
    """A PPO run on ``env`` (a :class:`~sail_env.jax.env.SailEnv`, stepped by its ``step_batch``) in
    chunks of updates. Each update's metrics: the success rate of the episodes that ended in its
    rollout (NaN if none), the mean reward, and the exploration's standard deviation (the mean over
    its actions' components) over the rollout (``std``) and at the episodes' last steps
    (``std_at_end``: where they are scored; NaN if none ended)."""
    action_size = env.action_space(env_params).shape[0]
    obs_size = env.observation_space(env_params).shape[0]
    minibatch = config.batch_size // config.num_minibatches
    factors_size = env_params.factors.shape[-1]

    optimizer = optax.chain(optax.clip_by_global_norm(config.max_grad_norm),
                            optax.adam(functools.partial(learning_rate_at, config) if config.anneal_lr
                                       else config.learning_rate, eps=1e-5))

    def init(key: jax.Array) -> RunState:
        key, net_key, reset_key = jax.random.split(key, 3)
        network = init_network(net_key, obs_size, action_size, config, factors_size)
        obs, env_state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(reset_key, config.num_envs), env_params)
        return RunState(network, optimizer.init(network), env_state, Memory.first(obs, config), key,
                        jnp.zeros((), jnp.int32))

    def env_step(carry, _):
        network, env_state, memory, key = carry
        key, act_key, step_key = jax.random.split(key, 3)
        factors = _factors(env, env_params, env_state, config)
        output, actor_hidden = apply(network["actor"], _seen(config, "actor", memory.inputs, factors),
                                     memory.hidden["actor"], memory.start)
        mean, log_std = _gaussian(output, network["log_std"], config)
        action = mean + jnp.exp(log_std) * jax.random.normal(act_key, mean.shape)
        if config.clipped_likelihood:
            action = jnp.clip(action, -1.0, 1.0)  # what the env plays, and what its likelihood is of
        value, critic_hidden = apply(network["critic"], _seen(config, "critic", memory.inputs, factors),
                                     memory.hidden["critic"], memory.start)
        next_obs, env_state, reward, terminated, _, info = env.step_batch(
            jax.random.split(step_key, config.num_envs), env_state, action, env_params)
        transition = Transition(memory.inputs, factors, memory.start, action,
                                _log_prob(mean, log_std, action, config.clipped_likelihood),
                                jnp.broadcast_to(jnp.exp(log_std), action.shape), value[:, 0],
                                reward.astype(jnp.float32), terminated, terminated & info["is_success"])
        memory = memory.next(next_obs, terminated, {"actor": actor_hidden, "critic": critic_hidden})
        return (network, env_state, memory, key), transition

    def rollout(state: RunState) -> tuple[RunState, Transition, dict[str, jax.Array | None]]:
        (_, env_state, memory, key), transitions = jax.lax.scan(
            env_step, (state.network, state.env_state, state.memory, state.key), None, config.num_steps)
        return state._replace(env_state=env_state, memory=memory, key=key), transitions, state.memory.hidden

    def gae(transitions: Transition, last_value: jax.Array) -> tuple[jax.Array, jax.Array]:
        def back(carry, t: Transition):
            advantage, next_value = carry
            alive = 1.0 - t.done
            delta = t.reward + config.gamma * next_value * alive - t.value
            advantage = delta + config.gamma * config.gae_lambda * alive * advantage
            return (advantage, t.value), advantage

        _, advantages = jax.lax.scan(back, (jnp.zeros_like(last_value), last_value), transitions, reverse=True)
        return advantages, advantages + transitions.value

    def loss(network, hidden: dict[str, jax.Array | None], batch: Transition, advantages: jax.Array,
             targets: jax.Array) -> jax.Array:
        mean, log_std = _gaussian(_unroll(network["actor"], hidden["actor"],
                                          _seen(config, "actor", batch.obs, batch.factors), batch.start),
                                  network["log_std"], config)
        log_prob = _log_prob(mean, log_std, batch.action, config.clipped_likelihood)
        value = _unroll(network["critic"], hidden["critic"], _seen(config, "critic", batch.obs, batch.factors),
                        batch.start)[..., 0]
        ratio = jnp.exp(log_prob - batch.log_prob)
        advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
        policy_loss = -jnp.minimum(ratio * advantages,
                                   jnp.clip(ratio, 1 - config.clip_coef, 1 + config.clip_coef) * advantages).mean()
        value_loss = 0.5 * jnp.mean((value - targets) ** 2)
        # The Gaussian's entropy before the clip, also with the clipped likelihood: a bonus on the spread
        # alone. The clipped Gaussian's would add a density's entropy to the bounds' masses' (no common
        # measure): below σ = (2πe)^-½ ≈ 0.24 a mean far beyond a bound would score higher than any
        # spread inside the box, and the bonus would push the actor out of it.
        entropy = jnp.sum(log_std + 0.5 * jnp.log(2 * jnp.pi * jnp.e), axis=-1).mean()
        return policy_loss + config.vf_coef * value_loss - config.ent_coef * entropy

    def minibatches(key: jax.Array, hidden: dict[str, jax.Array | None], data: tuple) -> tuple:
        """The rollout (``data``: arrays (T, N, …)) cut into ``num_minibatches`` along a new leading
        axis, with the GRUs' states before it: shuffled steps for a memoryless policy; for a GRU, whole
        sequences of shuffled environments, as its forward re-runs them."""
        if not config.recurrent:
            order = jax.random.permutation(key, config.batch_size)
            flat = jax.tree.map(lambda a: a.reshape((config.batch_size,) + a.shape[2:])[order], data)
            return hidden, *jax.tree.map(lambda a: a.reshape((config.num_minibatches, minibatch) + a.shape[1:]), flat)
        order = jax.random.permutation(key, config.num_envs)
        envs = config.num_envs // config.num_minibatches
        split = jax.tree.map(lambda a: jnp.swapaxes(
            a[:, order].reshape((config.num_steps, config.num_minibatches, envs) + a.shape[2:]), 0, 1), data)
        return jax.tree.map(lambda h: h[order].reshape((config.num_minibatches, envs) + h.shape[1:]), hidden), *split

    def update(state: RunState, _):
        state, transitions, before = rollout(state)
        memory = state.memory
        seen = _seen(config, "critic", memory.inputs, _factors(env, env_params, state.env_state, config))
        last_value = apply(state.network["critic"], seen, memory.hidden["critic"], memory.start)[0][:, 0]
        advantages, targets = gae(transitions, last_value)

        def epoch(carry, _):
            network, opt_state, key = carry
            key, perm_key = jax.random.split(key)

            def minibatch_step(carry, data):
                network, opt_state = carry
                grads = jax.grad(loss)(network, *data)
                updates, opt_state = optimizer.update(grads, opt_state, network)
                return (optax.apply_updates(network, updates), opt_state), None

            (network, opt_state), _ = jax.lax.scan(minibatch_step, (network, opt_state),
                                                   minibatches(perm_key, before, (transitions, advantages, targets)))
            return (network, opt_state, key), None

        (network, opt_state, key), _ = jax.lax.scan(epoch, (state.network, state.opt_state, state.key), None,
                                                    config.update_epochs)
        ended = transitions.done.sum()
        std = transitions.std.mean(axis=-1)
        metrics = {"success": jnp.where(ended > 0, transitions.success.sum() / jnp.maximum(ended, 1), jnp.nan),
                   "reward": transitions.reward.mean(), "std": std.mean(),
                   "std_at_end": jnp.where(ended > 0, (std * transitions.done).sum() / jnp.maximum(ended, 1), jnp.nan)}
        return state._replace(network=network, opt_state=opt_state, key=key, update=state.update + 1), metrics

    def run(state: RunState, updates: int) -> tuple[RunState, dict[str, jax.Array]]:
        return jax.lax.scan(update, state, None, updates)

    return Chunks(init, run, rollout)


def make_train(env, env_params, config: PPOConfig) -> Callable[[jax.Array], dict[str, Any]]:
    """``train(key)``: a whole PPO run from scratch in one piece (:func:`make_chunks`); returns the
    final network and the metrics of each update."""
    chunks = make_chunks(env, env_params, config)

    def train(key: jax.Array) -> dict[str, Any]:
        state, metrics = chunks.run(chunks.init(key), config.num_updates)
        return {"network": state.network, "metrics": metrics}

    return train


def actor_arrays(network: dict[str, Any]) -> dict[str, np.ndarray]:
    """The actor as named NumPy arrays (``w0, b0, w1, b1, …``, and ``gru_wx, gru_wh, gru_bx, gru_bh``
    for a GRU, which sits before the last layer) as :class:`agents.mlp_policy.MlpPolicyAgent` reads them:
    the deterministic policy, so the last layer's outputs of the mean alone (with a state-dependent std
    it also has the log std's, which ``network["log_std"]``'s size tells apart)."""
    arrays, layers = {}, network["actor"]["layers"]
    means = network["log_std"].shape[-1] if "log_std" in network else layers[-1]["b"].shape[-1]
    for i, layer in enumerate(layers):
        last = i == len(layers) - 1
        arrays[f"w{i}"] = np.asarray(layer["w"][:, :means] if last else layer["w"])
        arrays[f"b{i}"] = np.asarray(layer["b"][:means] if last else layer["b"])
    for name, value in network["actor"].get("gru", {}).items():
        arrays[f"gru_{name}"] = np.asarray(value)
    return arrays


def play_deterministic(env, env_params, config: PPOConfig, actor: dict[str, Any], key: jax.Array,
                       episodes: int) -> tuple[jax.Array, jax.Array]:
    """The deterministic actor on ``episodes`` fresh episodes of the JAX env (each environment's first
    episode counts; its autoreset starts another, not counted): its success rate, and the share of the
    actions it asked for (each component, each step) beyond [-1, 1], which the env clips. That share
    is how far the actor's mean has left the box, which a policy whose deterministic play falls late in
    a run does (docs/learners.md)."""
    action_size = env.action_space(env_params).shape[0]
    reset_key, steps_key = jax.random.split(key)
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(reset_key, episodes), env_params)

    def one(carry, key):
        memory, state, success, ended, beyond = carry
        seen = _seen(config, "actor", memory.inputs, _factors(env, env_params, state, config))
        output, hidden = apply(actor, seen, memory.hidden["actor"], memory.start)
        mean = _gaussian(output, jnp.zeros(action_size), config)[0]
        beyond = beyond + jnp.where(ended[:, None], 0.0, (jnp.abs(mean) > 1.0).astype(float)).sum(0)
        obs, state, _, terminated, _, info = env.step_batch(jax.random.split(key, episodes), state,
                                                            jnp.clip(mean, -1.0, 1.0), env_params)
        success = jnp.where(terminated & ~ended, info["is_success"], success)
        memory = memory.next(obs, terminated, {**memory.hidden, "actor": hidden})
        return (memory, state, success, ended | terminated, beyond), jnp.sum(~ended)

    start = (Memory.first(obs, config), state, jnp.zeros(episodes, bool), jnp.zeros(episodes, bool),
             jnp.zeros(action_size))
    keys = jax.random.split(steps_key, env_params.max_steps_in_episode)
    (_, _, success, _, beyond), playing = jax.lax.scan(one, start, keys)
    return success.mean(), beyond.sum() / (playing.sum() * action_size)
