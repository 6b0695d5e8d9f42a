"""``python -m sail_env.analysis.paper``: its numbers against independent closed forms and the seed's equations."""

import json
import math

import numpy as np
import pytest
import scipy.integrate

from sail_env.analysis import paper
from sail_env.physics import DEEP_DISH, FLAT, SEED, PlanarModel
from sail_env.physics.constants import LIGHT_YEAR, SPEED_OF_LIGHT, STEFAN_BOLTZMANN
from tests.conftest import seed_rhs

FIGURES = ("figure4_relativity", "figure5_perturbations", "stability_map", "pointing_tolerance")
OMEGA = math.sqrt(SEED.push_force_n / (2 * SEED.total_mass_kg * SEED.curvature_radius_m))  # seed X mode
VZ = SEED.push_force_n / SEED.total_mass_kg * SEED.beam_cutoff_s
X_EQ_PER_RAD = 2 * SEED.curvature_radius_m - SEED.com_distance_m  # X_eq = θ (2R − Lc)


def _reject(constant):
    raise ValueError(f"non-standard JSON constant {constant}")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    assert paper.main(["--out", str(out), "--quick"]) == 0
    return out, json.loads((out / "report.json").read_text(), parse_constant=_reject)


def _growth_rate(config) -> float:
    """Largest real eigenvalue part of the seed's eqs 16-19, linearised column by column."""
    a = np.column_stack([seed_rhs(config, e) for e in np.eye(4)])
    return max(np.linalg.eigvals(a).real.max(), 0.0)


def test_writes_report_and_figures(run):
    out, report = run
    for name in FIGURES:
        png = (out / f"{name}.png").read_bytes()
        assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 10_000
    text = (out / "report.md").read_text()
    assert f"`python -m sail_env.analysis.paper --out {out} --quick`" in text
    assert report["quick"] is True and paper.QUICK_NOTE in text
    assert report["versions"]["numpy"] == np.__version__
    assert f"{report['relativity']['t_0.2c_doppler_s']:.1f} s" in text
    assert f"{report['tolerance']['max_passive_tilt_rad']:.3e} rad" in text
    for difference in report["differences"]:
        assert all(difference[k] for k in paper.DIFFERENCE_FIELDS)
        assert f"| {difference['topic']} |" in text


def test_relativity_against_closed_forms(run):
    rel = run[1]["relativity"]
    power, mass, beta, c = 50e9, 1e-3, 0.2, SPEED_OF_LIGHT
    k = 2 * power / (mass * c**2)
    # Seed eq 7 as printed, γβ = k t without Doppler, and the Doppler law by quadrature.
    eq7 = mass * c**2 / (4 * power) * (beta / (1 - beta**2) + 0.5 * math.log((1 + beta) / (1 - beta)))
    doppler, _ = scipy.integrate.quad(lambda b: (1 + b) / ((1 - b) * (1 - b * b) ** 1.5 * k), 0, beta)
    assert rel["t_0.2c_seed_eq7_s"] == pytest.approx(eq7, rel=1e-9)
    assert rel["t_0.2c_no_doppler_s"] == pytest.approx(beta / math.sqrt(1 - beta**2) / k, rel=1e-9)
    assert rel["t_0.2c_doppler_s"] == pytest.approx(doppler, rel=1e-9)
    assert (rel["t_0.2c_seed_eq7_s"], rel["t_0.2c_no_doppler_s"], rel["t_0.2c_doppler_s"]) == pytest.approx(
        (184.7, 183.5, 226.4), abs=0.1)
    for row in rel["by_mass"]:  # every time scales with the mass
        assert row["t_0.2c_doppler_s"] == pytest.approx(doppler * row["mass_kg"] / mass, rel=1e-9)


def test_figure5_oscillation_between_start_and_mirror_image(run):
    fig5 = run[1]["figure5"]
    for case, (x0, theta0) in zip(fig5["cases"], paper.FIGURE5_STARTS):
        x_eq = theta0 * X_EQ_PER_RAD
        assert case["x_min_m"] == pytest.approx(x0, abs=1e-12)
        assert case["x_max_m"] == pytest.approx(2 * x_eq - x0, rel=1e-4)
        assert case["amplitude_m"] == pytest.approx(abs(x_eq - x0), rel=1e-4)
        assert case["theta_at_zoom_end_rad"] == pytest.approx(theta0, rel=1e-9)  # R = Lc: θ never changes
        assert case["x_max_if_theta0_in_degrees_m"] == pytest.approx(
            2 * math.radians(theta0) * X_EQ_PER_RAD - x0, rel=1e-4)
    seed_peaks = paper.SEED_CLAIMS["figure5_x_max_m"]
    assert [c["x_max_m"] for c in fig5["cases"]] == pytest.approx(seed_peaks, rel=0.01)
    assert fig5["period_s"] == pytest.approx(2 * math.pi / OMEGA)
    assert fig5["flat_growth_rate_s-1"] == pytest.approx(_growth_rate(FLAT), rel=1e-9)
    # |Vx| of the flat sail crosses c at the reported time (to the 2000-sample resolution).
    flat, t_c = PlanarModel(FLAT), fig5["flat_vx_exceeds_c_after_s"]
    start = np.array([paper.FIGURE5_STARTS[1][0], 0.0, paper.FIGURE5_STARTS[1][1], 0.0])
    speed = [abs((flat.discretize(t)[0] @ start)[1]) for t in (t_c - 2e-4, t_c)]
    assert speed[0] < SPEED_OF_LIGHT <= speed[1]


def test_stability_against_the_seed_equations(run):
    stab = run[1]["stability"]
    assert stab["seed"]["kind"] == "neutral"
    assert stab["seed"]["frequencies_rad_s"] == pytest.approx([OMEGA])
    assert sorted(e[1] for e in stab["seed"]["eigenvalues"]) == pytest.approx([-OMEGA, 0, 0, OMEGA], abs=1e-9)
    for key, radius in (("growth_rate_R15m_s-1", 15.0), ("growth_rate_R_1pc_above_Lc_s-1", 10.1)):
        assert stab[key] == pytest.approx(_growth_rate(SEED.replace(curvature_radius_m=radius)), rel=1e-9)
    assert stab["growth_rate_R15m_s-1"] == pytest.approx(57.735, abs=1e-3)
    assert stab["flat_growth_rate_s-1"] == pytest.approx(100.0)
    a = np.column_stack([seed_rhs(DEEP_DISH, e) for e in np.eye(4)])
    assert stab["deep_dish_frequencies_rad_s"] == pytest.approx(sorted(np.linalg.eigvals(a).imag)[2:])
    assert stab["unstable_for_every_R_above_Lc"]
    assert stab["max_growth_rate_R_below_Lc_s-1"] == 0.0
    # With L = 2 Lc the stiffness discriminant is (2 Lc/R − 3)²/4: the frequencies cross at R = 2 Lc/3.
    assert stab["frequency_crossing_R_over_Lc"] == pytest.approx(2 / 3, abs=0.05)


def test_pointing_tolerance_against_the_analytic_band(run):
    tol = run[1]["tolerance"]
    limit, phase = tol["tolerance_rad"], abs(math.sin(OMEGA * SEED.beam_cutoff_s))
    # Vx = −ω (X0 − θ0 (2R − Lc)) sin ωt: envelope ω |X0 − X_eq| / Vz; at cut-off × |sin ω t_cut|.
    max_offset = limit * VZ / OMEGA
    assert tol["max_passive_offset_m"] == pytest.approx(max_offset, rel=1e-4)
    assert tol["max_passive_tilt_rad"] == pytest.approx(max_offset / X_EQ_PER_RAD, rel=1e-4)
    assert tol["max_passive_offset_at_cutoff_m"] == pytest.approx(max_offset / phase, rel=1e-9)
    assert tol["max_passive_tilt_at_cutoff_rad"] == pytest.approx(max_offset / phase / X_EQ_PER_RAD, rel=1e-9)
    assert tol["max_passive_tilt_rad"] == pytest.approx(8.5e-4, rel=0.01)
    for (x0, theta0), cut, env in zip(paper.FIGURE5_STARTS, tol["figure5_pointing_at_cutoff_rad"],
                                      tol["figure5_pointing_envelope_rad"]):
        envelope = OMEGA * abs(x0 - theta0 * X_EQ_PER_RAD) / VZ
        assert env == pytest.approx(envelope, rel=1e-4)
        assert cut == pytest.approx(envelope * phase, rel=1e-9)
    assert tol["figure5_pointing_at_cutoff_rad"][0] == pytest.approx(8.5e-9, rel=0.01)
    # The success map is the band |X0 − θ0 (2R − Lc)| ≤ max offset, counted on the same grid.
    n = tol["map_points_per_axis"]
    tilts, offsets = np.meshgrid(np.linspace(*tol["map_tilt_range_rad"], n),
                                 np.linspace(*tol["map_offset_range_m"], n))
    miss = np.abs(offsets - tilts * X_EQ_PER_RAD)
    assert tol["map_success_fraction_envelope"] == pytest.approx(np.mean(miss <= max_offset))
    assert tol["map_success_fraction_at_cutoff"] == pytest.approx(np.mean(miss <= max_offset / phase))
    assert 0.1 < tol["map_success_fraction_envelope"] < tol["map_success_fraction_at_cutoff"] < 0.9


def test_material_and_mission_numbers(run):
    mis = run[1]["mission"]
    alu, power = mis["aluminium"], mis["power"]
    assert mis["eq20_tolerance_rad"] == pytest.approx(4e8 / (4.25 * LIGHT_YEAR))
    assert mis["eq24_required_figure_of_merit"] == pytest.approx(
        1e5 * 5e-5 * SPEED_OF_LIGHT / (4 * STEFAN_BOLTZMANN * 1000.0**4))
    assert mis["eq24_required_figure_of_merit"] == pytest.approx(6.6e3, rel=0.01)
    areal = 4 * STEFAN_BOLTZMANN / SPEED_OF_LIGHT * 0.06 * 0.82 * 600.0**4 / (0.135 * 1.32)
    assert alu["areal_density_for_1.32_m_s2_kg_m2"] == pytest.approx(areal)
    assert alu["thickness_for_1.32_m_s2_m"] == pytest.approx(10e-9, rel=0.01)
    assert alu["acceleration_at_seed_areal_density_m_s2"] == pytest.approx(1.32 * areal / 5e-5)
    assert power["push_at_full_power_n"] == pytest.approx(2 * 50e9 / SPEED_OF_LIGHT)
    assert power["power_for_seed_push_w"] == pytest.approx(100.0 * SPEED_OF_LIGHT / 2)
    assert mis["distance_at_cutoff_m"] == pytest.approx(0.5 * 1e5 * 600.0**2)
    assert mis["one_way_light_delay_at_cutoff_s"] == pytest.approx(1.8e10 / SPEED_OF_LIGHT)
    # 2 (a t²/2)/c = period  ⇒  t = √(c · period / a).
    assert mis["round_trip_exceeds_period_after_s"] == pytest.approx(
        math.sqrt(SPEED_OF_LIGHT * 2 * math.pi / OMEGA / 1e5), rel=1e-9)
