"""A trained tanh MLP policy played in NumPy: what ``train_jax.py`` saves (``policy.npz``), so that
``evaluate.py`` reports the JAX learners on the Gym envs without importing JAX."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

#: The file a JAX run keeps its policy in, and the metadata key that names its task.
POLICY_FILE = "policy.npz"


class MlpPolicyAgent:
    """The deterministic action of a saved actor: ``clip(mean(obs), -1, 1)`` with tanh hidden layers.

    ``policy.npz`` holds ``w0, b0, …`` (float32) and ``meta`` (a JSON string with ``env_id``,
    ``algo`` and ``obs_size``).
    """

    def __init__(self, path: str | Path, name: str | None = None) -> None:
        with np.load(path, allow_pickle=False) as data:
            count = sum(1 for key in data.files if key.startswith("w"))
            self.layers = [(data[f"w{i}"].astype(np.float64), data[f"b{i}"].astype(np.float64)) for i in range(count)]
            self.meta = json.loads(str(data["meta"]))
        self.name = name or f"{self.meta.get('algo', 'mlp')}"
        self.obs_size = self.layers[0][0].shape[0]

    def act(self, observation: np.ndarray) -> np.ndarray:
        x = np.asarray(observation, dtype=np.float64)
        if x.shape[-1] != self.obs_size:
            raise ValueError(f"{self.name}: the policy takes observations of size {self.obs_size} "
                             f"({self.meta.get('env_id')}), got {x.shape[-1]}")
        for w, b in self.layers[:-1]:
            x = np.tanh(x @ w + b)
        w, b = self.layers[-1]
        return np.clip(x @ w + b, -1.0, 1.0).astype(np.float32)

    def reset(self) -> None:
        """Memoryless."""


def save_policy(path: Path, arrays: dict[str, np.ndarray], meta: dict) -> None:
    """Write ``arrays`` and ``meta`` to ``path`` whole or not at all (a temporary file, then a rename)."""
    temporary = path.with_name(f".{path.name}.partial")
    with open(temporary, "wb") as out:
        np.savez(out, meta=np.array(json.dumps(meta)), **{k: v.astype(np.float32) for k, v in arrays.items()})
    temporary.replace(path)
