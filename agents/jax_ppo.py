"""PPO written for the JAX backend: the whole training loop is one jitted function of a key
(rollout by ``lax.scan`` over ``vmap``-ed environments, GAE by a reverse scan, minibatch epochs
with ``optax``), so ``vmap`` over keys trains many seeds at once (PureJaxRL's design; Lu et al.
2022). The method is PPO with the clipped objective (Schulman et al. 2017) as CleanRL's
continuous-action script runs it: separate tanh actor and critic networks, a state-independent
log standard deviation, advantages normalised per minibatch, the learning rate annealed linearly.

The trained actor is plain arrays (:func:`actor_arrays`): :class:`agents.mlp_policy.MlpPolicyAgent`
plays it in NumPy, so ``evaluate.py`` reports it on the Gym envs beside the other agents.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax


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
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_coef: float = 0.2
    ent_coef: float = 0.0
    vf_coef: float = 0.5
    max_grad_norm: float = 0.5
    hidden: tuple[int, ...] = (64, 64)
    log_std_init: float = -1.0

    def __post_init__(self) -> None:
        for name in ("total_timesteps", "num_envs", "num_steps", "update_epochs", "num_minibatches"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
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


def _mlp(layers: list[dict[str, jax.Array]], x: jax.Array) -> jax.Array:
    for layer in layers[:-1]:
        x = jnp.tanh(x @ layer["w"] + layer["b"])
    return x @ layers[-1]["w"] + layers[-1]["b"]


def init_network(key: jax.Array, obs_size: int, action_size: int, config: PPOConfig) -> dict[str, Any]:
    actor_key, critic_key = jax.random.split(key)
    return {"actor": _mlp_init(actor_key, (obs_size, *config.hidden, action_size), 0.01),
            "critic": _mlp_init(critic_key, (obs_size, *config.hidden, 1), 1.0),
            "log_std": jnp.full(action_size, config.log_std_init, jnp.float32)}


def _log_prob(mean: jax.Array, log_std: jax.Array, action: jax.Array) -> jax.Array:
    z = (action - mean) / jnp.exp(log_std)
    return jnp.sum(-0.5 * z * z - log_std - 0.5 * jnp.log(2 * jnp.pi), axis=-1)


class Transition(NamedTuple):
    obs: jax.Array
    action: jax.Array
    log_prob: jax.Array
    value: jax.Array
    reward: jax.Array
    done: jax.Array
    success: jax.Array  # 1 where an episode ended with success, else 0


def make_train(env, env_params, config: PPOConfig) -> Callable[[jax.Array], dict[str, Any]]:
    """``train(key)``: a PPO run from scratch on ``env`` (a :class:`~sail_env.jax.env.SailEnv`,
    stepped by its ``step_batch``); returns the final network and, per update, the success rate of the
    episodes that ended in its rollout (NaN if none) and the mean reward."""
    action_size = env.action_space(env_params).shape[0]
    obs_size = env.observation_space(env_params).shape[0]
    minibatch = config.batch_size // config.num_minibatches

    def schedule(count: jax.Array) -> jax.Array:
        done = count // (config.num_minibatches * config.update_epochs)
        return config.learning_rate * (1.0 - done / config.num_updates)

    optimizer = optax.chain(optax.clip_by_global_norm(config.max_grad_norm),
                            optax.adam(schedule if config.anneal_lr else config.learning_rate, eps=1e-5))

    def train(key: jax.Array) -> dict[str, Any]:
        key, net_key, reset_key = jax.random.split(key, 3)
        network = init_network(net_key, obs_size, action_size, config)
        opt_state = optimizer.init(network)
        obs, env_state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(reset_key, config.num_envs), env_params)

        def env_step(carry, _):
            network, env_state, obs, key = carry
            key, act_key, step_key = jax.random.split(key, 3)
            mean = _mlp(network["actor"], obs)
            action = mean + jnp.exp(network["log_std"]) * jax.random.normal(act_key, mean.shape)
            value = _mlp(network["critic"], obs)[:, 0]
            next_obs, env_state, reward, terminated, _, info = env.step_batch(
                jax.random.split(step_key, config.num_envs), env_state, action, env_params)
            transition = Transition(obs, action, _log_prob(mean, network["log_std"], action), value,
                                    reward.astype(jnp.float32), terminated, terminated & info["is_success"])
            return (network, env_state, next_obs, key), transition

        def gae(transitions: Transition, last_value: jax.Array) -> tuple[jax.Array, jax.Array]:
            def back(carry, t: Transition):
                advantage, next_value = carry
                alive = 1.0 - t.done
                delta = t.reward + config.gamma * next_value * alive - t.value
                advantage = delta + config.gamma * config.gae_lambda * alive * advantage
                return (advantage, t.value), advantage

            _, advantages = jax.lax.scan(back, (jnp.zeros_like(last_value), last_value), transitions, reverse=True)
            return advantages, advantages + transitions.value

        def loss(network, batch: Transition, advantages: jax.Array, targets: jax.Array) -> jax.Array:
            mean = _mlp(network["actor"], batch.obs)
            log_prob = _log_prob(mean, network["log_std"], batch.action)
            value = _mlp(network["critic"], batch.obs)[:, 0]
            ratio = jnp.exp(log_prob - batch.log_prob)
            advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
            policy_loss = -jnp.minimum(ratio * advantages,
                                       jnp.clip(ratio, 1 - config.clip_coef, 1 + config.clip_coef) * advantages).mean()
            value_loss = 0.5 * jnp.mean((value - targets) ** 2)
            entropy = jnp.sum(network["log_std"] + 0.5 * jnp.log(2 * jnp.pi * jnp.e))
            return policy_loss + config.vf_coef * value_loss - config.ent_coef * entropy

        def update(carry, _):
            network, opt_state, env_state, obs, key = carry
            (network, env_state, obs, key), transitions = jax.lax.scan(
                env_step, (network, env_state, obs, key), None, config.num_steps)
            advantages, targets = gae(transitions, _mlp(network["critic"], obs)[:, 0])

            def epoch(carry, _):
                network, opt_state, key = carry
                key, perm_key = jax.random.split(key)
                order = jax.random.permutation(perm_key, config.batch_size)
                flat = jax.tree.map(lambda a: a.reshape((config.batch_size,) + a.shape[2:])[order],
                                    (transitions, advantages, targets))
                split = jax.tree.map(lambda a: a.reshape((config.num_minibatches, minibatch) + a.shape[1:]), flat)

                def minibatch_step(carry, data):
                    network, opt_state = carry
                    grads = jax.grad(loss)(network, *data)
                    updates, opt_state = optimizer.update(grads, opt_state, network)
                    return (optax.apply_updates(network, updates), opt_state), None

                (network, opt_state), _ = jax.lax.scan(minibatch_step, (network, opt_state), split)
                return (network, opt_state, key), None

            (network, opt_state, key), _ = jax.lax.scan(epoch, (network, opt_state, key), None, config.update_epochs)
            ended = transitions.done.sum()
            metrics = {"success": jnp.where(ended > 0, transitions.success.sum() / jnp.maximum(ended, 1), jnp.nan),
                       "reward": transitions.reward.mean()}
            return (network, opt_state, env_state, obs, key), metrics

        (network, *_), metrics = jax.lax.scan(update, (network, opt_state, env_state, obs, key), None,
                                              config.num_updates)
        return {"network": network, "metrics": metrics}

    return train


def actor_arrays(network: dict[str, Any]) -> dict[str, np.ndarray]:
    """The actor as named NumPy arrays (``w0, b0, w1, b1, …``; the mean is the last layer's
    output, as :class:`agents.mlp_policy.MlpPolicyAgent` computes it)."""
    arrays = {}
    for i, layer in enumerate(network["actor"]):
        arrays[f"w{i}"], arrays[f"b{i}"] = np.asarray(layer["w"]), np.asarray(layer["b"])
    return arrays



def success_rate(env, env_params, actor: list[dict[str, jax.Array]], key: jax.Array, episodes: int) -> jax.Array:
    """The deterministic actor's success rate over ``episodes`` fresh episodes of the JAX env (each
    environment's first episode counts; its autoreset starts another, not counted)."""
    reset_key, steps_key = jax.random.split(key)
    obs, state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(reset_key, episodes), env_params)

    def one(carry, key):
        obs, state, success, ended = carry
        action = jnp.clip(_mlp(actor, obs), -1.0, 1.0)
        obs, state, _, terminated, _, info = env.step_batch(jax.random.split(key, episodes), state, action, env_params)
        success = jnp.where(terminated & ~ended, info["is_success"], success)
        return (obs, state, success, ended | terminated), None

    start = (obs, state, jnp.zeros(episodes, bool), jnp.zeros(episodes, bool))
    keys = jax.random.split(steps_key, env_params.max_steps_in_episode)
    (_, _, success, _), _ = jax.lax.scan(one, start, keys)
    return success.mean()
