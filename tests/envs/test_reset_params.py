"""``reset(options={"params": ...})`` (domain randomisation): the env then plays, in this episode and
the later ones, exactly the episodes of an env made with those keywords (same seed, the same numbers
bit for bit), single or vector; a change of the observation or action space is refused naming the
keyword and why (tests/envs/test_refusals.py: a refused reset changes nothing)."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.envs.params import PlanarParams
from sail_env.envs.vector import LightSailVectorEnv
from sail_env.tasks import DEEP_DISH_START_HALF_WIDTHS, TASKS
from tests.envs.test_copies import COPIES, _actions, assert_same

#: (id, params at reset): randomisation and the sail's own keywords, on every family.
CASES = [
    ("LightSailRealistic-v0", {"parameter_spread": 0.05, "push_noise": 0.02, "cutoff_jitter_s": 2.0,
                               "beam_jitter_m": 3e-5, "sensor_noise_std": (1e-4, 1e-2, 1e-5, 1e-3)}),
    ("LightSail-v0", {"config": "deep_dish", "start_half_widths": DEEP_DISH_START_HALF_WIDTHS}),
    ("LightSail3D-v0", {"curvature_radius_m": 12.0, "parameter_spread": 0.1,
                        "model_uncertainty": {"curvature": 0.1, "absorptivity": 0.0, "power": 0.1}}),
]


def _episodes(env: Any, first: dict[str, Any], count: int = 2) -> list:
    """What ``count`` episodes answer (the first reset with ``first``'s arguments, the next without)."""
    answers = [env.reset(**first)]
    for episode in range(count):
        if episode:
            answers.append(env.reset())
        step, done = 0, False
        while not done:
            answers.append(env.step(_actions(step, env.action_space.shape)))
            step, done = step + 1, answers[-1][2] or answers[-1][3]
    return answers


@pytest.mark.parametrize(("env_id", "params"), CASES, ids=[case[0] for case in CASES])
def test_a_reset_with_params_plays_the_episodes_of_an_env_made_with_them(env_id, params):
    env = gym.make(env_id)
    env.reset(seed=9)  # an episode of the env's own task first
    env.step(_actions(0, env.action_space.shape))
    made = gym.make(env_id, **params)
    assert_same(_episodes(env, {"seed": 4, "options": {"params": params}}), _episodes(made, {"seed": 4}), env_id)
    assert env.unwrapped.keywords == {**TASKS[env_id], **params}  # kept for the later episodes


def test_params_act_over_the_env_s_keywords_until_changed_again():
    env = gym.make("LightSailRealistic-v0")
    env.reset(seed=1, options={"params": {"push_noise": 0.03}})
    env.reset(seed=1, options={"params": {"parameter_spread": 0.2}})  # push_noise stays 0.03
    made = gym.make("LightSailRealistic-v0", push_noise=0.03, parameter_spread=0.2)
    assert_same(_episodes(env, {"seed": 2}, 1), _episodes(made, {"seed": 2}, 1), "both params")
    env.reset(options={"params": {"push_noise": 0.01, "parameter_spread": 0.1}})  # the task's own values again
    assert_same(_episodes(env, {"seed": 3}, 1), _episodes(gym.make("LightSailRealistic-v0"), {"seed": 3}, 1),
                "the task again")


def test_a_params_dataclass_sets_its_family_s_keywords():
    env = gym.make("LightSail-v0")
    env.reset(seed=0, options={"params": PlanarParams("deep_dish")})
    assert_same(_episodes(env, {"seed": 5}, 1), _episodes(gym.make("LightSail-v0", config="deep_dish"), {"seed": 5}, 1),
                "PlanarParams")


@pytest.mark.parametrize("env_id", ["LightSailRealistic-v0", "LightSail3D-v0"])
def test_a_vector_reset_with_params_plays_as_a_vector_env_made_with_them(env_id):
    """One ``params`` for every environment (the batch shares one task)."""
    params = dict(CASES[0][1] if env_id == "LightSailRealistic-v0" else CASES[2][1])

    def make(**keywords: Any) -> Any:
        return gym.make_vec(env_id, num_envs=3, vectorization_mode="vector_entry_point", **keywords)

    envs, made = make(), make(**params)
    answers = [envs.reset(seed=7, options={"params": params})]
    expected = [made.reset(seed=7)]
    for step in range(230):  # past the first ends: the autoreset draws the new task's episodes
        actions = _actions(step, envs.action_space.shape)
        answers.append(envs.step(actions))
        expected.append(made.step(actions))
    assert_same(answers, expected, env_id)


@pytest.mark.parametrize(("env_id", "params", "message"), [
    ("LightSail-v0", {"light_delay": True}, r"light_delay would change the observation from 5 to \d+ values"),
    ("LightSailRealistic-v0", {"light_delay": False, "push_noise": 0.01}, "light_delay would change the observation"),
    ("LightSail3D-v0", {"power_control": True}, "power_control would change the actions from 4 to 5"),
    ("LightSail-v0", {"render_mode": "rgb_array"}, "unexpected keyword argument 'render_mode'"),
    ("LightSail-v0", {"parameter_spread": 0.5}, r"parameter_spread must be in \[0, 0.5\)"),
    ("LightSail-v0", [("push_noise", 0.1)], "must be a dict of the env's keywords or a params dataclass"),
])
def test_params_that_would_change_a_space_or_are_bad_are_refused_naming_them(env_id, params, message):
    env = gym.make(env_id)
    with pytest.raises(ValueError, match=message):
        env.reset(seed=0, options={"params": params})


def test_a_vector_env_of_a_bare_spec_has_no_keywords_to_change():
    envs = LightSailVectorEnv.from_spec(gym.make("LightSail-v0").unwrapped.episode_spec, 2)
    with pytest.raises(ValueError, match="made of a bare spec"):
        envs.reset(options={"params": {"push_noise": 0.01}})


def test_a_spread_at_reset_draws_other_sails_each_episode():
    """The randomisation given at reset acts: the episodes' sails differ (the vector env's too)."""
    envs = gym.make_vec("LightSail-v0", num_envs=4, vectorization_mode="vector_entry_point")
    envs.reset(seed=0, options={"params": {"parameter_spread": 0.2}})
    assert len({row.tobytes() for row in envs.unwrapped.state.params.take(np.arange(4)).step}) == 4


@pytest.mark.parametrize("make_copy", list(COPIES.values()), ids=list(COPIES))
def test_a_copy_keeps_the_params_given_at_reset(make_copy):
    env = gym.make("LightSailRealistic-v0")
    env.reset(seed=6, options={"params": {"push_noise": 0.03}})
    other = make_copy(env)
    assert other.unwrapped.keywords == env.unwrapped.keywords
    assert_same(_episodes(other, {"seed": 8}, 1), _episodes(env, {"seed": 8}, 1), "copy")
