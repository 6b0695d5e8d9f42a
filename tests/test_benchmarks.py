"""The benchmark scripts that print README tables run (one episode per cell): they import the
library, and a refactoring that breaks them fails here rather than when someone re-measures."""

import json

import numpy as np
import pytest

import gymnasium as gym

from benchmarks import coast_draws, coast_interaction, coast_modal, coast_vs_nonlinear, cross_kernel, delay_absorption_3d, realistic_ablation, speed, uncertain_sizes


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


def test_a_modal_coast_piece_has_the_exact_moments_to_the_push_noises_own_feedback():
    """benchmarks/coast_modal.py: a 5 s piece of the v1 coast in the drift's eigenbasis against the
    45×45 moment exponential. The mean is exact (measured 1e-13 of the start limits); the covariance
    leaves out the push noise acting on the spread made within the piece, 2–4 % (measured), which one
    Richardson step takes to 1–5e-4. The beam jitter's part alone agrees with Van Loan's (1978)
    additive covariance to round-off."""
    from sail_env.analysis.jitter import propagate_covariance
    from sail_env.physics.noise import mean_and_covariance, second_moment

    env = gym.make("LightSail3DRealistic-v1")
    env.reset(seed=100003)
    plant, params = env.unwrapped.core.spec.plant, env.unwrapped.core.state.params
    units = plant.start_limits()
    x, u, middles = 0.01 * units[None], np.array([[1e-3, -2e-3, 1e-4, 0.0]]), np.array([300.0])
    start = second_moment(x[0], np.zeros((8, 8)))

    def exact_moments() -> tuple[np.ndarray, np.ndarray]:
        (propagator,) = plant._piece_propagators(params, u, middles[None], np.array([5.0]))
        return mean_and_covariance(propagator[0] @ start)

    mean, cov = exact_moments()
    drift, mult, additive = (m[0] for m in coast_modal.piece_matrices(plant, params, u, middles))
    scale = np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    errors = {}
    for richardson in (False, True):
        modal_mean, modal_cov = coast_modal.modal_piece(drift, mult, additive, plant.white_noise.push_psd_s, 5.0,
                                                        x[0], richardson)
        assert np.max(np.abs(modal_mean - mean) / units) < 1e-11
        errors[richardson] = np.max(np.abs(modal_cov - cov) / scale)
    assert 1e-2 < errors[False] < 0.1 and errors[True] < 1e-3
    # The beam jitter alone against Van Loan's additive covariance (no second moment, so no mean whose
    # square the small covariance is lost against).
    _, jitter_cov = coast_modal.modal_piece(drift, mult, additive, 0.0, 5.0, x[0], False)
    van_loan = propagate_covariance(np.zeros((8, 8)), drift[:8, :8], additive[:8, :8], 5.0)
    jitter_scale = np.sqrt(np.outer(np.diag(van_loan), np.diag(van_loan)))
    assert np.max(np.abs(jitter_cov - van_loan) / jitter_scale) < 1e-9


@pytest.mark.parametrize("x", [1e-6 + 2e-7j, 9e-4j, 1.1e-3 - 2e-4j, 0.1 + 0.3j, -0.4j])
def test_the_divided_difference_of_the_exponential_on_both_sides_of_its_series(x):
    """``∫₀^h e^{ν(h−r)} e^{μr} dr = h e^{νh} Σ xᵏ/(k+1)!`` with ``x = (μ − ν) h``: 25 terms of the
    series are exact to round-off for ``|x| ≤ 0.5``; the benchmark's form is a short series below
    ``|x| = 1e-3`` and the quotient of exponentials above, which inherits their phases' round-off,
    ``ε |μh| / |x|`` relative (``|μh|`` ~ 800 rad here); the series is good to ~1e-14."""
    import cmath
    import math

    h, nu = 5.0, -2e-9 + 155.6j
    mu = nu + x / h
    x = (mu - nu) * h  # as represented (the subtraction is exact)
    reference = h * cmath.exp(nu * h) * sum(x**k / math.factorial(k + 1) for k in range(25))
    value = coast_modal._divided(nu, mu, cmath.exp(nu * h), cmath.exp(mu * h), h)
    phase = 0.0 if abs(x) < coast_modal.SERIES_BELOW else 4 * np.finfo(float).eps * abs(mu * h) / abs(x)
    assert abs(value - reference) < (1e-13 + phase) * abs(reference)


@pytest.mark.parametrize("delta", [0.0, 1e-4, 0.1 + 0.3j, 0.39j, 0.41, 2.0 - 5.0j, -0.02 + 155.0j])
def test_the_interaction_pictures_moments_on_both_sides_of_its_series(delta):
    """``∫_{−h/2}^{h/2} τⁿ e^{δτ} dτ`` (n ≤ 3) against adaptive quadrature, on both sides of the
    series' bound ``|δ| h/2 = 1`` and at the fast mode's 155 rad/s."""
    import scipy.integrate

    half = 2.5
    values = coast_interaction.moments(np.array([delta]), half, 3)[:, 0]
    for n, value in enumerate(values):
        parts = [scipy.integrate.quad(lambda t, part=part: part(t**n * np.exp(delta * t)), -half, half, limit=4000)[0]
                 for part in (np.real, np.imag)]
        reference = complex(*parts)
        assert abs(value - reference) <= 1e-11 * abs(reference) + 1e-15


def _two_oscillators() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Two lightly damped oscillators 0.005 rad/s apart near 30 rad/s, with the augmented state's
    constant (5×5): their kinematics, their stiffness and push (what a changing power scales) and a
    coupling between them."""
    kinematics = np.zeros((5, 5))
    kinematics[0, 1] = kinematics[2, 3] = 1.0
    kinematics[1, 1] = kinematics[3, 3] = -0.01
    stiffness = np.zeros((5, 5))
    stiffness[1, 0], stiffness[3, 2], stiffness[1, 4], stiffness[3, 4] = -900.0, -900.3, 50.0, 20.0
    coupling = np.zeros((5, 5))
    coupling[1, 2] = coupling[3, 0] = 1.0
    return kinematics, stiffness, coupling


def test_the_interaction_picture_step_with_its_secular_term_takes_long_pieces():
    """Two oscillators 0.005 rad/s apart (30 rad/s), whose stiffness and push change by ±20 % and
    whose coupling swings by ±3 /s² over a minute, over 30 s of 1 s pieces (30 turns of the phase
    each), against DOP853: the midpoint rule is off by the state's own size, the interaction
    picture's first term by 8 %, with the eigenvalues' secular second-order shift by 0.14 %. Each is
    a factor below the one before: dropping the shift fails, and so does taking it over the
    near-degenerate pairs too (their varying coupling then divides by their gap: 1.6 %)."""
    import math

    import scipy.integrate
    import scipy.linalg

    kinematics, stiffness, coupling = _two_oscillators()

    def generator(t):
        return kinematics + (1.0 + 0.2 * math.sin(t / 10.0)) * stiffness + 3.0 * math.sin(t / 7.0) * coupling

    start, span, h = np.array([1e-3, 0.0, 0.0, 0.0, 1.0]), 30.0, 1.0
    exact = scipy.integrate.solve_ivp(lambda t, z: generator(t) @ z, (0.0, span), start, method="DOP853",
                                      rtol=1e-12, atol=1e-16).y[:, -1]
    midpoint, first, second = start.copy(), start.copy(), start.copy()
    for i in range(math.ceil(span / h)):
        middle = (i + 0.5) * h
        change = coast_interaction.change_of(generator, middle, h)
        midpoint = scipy.linalg.expm(h * generator(middle)) @ midpoint
        first = coast_interaction.interaction_step(generator(middle), change, h, False) @ first
        second = coast_interaction.interaction_step(generator(middle), change, h, True) @ second
    scale = np.array([1e-3, 3e-2, 1e-3, 3e-2])
    errors = [np.linalg.norm((z - exact)[:4] / scale) for z in (midpoint, first, second)]
    assert errors[0] > 1.0 and errors[1] < 0.1 * errors[0] and errors[2] < 0.03 * errors[1] and errors[2] < 2e-3


def test_the_interaction_picture_step_carries_second_moments_with_multiplicative_noise():
    """The same two oscillators' second-moment equation (25×25: the drift on both sides, a push-like
    noise that scales the stiffness, PSD 1e-6 s, and a growing additive noise on both velocities),
    from a point over 30 s in 3 s pieces (90 rad of phase each), against DOP853 of the mean and the
    covariance themselves. The second-order term on every slowly turning pair (the block, as in the
    coast's moment equation, benchmarks/coast_interaction.py) brings the covariance to 2.9e-4 and the
    mean to 3.6e-3 of the spread; the eigenvalues' shift alone (the diagonal) leaves 4.6e-4 and
    5.1e-3, no second-order term 1.5e-2 and 0.12: the bounds fail both. The same in the interaction
    picture of the clustered base (the drift's Kronecker sum, the noise kept only within slowly
    turning clusters, no eigensolve of the whole generator): 2.1e-4 and 3.6e-3; with the drift's
    Kronecker sum alone as the base, or clusters of the exactly degenerate modes only, 1.1e-2."""
    import math

    import scipy.integrate

    kinematics, stiffness, coupling = _two_oscillators()
    push_psd, ones = 1e-6, np.eye(5)

    def model(t):
        scale = 1.0 + 0.2 * math.sin(t / 10.0)
        additive = np.zeros((5, 5))
        additive[1, 1] = additive[3, 3] = 1e-8 * (1.0 + t / 10.0) ** 2
        return kinematics + scale * stiffness + 3.0 * math.sin(t / 7.0) * coupling, scale * stiffness, additive

    def generator(t):
        drift, mult, additive = model(t)
        out = np.kron(drift, ones) + np.kron(ones, drift) + push_psd * np.kron(mult, mult)
        out[:, -1] += additive.ravel()  # the intensity times the constant's M_nn = 1
        return out

    def moments(t, y):
        drift, mult, additive = model(t)
        mean, cov = y[:5], y[5:].reshape(5, 5)
        change = drift @ cov + cov @ drift.T + push_psd * mult @ (cov + np.outer(mean, mean)) @ mult.T + additive
        return np.concatenate([drift @ mean, change.ravel()])

    start, span, h = np.array([1e-3, 0.0, 0.0, 0.0, 1.0]), 30.0, 3.0
    end = scipy.integrate.solve_ivp(moments, (0.0, span), np.concatenate([start, np.zeros(25)]), method="DOP853",
                                    rtol=1e-12, atol=1e-30).y[:, -1]
    mean, cov = end[:4], end[5:].reshape(5, 5)[:4, :4]
    spread = np.sqrt(np.diag(cov))
    for clustered in (False, True):
        second = np.outer(start, start).ravel()
        for i in range(round(span / h)):
            middle = (i + 0.5) * h
            if clustered:
                lam, vec, inv, base = coast_interaction.clustered_base(generator(middle), model(middle)[0], 0.5 * h)
                change = coast_interaction.change_of(generator, middle, h, base=base)
                second = coast_interaction.step_in_basis(lam, vec, inv, change, h, True) @ second
            else:
                change = coast_interaction.change_of(generator, middle, h)
                second = coast_interaction.interaction_step(generator(middle), change, h, True) @ second
        m, c = coast_interaction.mean_and_covariance_of(second)
        mean_error = np.max(np.abs(m - mean) / spread)
        cov_error = np.max(np.abs(c - cov) / np.outer(spread, spread))
        assert mean_error < 4.2e-3 and cov_error < 3.6e-4, clustered


def test_the_draws_benchmarks_today_is_the_plants_own_coast(monkeypatch):
    """``coast_draws``' "today" (a draw after every piece) is the plant's ``coast`` with the same
    normals, and its draw once at the end has the composed pieces' exact moments: the same end
    states to 1e-6 (the coast magnifies a last-bit difference of a batched against a broadcast
    product to ~1e-8; a wrong normal moves them by their spread), and a mean within four standard
    errors."""
    plant, coasts = coast_modal.record_coasts("LightSail3DRealistic-v1", ["passive"], 1)
    coast = max(coasts, key=lambda c: float(c["duration"][0]))
    samples, n = 4, plant.n_states
    pieces = coast_modal.pieces_of(plant, coast)[0]
    drawn = coast_draws.end_states(plant, coast, 1, 1, samples, np.random.default_rng(5))
    rng = np.random.default_rng(5)
    normals = np.stack([rng.standard_normal((samples, n)) for _ in range(pieces)], axis=1)
    repeat = np.zeros(samples, dtype=int)
    expected, diverged = plant.coast(coast["p"].repeat(samples), coast["x"][repeat], coast["u"][repeat],
                                     coast["duration"][repeat], normals, coast["start_s"][repeat])
    assert not diverged.any()
    np.testing.assert_allclose(drawn, expected, rtol=1e-6, atol=0.0)

    once = coast_draws.end_states(plant, coast, 1, 10**9, 4000, np.random.default_rng(6))
    count, length, middles = coast_modal.pieces_of(plant, coast)
    moment = coast_modal.second_moment(coast["x"], np.zeros((1, n, n)))
    for propagator in plant._piece_propagators(coast["p"], coast["u"], middles[None], np.array([length])):
        moment = (propagator @ moment[:, :, None])[:, :, 0]
    mean, cov = coast_modal.mean_and_covariance(moment)
    spread = np.sqrt(np.diag(cov[0]) / len(once))
    assert np.all(np.abs(once.mean(axis=0) - mean[0]) < 4.0 * spread)

    draws = []
    monkeypatch.setattr(coast_draws, "sample_gaussian", lambda *args: draws.append(1) or coast_modal.sample_gaussian(*args))
    for every, expected_draws in ((1, pieces), (10, -(-pieces // 10)), (10**9, 1)):
        draws.clear()
        coast_draws.end_states(plant, coast, 1, every, 2, np.random.default_rng(7))
        assert len(draws) == expected_draws


def test_interpolated_eigenbases_rebuild_each_pieces_drift():
    """``coast_modal.interpolated_bases`` on LQG's coast to cut-off: every piece's ``V Λ V⁻¹`` from the
    splines is its own drift to 1e-8 of the drift's size (2.8e-9; a spline across a phase the
    eigensolver flipped, or modes taken in another order, would be off by the drift's size), and
    worse with half the eigensolves (4.4e-8); a coast across the spot's kink (passive, seed 100000)
    is refused, where the splines would be off by 1 %."""
    plant, coasts = coast_modal.record_coasts("LightSail3DRealistic-v1", ["passive", "lqg"], 2)
    kinked, coast = (max((c for c in coasts if c["agent"] == agent), key=lambda c: float(c["duration"][0]))
                     for agent in ("passive", "lqg"))
    _, _, middles = coast_modal.pieces_of(plant, coast)
    drift = coast_modal.piece_matrices(plant, coast["p"], coast["u"], middles)[0]
    errors = []
    for spacing in (25.0, 50.0):
        lam, vec, inv = coast_modal.interpolated_bases(plant, coast, spacing)
        rebuilt = np.einsum("cij,cj,cjk->cik", vec, lam, inv)
        errors.append(np.max(np.abs(rebuilt - drift)) / np.max(np.abs(drift)))
    assert errors[0] < 1e-8 and errors[1] > 4.0 * errors[0]
    assert coast_modal.split_pieces(plant, kinked).any()
    with pytest.raises(ValueError, match="kink"):
        coast_modal.interpolated_bases(plant, kinked, 25.0)


@pytest.mark.parametrize("leak", [0.0, 1e-9])
def test_a_defective_drift_is_refused_by_the_modal_piece(leak):
    """A free mass pushed by a constant force: the augmented drift is a Jordan block, with no
    eigenbasis for the closed form (without the guard, a near one left the mean off by 0.19 and the
    covariance NaN). Exactly defective, the eigenvectors' inverse fails; nearly, the guard refuses."""
    drift = np.zeros((3, 3))
    drift[0, 1], drift[1, 1], drift[1, 2] = 1.0, -leak, 1e-3  # x' = v, v' = −leak v + constant
    with pytest.raises(ValueError, match="eigenbasis" if leak else "singular"):
        coast_modal.modal_piece(drift, np.zeros((3, 3)), np.zeros((3, 3)), 0.0, 5.0, np.array([0.1, 0.2]), False)


def test_two_blas_kernels_play_the_same_episodes(tmp_path, capsys):
    """Two children under two OpenBLAS kernels (Prescott's generic one against this machine's):
    the noisy planar task's pointing to 5e-10 (measured on 200 episodes), far inside the bound."""
    summary = cross_kernel.main(["--episodes", "3", "--tasks", "LightSailRealistic-v0", "--out", str(tmp_path)])
    assert summary["tasks"]["LightSailRealistic-v0"]["max_relative_difference"] < cross_kernel.SAME_EPISODES
    assert (tmp_path / "cross_kernel_passive.json").is_file()


def test_speed_takes_turns_and_writes_its_tables_into_the_readme(tmp_path, capsys, monkeypatch):
    """Peer and subject alternate (A, B, A, B): a burst of load on the machine cannot favour one."""
    order = []
    timed = speed.timed
    monkeypatch.setattr(speed, "timed", lambda work: (order.append(work), timed(work))[1])
    readme = tmp_path / "README.md"
    readme.write_text("before\n<!-- speed-table:start -->\nold\n<!-- speed-table:end -->\nafter\n")
    args = ["--quick", "--sections", "single", "--tasks", "LightSail-v0", "--out", str(tmp_path / "speed.json"),
            "--readme", str(readme)]
    assert speed.main(args) == 0
    assert len(order) == 4 and order[0] is order[2] and order[1] is order[3] and order[0] is not order[1]
    text = readme.read_text()
    assert text.startswith("before\n<!-- speed-table:start -->\nMeasured on ") and text.endswith("after\n")
    assert "| LightSail-v0 | " in text and "old" not in text
    rounds = __import__("json").loads((tmp_path / "speed.json").read_text())["single"]["LightSail-v0"]
    assert len(rounds["LightSail-v0"]["rounds"]) == 2 and rounds["CartPole-v1"]["rate"] > 0


def test_speed_refuses_a_readme_without_its_markers_before_measuring(tmp_path, capsys):
    readme = tmp_path / "README.md"
    readme.write_text("no markers\n")
    assert speed.main(["--quick", "--readme", str(readme), "--out", str(tmp_path / "s.json")]) == 2
    assert "speed-table:start" in capsys.readouterr().err and not (tmp_path / "s.json").exists()


def test_first_try_trains_evaluates_and_appends_one_json_line(tmp_path, capsys):
    """docs/learners.md's first-try table: one update of the single-file PPO (one env, one
    episode of 256 steps), its row holding both evaluations and the training-time numbers; the
    noise table's LQR without noise succeeds."""
    from benchmarks import first_try

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


def test_learning_curves_average_the_seeds_and_draw_the_report_lines(tmp_path, capsys):
    """Two seeds' evaluations.npz (one evaluated further than the other) and an evaluate.py report:
    the curve stops at the steps both reached, and the printed summary is their mean."""
    from benchmarks import learning_curves

    for seed, rates in enumerate(([0.2, 0.6, 0.8], [0.4, 0.8])):
        run = tmp_path / f"run-seed{seed}"
        run.mkdir()
        successes = np.array([[1] * round(10 * r) + [0] * (10 - round(10 * r)) for r in rates])
        np.savez(run / "evaluations.npz", timesteps=10_000 * np.arange(1, len(rates) + 1), successes=successes)
    report = tmp_path / "report.json"
    report.write_text(json.dumps({"agents": {"lqg": {"success_rate": 0.84, "episodes": 500}}}))
    out = tmp_path / "curve.png"
    assert learning_curves.main(["--env", "LightSail-v0", "--runs", f"PPO={tmp_path}/run-seed*",
                                 "--report", str(report), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "2 seeds to 20,000 steps; last evaluation 70.0 % (seeds 60, 80)" in printed
    assert out.stat().st_size > 10_000
    assert learning_curves.main(["--env", "LightSail-v0", "--runs", "no-equals-sign", "--out", str(out)]) == 2


def test_learning_curves_from_a_grid_export_take_each_cells_latest_trial(tmp_path, capsys):
    """With --grid the glob picks cells by name; a cell run twice (redo) counts once, by its latest
    trial; a cell without intermediate values (no evaluations) or of another name is left out."""
    from benchmarks import learning_curves

    def trial(cell, curve):
        return {"user_attrs": {"cell": cell}, "intermediate_values": {str(10_000 * (i + 1)): r for i, r in enumerate(curve)}}

    export = tmp_path / "grid.json"
    export.write_text(json.dumps({"study": "g", "user_attrs": {}, "trials": [
        trial("T-sac-tuned-0", [0.0, 0.0]),  # replaced by its redo below
        trial("T-sac-tuned-1", [0.4, 0.8]),
        trial("T-sac-tuned-0", [0.2, 0.6, 0.8]),
        trial("T-sac-tuned-2", []),
        trial("T-ppo-tuned-0", [1.0, 1.0])]}))
    out = tmp_path / "curve.png"
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--runs", "SAC=T-sac-tuned-*",
                                 "--out", str(out)]) == 0
    assert "SAC: 2 seeds to 20,000 steps; last evaluation 70.0 % (seeds 60, 80)" in capsys.readouterr().out
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--runs", "TD3=T-td3-*", "--out", str(out)]) == 2
    assert "no run with a learning curve" in capsys.readouterr().err


def test_reference_lines_near_100_percent_stay_off_the_frame_and_are_named_together(tmp_path, capsys, monkeypatch):
    """The adaptive LQG and both bounds at 98-99 % once merged into the top of the frame: the axis now
    runs above 100 %, and lines too close to tell apart are named together above them; a line two
    points or more from its neighbours is not."""
    from benchmarks import learning_curves

    figures = []
    subplots = learning_curves.plt.subplots
    monkeypatch.setattr(learning_curves.plt, "subplots", lambda *a, **k: figures.append(subplots(*a, **k)) or figures[-1])
    export = tmp_path / "grid.json"
    export.write_text(json.dumps({"study": "g", "user_attrs": {}, "trials": [
        {"user_attrs": {"cell": f"T-ppo-tuned-{seed}"}, "intermediate_values": {"10000": 0.5, "20000": 0.9}}
        for seed in range(2)]}))
    report = tmp_path / "report.json"
    report.write_text(json.dumps({"agents": {name: {"success_rate": rate, "episodes": 500} for name, rate in
                                             (("lqg", 0.826), ("lqg-mm", 0.986), ("lqr-oracle", 0.992),
                                              ("lqg-oracle", 0.984))}}))
    assert learning_curves.main(["--env", "T", "--grid", str(export), "--runs", "PPO=T-ppo-*", "--report", str(report),
                                 "--out", str(tmp_path / "curve.png")]) == 0
    (fig, ax), = figures
    assert ax.get_ylim()[1] >= 105
    notes = [text.get_text() for text in ax.texts]
    assert notes == ["ceiling: LQG oracle / adaptive LQG (lqg-mm) / ceiling: LQR oracle: 98.4–99.2 %, on top of each other"]
    assert learning_curves.bundles({"a": (0.5, 1), "b": (0.52, 1), "c": (0.53, 1)}) == [["b", "c"]]


def test_every_reference_line_has_a_style():
    """zip() would drop a reference without one, silently (the fourth, lqg-oracle, once was)."""
    from benchmarks import learning_curves

    assert len(learning_curves.REFERENCE_STYLES) >= len(learning_curves.REFERENCES)


def test_uncertain_sizes_measures_each_scale_once_and_refuses_one_past_a_limit(tmp_path, capsys):
    out = tmp_path / "sizes.json"
    uncertain_sizes.main(["--episodes", "1", "--scales", "1", "2.5", "--out", str(out)])
    results = json.loads(out.read_text())
    assert set(results["x1"]["agents"]) == {"lqg", "lqg-mm-offset", "bank spanning the sizes", "lqg-oracle"}
    assert "absorptivity" in results["x2.5"]["refused"]
    capsys.readouterr()
    uncertain_sizes.main(["--episodes", "1", "--scales", "1", "--out", str(out)])  # measured: kept, not replayed
    assert "x1 lqg" not in capsys.readouterr().out


def test_results_table_goes_between_the_markers_and_a_file_without_them_is_refused(tmp_path, capsys):
    """``python -m benchmarks.results_table --readme FILE`` puts the table between FILE's markers and
    leaves the rest; a file without them is one line on stderr, exit 2, and stays as it was."""
    from agents import cli
    from benchmarks import results_table

    start, end = cli.section_markers(results_table.SECTION)
    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{start}\nold\n{end}\nafter\n")
    assert results_table.main(["--readme", str(readme)]) == 0
    assert readme.read_text() == f"before\n{start}\n{results_table.render()}\n{end}\nafter\n"
    plain = tmp_path / "plain.md"
    plain.write_text("no markers\n")
    capsys.readouterr()
    assert results_table.main(["--readme", str(plain)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no <!-- results-table:start -->" in err and plain.read_text() == "no markers\n"
