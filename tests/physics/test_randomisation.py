"""The randomisation's one home (:mod:`sail_env.physics.randomisation`): its table names every random
keyword, :func:`randomisation` takes them and leaves the rest, and none of them changes an env's spaces,
so that each may be given at reset (``options["params"]``, tests/envs/test_reset_params.py)."""

from __future__ import annotations

import gymnasium as gym
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.physics import disturbances, randomisation
from sail_env.physics.disturbances import Dust, LandingJitter

#: A value of each random keyword that is not the realistic tasks' (on the 3D realistic sail: every one applies).
CHANGES = {"parameter_spread": 0.2, "push_noise": 0.02, "cutoff_jitter_s": 1.0,
           "sensor_noise_std": (1e-4, 1e-4, 1e-2, 1e-2, 1e-5, 1e-5, 1e-3, 1e-3), "beam_jitter_m": 2e-5,
           "ground_jitter_rad": 1e-15, "dust_density_m3": 1e-9, "dust_grain_mass_kg": 2e-12,
           "model_uncertainty": {"curvature": 0.1, "absorptivity": 0.2, "power": 0.1, "pointing_bias_m": 5e-3}}


def test_every_random_keyword_is_in_the_one_table():
    table = randomisation.__doc__.split("| keyword(s) |")[1].split("\n\n")[0]
    names = (*randomisation.FIELDS, *disturbances.keywords(), "model_uncertainty")
    assert sorted(names) == sorted(CHANGES)
    for name in names:
        assert f"``{name}``" in table, name


def test_randomisation_takes_its_keywords_and_leaves_the_rest():
    made, rest = randomisation.randomisation({"push_noise": 0.01, "beam_jitter_m": 1e-5, "light_delay": True,
                                              "dust_density_m3": 1e-9, "dust_grain_mass_kg": 0.0, "config": "seed"})
    assert made == randomisation.Randomisation(push_noise=0.01, sources=(LandingJitter(1e-5),))  # dust: off
    assert rest == {"light_delay": True, "config": "seed"}
    assert [type(d) for d in randomisation.randomisation({"dust_density_m3": 1e-9, "dust_grain_mass_kg": 1e-12})[0]
            .sources] == [Dust]


@pytest.mark.parametrize("name", sorted(CHANGES))
def test_no_random_keyword_changes_the_spaces(name):
    """On the light-delayed realistic 3D task, whose command history a change of the timing would change."""
    env = gym.make("LightSail3DRealistic-v1")
    before = env.unwrapped.episode_spec
    env.reset(seed=0, options={"params": {name: CHANGES[name]}})  # refused if a space changed
    after = env.unwrapped.episode_spec
    assert after is not before and env.unwrapped.keywords[name] == CHANGES[name]
    assert (after.observation_size, after.plant.n_inputs) == (before.observation_size, before.plant.n_inputs)
