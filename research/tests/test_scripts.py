"""The research scripts behind the docs' claims (research/README.md) run on a tiny budget (one episode
per cell, the last seconds of a flight): they import the library, and a refactoring that breaks them
fails here rather than when someone re-measures. Off the default run: ``python -m pytest research/tests``."""

import json

import pytest

from research import (action_noise, actor_average, coast_vs_nonlinear, delay_absorption_3d, first_try, handover,
                      realistic_ablation, sensor_noise_learner, uncertain_failures, uncertain_sizes)


@pytest.mark.parametrize("script", [realistic_ablation, delay_absorption_3d])
def test_table_script_prints_its_table(script, capsys):
    script.main(["--episodes", "1"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert lines[2].startswith("| ") and lines[3].startswith("|---")
    rows = [line for line in lines[4:] if line.startswith("| ")]
    assert len(rows) >= 4 and all(line.count("%") >= 2 for line in rows)


def test_coast_agrees_with_the_nonlinear_body_over_its_last_50_ms(capsys):
    """The whole-flight comparison runs for tens of minutes (docs/physics.md §14); its last 50 ms
    here (measured: 3e-5 of the coast's largest lateral speed)."""
    result = coast_vs_nonlinear.main(["--start", "599.95"])
    assert result["relative_velocity_error"] < 3e-4


def test_the_flat_top_edge_costs_the_coast_its_accuracy_a_gaussian_does_not(capsys):
    """docs/physics.md §14: over 1 s before cut-off the coast is 7e-6 of the amplitude from the
    nonlinear body in a Gaussian beam, 1.1e-3 in the flat-top of the sail's size (its force is
    kinked at zero offset)."""
    gaussian = coast_vs_nonlinear.main(["--start", "599", "--rtol", "1e-7", "--beam-profile", "gaussian"])
    flat_top = coast_vs_nonlinear.main(["--start", "599", "--rtol", "1e-7"])
    assert gaussian["relative_velocity_error"] < 5e-5
    assert flat_top["relative_velocity_error"] > 20 * gaussian["relative_velocity_error"]


def test_first_try_trains_evaluates_and_appends_one_json_line(tmp_path, capsys):
    """docs/learners.md's first-try table: one update of the single-file PPO (one env, one
    episode of 256 steps), its row holding both evaluations and the training-time numbers; the
    noise table's LQR without noise succeeds."""
    out = tmp_path / "first_try.jsonl"
    args = ["--total-steps", "256", "--num-envs", "1", "--num-steps", "256", "--minibatches", "4",
            "--eval-episodes", "1", "--out", str(out)]
    (row,) = first_try.main(args)
    assert json.loads(out.read_text()) == row
    assert {"det_success", "sto_success", "train_last200_return", "final_action_std", "wall_s"} <= row.keys()
    assert row["steps"] == 256 and row["log_std_init"] == 0.0 and row["train_last200_return"] is not None
    (table,) = first_try.main(["--noise-table", "--eval-episodes", "2", "--out", str(out)])
    assert table["rows"][0] == {"sigma": 0.0, "success": 1.0, "return": table["rows"][0]["return"]}
    assert len(out.read_text().splitlines()) == 2


def test_uncertain_sizes_measures_each_scale_once_and_refuses_one_past_a_limit(tmp_path, capsys):
    out = tmp_path / "sizes.json"
    uncertain_sizes.main(["--episodes", "1", "--scales", "1", "2.5", "--out", str(out)])
    results = json.loads(out.read_text())
    assert set(results["x1"]["agents"]) == {"lqg", "lqg-mm-offset", "bank spanning the sizes", "lqg-oracle"}
    assert "absorptivity" in results["x2.5"]["refused"]
    capsys.readouterr()
    uncertain_sizes.main(["--episodes", "1", "--scales", "1", "--out", str(out)])  # measured: kept, not replayed
    assert "x1 lqg" not in capsys.readouterr().out


def test_uncertain_failures_redraws_the_episodes_and_bins_them(tmp_path, capsys):
    """The 200 episodes' draws are the env's (the script checks each); the learners fail where the
    power reaching the sail is far from nominal (docs/learners.md), the offset bank not."""
    result = uncertain_failures.main(["--out", str(tmp_path / "failures.json")])
    power = result["factors"]["power at the sail"]
    assert power["edges"][0] < 0.8 < 1.2 < power["edges"][-1]
    learner = next(rates for name, rates in power["success"].items() if name == "PPO, clipped likelihood: 5 run(s)")
    assert max(learner[0], learner[-1]) + 0.15 < min(learner[1:-1])
    assert min(power["success"]["lqg-mm-offset"]) > 0.85
    assert json.loads((tmp_path / "failures.json").read_text())["episodes"] == 200


def test_action_noise_puts_the_errors_where_asked(capsys):
    """One episode: no error is the bank's own outcome; errors on the last step alone still play."""
    clean, = action_noise.main(["--episodes", "1", "--sizes", "0"])
    assert clean[0] == 0.0 and clean[1] in (0.0, 1.0) and clean[2] > 0
    last, = action_noise.main(["--episodes", "1", "--sizes", "0.01", "--last", "1"])
    assert last[1] in (0.0, 1.0) and last[2] != clean[2]  # the last action moved the end
    assert "| 0.01 |" in capsys.readouterr().out


def test_handover_gives_the_steps_to_the_second_agent_and_tells_the_bank_what_was_sent(tmp_path):
    """A learner that always asks for 0.5 on every input: after the handover to it (the window's last
    step) the env is sent 0.5, and the bank's filters hold that command, not the bank's own."""
    import gymnasium as gym
    import numpy as np

    from agents.evaluation import make_agent
    from agents.mlp_policy import MlpPolicyAgent, save_policy

    env = gym.make(handover.ENV_ID)
    spec = env.unwrapped.episode_spec
    size, m = env.observation_space.shape[0], env.action_space.shape[0]
    path = tmp_path / "policy.npz"
    save_policy(path, {"w0": np.zeros((size, m)), "b0": np.full(m, np.arctanh(0.5))},
                {"env_id": handover.ENV_ID, "algo": "jax_ppo", "tanh_mean": True})
    learner, bank = MlpPolicyAgent(path), make_agent(handover.BANK, env)
    player = handover.make_player("bank-learner", learner, bank, 1, spec.n_steps, np.asarray(spec.action_scale))
    obs, _ = env.reset(seed=action_noise.FIRST_SEED)
    player.reset()
    for step in range(spec.n_steps):
        action = player.act(obs)
        if step < spec.n_steps - 1:
            assert not np.allclose(action, 0.5)  # the bank steers
        obs, *_ = env.step(action)
    np.testing.assert_allclose(action, 0.5, rtol=1e-6)
    for member in bank.bank:
        np.testing.assert_allclose(member.last_command[0], 0.5 * np.asarray(spec.action_scale), rtol=1e-6)


def test_handover_refuses_a_handover_outside_the_window(capsys):
    with pytest.raises(SystemExit):
        handover.main(["--policy", "unused.npz", "--last", "200"])
    assert "K must be in [1, 199]" in capsys.readouterr().err


def test_handover_refuses_a_policy_it_cannot_read_before_its_table(tmp_path, capsys):
    """A missing or empty policy: one line, no header printed above a traceback."""
    (tmp_path / "empty.npz").write_bytes(b"")
    for policy in (tmp_path / "missing.npz", tmp_path / "empty.npz"):
        with pytest.raises(SystemExit):
            handover.main(["--policy", str(policy)])
        captured = capsys.readouterr()
        assert captured.out == "" and "--policy" in captured.err and "Traceback" not in captured.err


def test_actor_average_refuses_a_cut_checkpoint_in_one_line(tmp_path, capsys):
    from research import actor_average

    (tmp_path / "checkpoint.npz").write_bytes(b"PK\x03\x04 cut short")  # a BadZipFile traceback before
    assert actor_average.main([str(tmp_path / "checkpoint.npz"), "--out", str(tmp_path / "out.json")]) == 2
    assert "empty, cut short or not an .npz file" in capsys.readouterr().err


def test_actor_average_scores_each_actor_and_the_means_of_the_last(tmp_path, capsys):
    """A run of train_jax.py on LightSail-v0 continued by 4 updates: actors 1 and 3 and the mean of the 4
    scored on the same episodes; the checkpoint is left as it was."""
    import train_jax

    runs = tmp_path / "runs"
    assert train_jax.main(["-n", "512", "--num-envs", "8", "--num-steps", "64", "--hidden", "8",
                           "--runs-dir", str(runs)]) == 0
    checkpoint = next(runs.glob("*/checkpoint.npz"))
    before = checkpoint.read_bytes()
    out = tmp_path / "average.json"
    assert actor_average.main([str(checkpoint), "--updates", "4", "--every", "2", "--episodes", "8",
                               "--out", str(out)]) == 0
    results = json.loads(out.read_text())
    assert [after for after, _ in results["each"]] == [1, 3] and list(results["averaged"]) == ["4"]
    assert all(0 <= rate <= 1 for _, (rate,) in results["each"]) and results["from_update"] == 1
    assert checkpoint.read_bytes() == before
    assert actor_average.main([str(checkpoint), "--out", str(out)]) == 2


def test_actor_average_means_the_last_actors_weight_by_weight():
    import numpy as np

    actors = [{"w": np.full((2, 2), float(i)), "b": np.array([i, -i], float)} for i in range(6)]
    mean = actor_average.mean_of_last(actors, 4)
    np.testing.assert_array_equal(mean["w"], np.full((2, 2), 3.5))
    np.testing.assert_array_equal(mean["b"], [3.5, -3.5])


def test_sensor_noise_learner_scales_the_tasks_noise_alone_and_records_its_run(tmp_path, capsys):
    """The scale reaches the sensor noise and nothing else; a two-update run writes its curve and both
    final scores, and an existing --out is refused."""
    import numpy as np

    import sail_env.jax

    task = sail_env.jax.make(sensor_noise_learner.ENV_ID)[1]
    for scale in (0.0, 0.5):
        scaled = sensor_noise_learner.with_sensor_noise(scale)
        np.testing.assert_array_equal(scaled.sensor_std, scale * task.sensor_std)
        np.testing.assert_array_equal(scaled.step_matrix, task.step_matrix)
        assert scale == 0.0 or scaled.sensor_std.max() > 0
    out = tmp_path / "run.json"
    ppo = ["-n", "1024", "--num-envs", "8", "--num-steps", "64", "--hidden", "8", "--history", "2"]
    assert sensor_noise_learner.main(["--scale", "0", "--chunk", "1", "--final-episodes", "4", "--out", str(out),
                                      "--", *ppo]) == 0
    record = json.loads(out.read_text())
    assert record["status"] == "finished" and [step for step, _ in record["curve"]] == [512, 1024]
    assert 0 <= record["final_success_scaled_noise"] <= 1 and 0 <= record["final_success_task"] <= 1
    assert sensor_noise_learner.main(["--scale", "0", "--out", str(out), "--", *ppo]) == 2
    assert "exists" in capsys.readouterr().err
    other = tmp_path / "other.json"
    assert sensor_noise_learner.main(["--scale", "0", "--out", str(other), "--", "--env", "LightSail3D-v0"]) == 2
    assert "--env: only train_jax.py's PPO settings" in capsys.readouterr().err and not other.exists()
