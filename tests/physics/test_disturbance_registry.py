"""The random disturbances' interface (sail_env.physics.disturbance): a new disturbance is one
registered class, which every env whose plant accepts it then takes as a keyword; the channels add
independent sources in variance; the design's process noise reads every source."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import pytest

import sail_env  # noqa: F401  (registers the ids)
from sail_env.physics import disturbance
from sail_env.physics.disturbance import BeamDisturbance, ImpulseDisturbance, register
from sail_env.physics.disturbances import Dust, GroundJitter, LandingJitter, split_keywords


@dataclasses.dataclass(frozen=True)
class ServoJitter(BeamDisturbance):
    """A made-up second beam offset, constant in size: what a user's new module would hold."""

    servo_jitter_m: float = 0.0

    def std_m(self, plant, p, t):
        return self.servo_jitter_m


@pytest.fixture
def servo_registered(monkeypatch):
    monkeypatch.setitem(disturbance.REGISTRY, "servo_jitter_m", ServoJitter)


def play(env: gym.Env, seed: int, steps: int = 60) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    observations, rewards = [observation], []
    for _ in range(steps):
        observation, reward, terminated, truncated, _ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        observations.append(observation)
        rewards.append(reward)
        if terminated or truncated:
            break
    return np.array(observations), np.array(rewards)


def test_a_registered_disturbance_is_an_env_keyword_and_adds_in_variance(servo_registered):
    """A new beam offset of 4e-5 m on top of the landing jitter's 3e-5 m plays the episodes of one
    landing jitter of 5e-5 m (independent Gaussians add in variance), not those of either alone."""
    both = gym.make("LightSailDeepDish-v0", beam_jitter_m=3e-5, servo_jitter_m=4e-5)
    assert [type(d) for d in both.unwrapped.episode_spec.randomisation.sources] == [LandingJitter, ServoJitter]
    one = gym.make("LightSailDeepDish-v0", beam_jitter_m=math.hypot(3e-5, 4e-5))
    alone = gym.make("LightSailDeepDish-v0", beam_jitter_m=3e-5)
    for seed in range(3):
        (obs_both, rew_both), (obs_one, rew_one) = play(both, seed), play(one, seed)
        np.testing.assert_allclose(obs_both, obs_one, rtol=1e-5, atol=1e-6)
        np.testing.assert_allclose(rew_both, rew_one, rtol=0, atol=1e-9)
        assert not np.allclose(play(alone, seed)[0], obs_both, rtol=1e-5, atol=1e-6)


def test_an_unregistered_keyword_is_still_refused():
    with pytest.raises(TypeError, match="servo_jitter_m"):
        gym.make("LightSailDeepDish-v0", servo_jitter_m=1e-5)


def test_a_keyword_names_one_disturbance():
    @dataclasses.dataclass(frozen=True)
    class Twin(BeamDisturbance):
        beam_jitter_m: float = 0.0

    with pytest.raises(ValueError, match="'beam_jitter_m' is already taken by LandingJitter"):
        register(Twin)


def test_split_keeps_the_active_sources_in_registration_order():
    sources, rest = split_keywords({"push_noise": 0.01, "dust_density_m3": 1e-6, "dust_grain_mass_kg": 1e-15,
                                    "ground_jitter_rad": 1e-15, "beam_jitter_m": 0.0})
    assert sources == (GroundJitter(1e-15), Dust(1e-6, 1e-15)) and rest == {"push_noise": 0.01}
    assert split_keywords({"dust_density_m3": 1e-6})[0] == ()  # a grain mass of zero: no dust


def test_one_impulse_process_at_most(monkeypatch):
    @dataclasses.dataclass(frozen=True)
    class Hail(ImpulseDisturbance):
        hail_rate_hz: float = 0.0

        def rows(self, plant):
            return (2,)

    monkeypatch.setitem(disturbance.REGISTRY, "hail_rate_hz", Hail)
    with pytest.raises(ValueError, match="at most one impulse disturbance"):
        gym.make("LightSail3D-v0", hail_rate_hz=1.0, dust_density_m3=1e-6, dust_grain_mass_kg=1e-15)


def test_the_designs_process_noise_reads_every_source():
    """``EpisodeSpec.window_step_noise`` against its formulas written out for the Newtonian flight
    (``D = a t²/2``, ``v = a t``): the ground jitter ``(D δ)²`` through Γ's offset columns, the dust's
    ``rate · dt · kick²`` on the lateral speeds and tilt rates (docs/physics.md §12, §15)."""
    delta, density, grain = 1e-15, 1e-6, 1e-15
    spec = gym.make("LightSail3D-v0", ground_jitter_rad=delta, dust_density_m3=density, dust_grain_mass_kg=grain,
                    control_start_s=10.0).unwrapped.episode_spec
    plant = spec.plant
    lin, radius = plant.linearisation, plant.aperture_radius_m
    middle = 10.0 + 0.5 * spec.n_steps * spec.dt
    accel = lin.push_n / lin.mass_kg
    _, gamma = spec.nominal.discretize(spec.dt)
    offsets = gamma[:, :2]
    expected = (0.5 * accel * middle**2 * delta) ** 2 * offsets @ offsets.T
    speed = math.hypot(accel * middle, 2.0e4)
    rate = density * math.pi * radius**2 * speed
    lateral = (grain * 2.0e4 / math.sqrt(3) / lin.mass_kg) ** 2
    angular = (grain * speed * 0.5 * radius / lin.inertia[0, 0]) ** 2
    expected[[2, 3, 6, 7], [2, 3, 6, 7]] += rate * spec.dt * np.array([lateral, lateral, angular, angular])
    np.testing.assert_allclose(spec.window_step_noise(gamma), expected, rtol=1e-9, atol=0)


def test_the_configurations_old_names_still_work_with_a_warning():
    from sail_env.physics.rigid3d import plant, uncertainty

    with pytest.warns(DeprecationWarning, match="RigidTaskConfig"):
        assert plant.RigidFlight is plant.RigidTaskConfig
    with pytest.warns(DeprecationWarning, match="UncertainTaskConfig"):
        assert uncertainty.UncertainFlight is uncertainty.UncertainTaskConfig
    with pytest.raises(AttributeError):
        plant.RigidFlights  # noqa: B018
