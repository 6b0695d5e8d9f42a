"""A trained tanh MLP policy played in NumPy: what ``train_jax.py`` saves (``policy.npz``), so that
``evaluate.py`` reports the JAX learners on the Gym envs without importing JAX. The policy may have a
memory (:mod:`agents.jax_ppo`'s ``history``, ``recurrent`` and ``episode_mean``), kept here per episode."""

from __future__ import annotations

import io
import json
import zipfile
import zlib
from pathlib import Path

import numpy as np

from agents import cli

#: The file a JAX run keeps its policy in, and the metadata key that names its task.
POLICY_FILE = "policy.npz"
#: The GRU's arrays in a policy file (``gru_<name>``), as :func:`agents.jax_ppo.actor_arrays` names them.
GRU_ARRAYS = ("wx", "wh", "bx", "bh")


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * x))  # no overflow warning for large |x|


class MlpPolicyAgent:
    """The deterministic action of a saved actor: ``clip(mean(obs), -1, 1)`` with tanh hidden layers
    (the mean squashed by a tanh if the actor was trained with ``tanh_mean``),
    as :func:`agents.jax_ppo.apply` computes it: on the last ``history`` observations side by side
    (zeros before the episode's first), followed by the mean of the episode's observations so far if
    the actor was trained with it, and through a GRU before the last layer if the actor has one.

    ``policy.npz`` holds ``w0, b0, …`` (float32), ``gru_wx, gru_wh, gru_bx, gru_bh`` for a GRU, and
    ``meta`` (a JSON string with ``env_id``, ``algo``, ``history``, ``recurrent``: the GRU's size, 0
    for none, ``episode_mean`` and ``tanh_mean``; files saved before these existed lack them, which
    reads as 1, 0, false and false). An actor trained with ``privileged_actor`` (it saw the episode's
    parameter draw, which no env shows) is refused: ``ValueError``.

    ``act`` takes one observation (D,) or a batch (N, D) of episodes; a policy with memory keeps it
    per episode until :meth:`reset`.
    """

    def __init__(self, path: str | Path, name: str | None = None) -> None:
        data = read_npz(path)
        self.meta = json.loads(str(data["meta"]))
        if self.meta.get("privileged_actor"):
            raise ValueError(f"{path}: its actor was trained seeing the episode's parameter draw "
                             "(--privileged-actor), which no env shows a policy: it plays only in train_jax.py")
        count = sum(1 for key in data if key.startswith("w"))
        self.layers = [(data[f"w{i}"].astype(np.float64), data[f"b{i}"].astype(np.float64)) for i in range(count)]
        recurrent = self.meta.get("recurrent", 0)
        self.gru = {key: data[f"gru_{key}"].astype(np.float64) for key in GRU_ARRAYS} if recurrent else None
        self.history = int(self.meta.get("history", 1))
        self.episode_mean = bool(self.meta.get("episode_mean", False))
        self.tanh_mean = bool(self.meta.get("tanh_mean", False))
        self.name = name or f"{self.meta.get('algo', 'mlp')}"
        self.obs_size = self.layers[0][0].shape[0] // (self.history + self.episode_mean)
        self.reset()

    @property
    def has_memory(self) -> bool:
        return self.history > 1 or self.gru is not None or self.episode_mean

    def reset(self, which: np.ndarray | None = None) -> None:
        """Start afresh: every episode, or only those where ``which`` (N,) is true (the episodes an
        autoresetting batch has just begun)."""
        if which is None:
            self._stacked: np.ndarray | None = None  # (…, history * D): the last observations, the newest last
            self._hidden: np.ndarray | None = None  # (…, R): the GRU's state after them
            self._mean: np.ndarray | None = None  # (…, D): the mean of the episode's observations
            self._seen: np.ndarray | None = None  # (…): how many observations that mean is of
            self._start: np.ndarray | None = None  # (…): the next observation is its episode's first
        elif self._start is not None:
            self._start[np.asarray(which, dtype=bool)] = True

    def act(self, observation: np.ndarray) -> np.ndarray:
        x = np.asarray(observation, dtype=np.float64)
        if x.shape[-1] != self.obs_size:
            raise ValueError(f"{self.name}: the policy takes observations of size {self.obs_size} "
                             f"({self.meta.get('env_id')}), got {x.shape[-1]}")
        batch = x.shape[:-1]
        if self._start is None or self._start.shape != batch:
            if self._start is not None and self.has_memory:
                raise ValueError(f"{self.name}: its memory holds {self._start.shape} episodes, given {batch}: "
                                 "reset() before a batch of another size")
            self._stacked = np.zeros(batch + (self.history * self.obs_size,))
            self._hidden = np.zeros(batch + (len(self.gru["wh"]),)) if self.gru is not None else None
            self._mean, self._seen = np.zeros(batch + (self.obs_size,)), np.zeros(batch)
            self._start = np.ones(batch, dtype=bool)
        fresh = self._start[..., None]
        newest = x
        self._stacked = np.concatenate([np.where(fresh, 0.0, self._stacked)[..., self.obs_size:], newest], axis=-1)
        x = self._stacked
        if self.episode_mean:  # kept only for an actor that sees it: this runs on every step
            self._seen = np.where(self._start, 1.0, self._seen + 1.0)
            self._mean = np.where(fresh, newest, self._mean + (newest - self._mean) / self._seen[..., None])
            x = np.concatenate([x, self._mean], axis=-1)
        for w, b in self.layers[:-1]:
            x = np.tanh(x @ w + b)
        if self.gru is not None:
            self._hidden = x = self._gru_step(np.where(fresh, 0.0, self._hidden), x)
        self._start = np.zeros(batch, dtype=bool)
        w, b = self.layers[-1]
        mean = np.tanh(x @ w + b) if self.tanh_mean else x @ w + b
        return np.clip(mean, -1.0, 1.0).astype(np.float32)

    def _gru_step(self, hidden: np.ndarray, x: np.ndarray) -> np.ndarray:
        reset_x, update_x, candidate_x = np.split(x @ self.gru["wx"] + self.gru["bx"], 3, axis=-1)
        reset_h, update_h, candidate_h = np.split(hidden @ self.gru["wh"] + self.gru["bh"], 3, axis=-1)
        update = _sigmoid(update_x + update_h)
        candidate = np.tanh(candidate_x + _sigmoid(reset_x + reset_h) * candidate_h)
        return (1.0 - update) * candidate + update * hidden


def save_policy(path: Path, arrays: dict[str, np.ndarray], meta: dict) -> None:
    """Write ``arrays`` (as float32) and ``meta`` to ``path`` whole or not at all (:func:`agents.cli.write_whole`)."""
    write_npz(path, {"meta": np.array(json.dumps(meta)), **{k: v.astype(np.float32) for k, v in arrays.items()}})


def read_npz(path: str | Path) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` file, read now; ``ValueError`` naming the file for one that is empty,
    cut short or no ``.npz`` at all (NumPy's ``EOFError``, ``BadZipFile`` and the like)."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return {key: data[key] for key in data.files}
    except (EOFError, zipfile.BadZipFile, zlib.error, ValueError) as err:
        raise ValueError(f"{path}: empty, cut short or not an .npz file ({type(err).__name__}: {err})") from err


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """``arrays`` as an ``.npz`` file at ``path``, written whole or not at all."""
    content = io.BytesIO()
    np.savez(content, **arrays)
    cli.write_whole(path, content.getvalue())
