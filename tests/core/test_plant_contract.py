"""The plant contract (sail_env/core/plant.py) is complete and both sail models keep it; the core, the
envs, the JAX backend and the agents use nothing else."""

import re
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401
from sail_env.core.plant import Plant
from sail_env.tasks import TASKS

ROOT = Path(__file__).parents[2]
#: The code that must see a sail model only through the contract.
USERS = [*sorted((ROOT / "sail_env" / "core").glob("*.py")), *sorted((ROOT / "sail_env" / "envs").glob("*.py")),
         *sorted((ROOT / "sail_env" / "jax").glob("*.py")), *sorted((ROOT / "agents").glob("*.py"))]


def declared() -> set[str]:
    return {name for klass in Plant.__mro__ if klass is not object
            for name in (*vars(klass), *getattr(klass, "__annotations__", {})) if not name.startswith("_")}


@pytest.mark.parametrize("env_id", ["LightSail-v0", "LightSailRealistic-v0", "LightSail3D-v0",
                                    "LightSail3DRealistic-v1"])
def test_both_sail_models_keep_the_contract(env_id):
    plant = gym.make(env_id).unwrapped.episode_spec.plant
    assert isinstance(plant, Plant)
    missing = sorted(name for name in declared() if not hasattr(plant, name))
    assert not missing


def test_the_core_envs_and_agents_use_nothing_the_contract_does_not_declare():
    """Every ``plant.<member>`` the core, the envs, the JAX backend and the agents read is declared: a new use must
    extend the contract (and its table), not reach past it."""
    used = {}
    for path in USERS:
        text = path.read_text()
        for name in re.findall(r"\bplant\.([a-z_]\w*)", text) + re.findall(r"getattr\([\w.]*plant,\s*\"(\w+)\"", text):
            used.setdefault(name, set()).add(path.name)
    assert used, "the scan found no use of the plant at all"
    undeclared = {name: sorted(files) for name, files in used.items() if name not in declared()}
    assert not undeclared


@pytest.mark.parametrize("env_id", sorted(TASKS))
def test_one_generator_draws_what_the_batched_reset_draws(env_id):
    """The core draws a batch's parameters as ``factors`` of each generator's uniforms; a plant's
    ``draw(rng)`` must be that same map (LightSailUncertain-v0 once overrode ``draw`` alone, and its
    episodes never saw the sizes its tests checked)."""
    plant = gym.make(env_id).unwrapped.episode_spec.plant
    drawn = plant.draw(np.random.default_rng(11))
    batched = plant.factors(np.random.default_rng(11).random((1, plant.n_draws)))[0]
    np.testing.assert_array_equal(drawn, batched)
