"""The seed paper reproduced and corrected: ``python -m sail_env.analysis.paper --out DIR``.

The seed is Team 258, "Problem A: sending a light sail propelled nanocraft to Alpha
Centauri" (MCM). This writes ``DIR/report.md``, ``DIR/report.json`` and PNG figures:
its Figure 4 (relativity) and Figure 5 (the perturbed spherical sail), a stability
map over ``R`` and ``Lc``, the passive sail's pointing tolerance, and its material and
mission numbers, each next to the project's verdict. Every number is computed here by
``sail_env.physics``; the only literals are the seed's inputs and, for comparison,
its stated results (``SEED_CLAIMS``).
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import scipy.optimize
from matplotlib.figure import Figure

from sail_env.physics import (
    DEEP_DISH, FLAT, SEED, PlanarModel, SailConfig, push_force_from_laser,
)
from sail_env.analysis.planar import EnvelopeEstimator
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.mission import (
    distance_flown_m,
    one_way_light_delay_s,
    pointing_tolerance_rad,
    required_figure_of_merit,
    thermal_acceleration_limit,
)
from sail_env.physics.planar.model import THETA, VX, X
from sail_env.physics.pointing import POINTING_TOLERANCE_RAD
from sail_env.physics.relativity import LAWS, beta_history, time_to_beta
from sail_env.provenance import package_versions

LASER_POWER_W = 50e9
TARGET_BETA = 0.2
FIGURE4_MASSES_KG = (1e-3, 2e-3, 5e-3, 10e-3)  # the first is the seed's craft
#: Seed Fig 5 starts (X0 [m], θ0 [rad]): its code's (0.001 cm, 0.001) and (0.0001 cm, 0.0001).
FIGURE5_STARTS = ((1e-5, 1e-3), (1e-6, 1e-4))
#: Envelope samples per oscillation period: the envelope is low by at most 1 − cos(π/256) ≈ 8e-5.
ENVELOPE_SAMPLES = 256
#: Seed eq 24 inputs: a = 0.2 c / 600 s rounded, 0.5 g over 10 m², T = 1000 K.
EQ24_INPUTS = {"acceleration_m_s2": 1e5, "temperature_k": 1000.0, "areal_density_kg_m2": 5e-5}
#: The seed's aluminium (after Forward 1984); "ρd = 2.71" is aluminium's bulk density in g/cm³.
ALUMINIUM = {"emissivity": 0.06, "reflectance": 0.82, "absorptance": 0.135, "temperature_k": 600.0,
             "density_kg_m3": 2710.0}
#: Results as the seed states them: compared with, never computed from.
SEED_CLAIMS = {
    "figure5_x_max_m": (0.02, 0.002),
    "required_tilt_rad": 1e-8,
    "required_offset_m": 1e-5,
    "aluminium_acceleration_m_s2": 1.32,
    "eq24_figure_of_merit": 6.6e3,
    "eq20_miss_distance_m": 4e8,
    "distance_at_cutoff_m": 1e10,
}
DIFFERENCE_FIELDS = ("topic", "seed", "here", "cause", "size")
SECTIONS = ("relativity", "figure5", "stability", "tolerance", "mission")
LAW_STYLES = {"doppler": ("-", "correct, with Doppler"), "no_doppler": ("--", "γ³, no Doppler"),
              "seed_eq7": (":", "seed eq 7")}


def _trajectory(model: PlanarModel, state: np.ndarray, duration: float,
                n: int) -> tuple[np.ndarray, np.ndarray]:
    """Passive states at ``n`` equally spaced times over ``duration`` (exact steps)."""
    times = np.linspace(0.0, duration, n)
    step, _ = model.discretize(times[1])
    states = [np.asarray(state, dtype=float)]
    for _ in range(n - 1):
        states.append(step @ states[-1])
    return times, np.array(states)


def _period(model: PlanarModel) -> float:
    """Period [s] of the fastest oscillation."""
    return 2 * math.pi / max(model.stability.frequencies)


def _start(x0: float, theta0: float) -> np.ndarray:
    state = np.zeros(4)
    state[X], state[THETA] = x0, theta0
    return state


def relativity(quick: bool) -> tuple[dict, Figure]:
    """Seed Fig 4: β(t) at 50 GW for several masses under the three laws (docs/physics.md §5)."""
    times_to = [{f"t_0.2c_{law}_s": time_to_beta(TARGET_BETA, LASER_POWER_W, m, law) for law in LAWS}
                for m in FIGURE4_MASSES_KG]
    times = np.linspace(0.0, 1.2 * max(times_to[-1].values()), 80 if quick else 400)
    fig = Figure(figsize=(7, 4.5))
    ax = fig.add_subplot()
    for i, mass in enumerate(FIGURE4_MASSES_KG):
        for law in LAWS:
            ax.plot(times, beta_history(times, LASER_POWER_W, mass, law), LAW_STYLES[law][0], color=f"C{i}",
                    label=f"{mass * 1e3:g} g" if law == "doppler" else None)
    for style, label in LAW_STYLES.values():
        ax.plot([], [], style, color="k", label=label)
    ax.axhline(TARGET_BETA, color="grey", lw=0.8)
    ax.set(xlabel="time [s]", ylabel="β",
           title=f"Seed Fig 4: β(t) at {LASER_POWER_W / 1e9:g} GW, perfect mirror")
    ax.legend(fontsize=8, ncol=2)
    one_gram = times_to[0]
    result = {"power_w": LASER_POWER_W, "mass_kg": FIGURE4_MASSES_KG[0], **one_gram,
              "doppler_over_seed_eq7": one_gram["t_0.2c_doppler_s"] / one_gram["t_0.2c_seed_eq7_s"],
              "by_mass": [{"mass_kg": m, **t} for m, t in zip(FIGURE4_MASSES_KG, times_to)]}
    return result, fig


def figure5(quick: bool) -> tuple[dict, Figure]:
    """Seed Fig 5: X(t) of the passive seed sail for its two starts, z(t), and the flat sail."""
    model = PlanarModel(SEED)
    t_cut = SEED.beam_cutoff_s
    period = _period(model)
    zoom = t_cut / 300  # the seed's zoomed panels
    zoom_samples = math.ceil(zoom / period * ENVELOPE_SAMPLES)
    fig = Figure(figsize=(10, 10), layout="constrained")
    axes = fig.subplots(3, 2)
    times = np.linspace(0.0, t_cut, 200)
    axes[0, 0].plot(times, distance_flown_m(SEED.axial_acceleration_m_s2, times) / 1e3)
    axes[0, 0].set(xlabel="time [s]", ylabel="z [km]", title="z(t): parabolic")
    cases = []
    for row, (x0, theta0) in enumerate(FIGURE5_STARTS, start=1):
        times, states = _trajectory(model, _start(x0, theta0), t_cut / 2, 3000 if quick else 30000)
        axes[row, 0].plot(times, states[:, X] * 100, lw=0.3, color=f"C{row}")
        zoom_times, zoom_states = _trajectory(model, _start(x0, theta0), zoom, zoom_samples)
        axes[row, 1].plot(zoom_times, zoom_states[:, X] * 100, color=f"C{row}")
        for ax, title in zip(axes[row], ("", " (zoom)")):
            ax.set(xlabel="time [s]", ylabel="X [cm]", title=f"X0 = {x0:g} m, θ0 = {theta0:g} rad{title}")
        _, as_degrees = _trajectory(model, _start(x0, math.radians(theta0)), zoom, zoom_samples)
        x_min, x_max = float(zoom_states[:, X].min()), float(zoom_states[:, X].max())
        cases.append({"x0_m": x0, "theta0_rad": theta0, "x_min_m": x_min, "x_max_m": x_max,
                      "amplitude_m": (x_max - x_min) / 2,
                      "theta_at_zoom_end_rad": float(zoom_states[-1, THETA]),
                      "x_max_if_theta0_in_degrees_m": float(as_degrees[:, X].max())})
    flat = PlanarModel(FLAT)
    growth = flat.stability.growth_rate
    flat_times, flat_states = _trajectory(flat, _start(*FIGURE5_STARTS[1]), 25 / growth, 2000)
    speed = np.abs(flat_states[:, VX])
    axes[0, 1].semilogy(flat_times, np.abs(flat_states[:, X]), label="|X| [m]")
    axes[0, 1].semilogy(flat_times, speed, label="|Vx| [m/s]")
    axes[0, 1].axhline(SPEED_OF_LIGHT, color="grey", lw=0.8, label="c")
    axes[0, 1].set(xlabel="time [s]", title=f"Flat sail from X0 = {FIGURE5_STARTS[1][0]:g} m, "
                   f"θ0 = {FIGURE5_STARTS[1][1]:g} rad")
    axes[0, 1].legend(fontsize=8)
    result = {"cases": cases, "zoom_s": zoom, "period_s": period, "flat_growth_rate_s-1": growth,
              "flat_vx_exceeds_c_after_s": float(flat_times[np.argmax(speed >= SPEED_OF_LIGHT)])}
    return result, fig


def _stability_row(config: SailConfig) -> tuple[float, list[float], str]:
    """Growth rate (no -0.0), oscillation frequencies and kind of one configuration."""
    stability = PlanarModel(config).stability
    return stability.growth_rate + 0.0, list(stability.frequencies), stability.kind.value


def stability(quick: bool) -> tuple[dict, Figure]:
    """Growth rate and frequencies against R/Lc, and over (R, Lc) with L = 2 Lc (equal masses)."""
    lc = SEED.com_distance_m
    ratios = np.linspace(SEED.aperture_radius_m / lc, 3.0, 60 if quick else 600)
    rows = [_stability_row(SEED.replace(curvature_radius_m=r * lc)) for r in ratios]
    growth = np.array([g for g, _, _ in rows])
    freqs = np.array([(f + [math.nan, math.nan])[:2] for _, f, _ in rows])
    seed_growth, seed_freqs, seed_kind = _stability_row(SEED)
    fig = Figure(figsize=(13, 4.2), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(1, 3)
    ax1.plot(ratios, growth, color="C3", label="growth rate [1/s]")
    ax1.plot(ratios, freqs, ".", ms=2, color="C0")
    ax1.plot([], [], ".", color="C0", label="frequencies [rad/s]")
    ax1.axhline(_stability_row(FLAT)[0], color="grey", ls="--", lw=0.8, label="flat sail growth")
    ax1.plot([1.0] * len(seed_freqs), seed_freqs, "k*", ms=12, label="seed design")
    ax1.set(xlabel="R / Lc", ylabel="[1/s]", title=f"Lc = {lc:g} m, L = {SEED.strut_length_m:g} m")
    ax1.legend(fontsize=8)

    n = 25 if quick else 121
    r_grid = np.linspace(SEED.aperture_radius_m, 30.0, n)
    lc_grid = np.linspace(2.0, 20.0, n)
    grid = [[_stability_row(SEED.replace(curvature_radius_m=r, com_distance_m=c, strut_length_m=2 * c))
             for r in r_grid] for c in lc_grid]
    growth_map = np.array([[g for g, _, _ in row] for row in grid])
    slow_map = np.array([[min(f) if f and g == 0 else math.nan for g, f, _ in row] for row in grid])
    for ax, data, label in ((ax2, growth_map, "growth rate [1/s]"),
                            (ax3, slow_map, "slowest frequency [rad/s] (white: unstable)")):
        mesh = ax.pcolormesh(r_grid, lc_grid, data, shading="nearest")
        fig.colorbar(mesh, ax=ax, label=label)
        ax.plot(r_grid, r_grid, "w--", lw=0.8)
        ax.plot(SEED.curvature_radius_m, lc, "r*", ms=14)
        ax.set(xlabel="R [m]", ylabel="Lc [m] (L = 2 Lc)", ylim=(lc_grid[0], lc_grid[-1]), title=label)
    r_map, lc_map = np.meshgrid(r_grid, lc_grid)
    # Which side of R = Lc, with points on it (to rounding) on neither.
    side = np.concatenate([np.sign(ratios - 1) * ~np.isclose(ratios, 1),
                           (np.sign(r_map - lc_map) * ~np.isclose(r_map, lc_map)).ravel()])
    all_growth = np.concatenate([growth, growth_map.ravel()])
    below, above = all_growth[side < 0], all_growth[side > 0]
    result = {
        "seed": {"kind": seed_kind, "growth_rate_s-1": seed_growth, "frequencies_rad_s": seed_freqs,
                 "eigenvalues": [[float(e.real), float(e.imag)]
                                 for e in PlanarModel(SEED).stability.eigenvalues]},
        "growth_rate_R15m_s-1": _stability_row(SEED.replace(curvature_radius_m=15.0))[0],
        "growth_rate_R_1pc_above_Lc_s-1": _stability_row(SEED.replace(curvature_radius_m=1.01 * lc))[0],
        "deep_dish_frequencies_rad_s": _stability_row(DEEP_DISH)[1],
        "flat_growth_rate_s-1": _stability_row(FLAT)[0],
        "unstable_for_every_R_above_Lc": bool(np.all(above > 0)),
        "max_growth_rate_R_below_Lc_s-1": float(below.max()),
        "frequency_crossing_R_over_Lc": float(ratios[np.nanargmin(np.abs(freqs[:, 1] - freqs[:, 0]))]),
    }
    return result, fig


def tolerance(quick: bool) -> tuple[dict, Figure]:
    """Passive seed sail: terminal pointing |Vx|/Vz at cut-off against initial (X0, θ0) (docs/physics.md §2).

    The sail succeeds if the pointing is within ``POINTING_TOLERANCE_RAD`` (seed eq 20),
    either at exactly ``t_cut`` or, phase-free, for the envelope over the cut-off phase.
    The model is linear, so the pointing scales with the size of the start along any ray:
    the largest tolerated tilt (at zero offset) is the tolerance over the pointing per
    radian, and likewise the offset.
    """
    model = PlanarModel(SEED)
    t_cut = SEED.beam_cutoff_s
    end, _ = model.discretize(t_cut)
    speed = model.equilibrium_speed(t_cut)
    estimator = EnvelopeEstimator(model, samples_per_fast_period=ENVELOPE_SAMPLES)
    hold = np.zeros(model.B.shape[1])

    def pointing(starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ends = starts @ end.T
        envelope = np.array([estimator.peak_speed(s, hold) for s in ends])
        return np.abs(ends[:, VX]) / speed, envelope / speed

    at_cut, envelope = pointing(np.array([_start(0.0, 1.0), _start(1.0, 0.0)]))
    max_tilt, max_offset = POINTING_TOLERANCE_RAD / envelope
    max_tilt_cut, max_offset_cut = POINTING_TOLERANCE_RAD / at_cut
    n = 41 if quick else 201
    tilts = np.linspace(-3 * max_tilt, 3 * max_tilt, n)
    offsets = np.linspace(-3 * max_offset, 3 * max_offset, n)
    tilt_grid, offset_grid = np.meshgrid(tilts, offsets)
    starts = np.zeros((n * n, 4))
    starts[:, X], starts[:, THETA] = offset_grid.ravel(), tilt_grid.ravel()
    map_cut, map_envelope = (p.reshape(n, n) for p in pointing(starts))
    case_cut, case_envelope = pointing(np.array([_start(*s) for s in FIGURE5_STARTS]))

    fig = Figure(figsize=(7, 5.5), layout="constrained")
    ax = fig.add_subplot()
    nrad = POINTING_TOLERANCE_RAD * 1e9
    ratio = np.maximum(map_envelope / POINTING_TOLERANCE_RAD, 1e-2)
    mesh = ax.pcolormesh(tilts * 1e3, offsets * 1e3, np.log10(ratio), cmap="RdBu_r", vmin=-2, vmax=2,
                         shading="nearest")
    fig.colorbar(mesh, ax=ax, label=f"log10(envelope pointing / {nrad:g} nrad)")
    ax.contour(tilts * 1e3, offsets * 1e3, map_envelope, [POINTING_TOLERANCE_RAD], colors="k")
    ax.contour(tilts * 1e3, offsets * 1e3, map_cut, [POINTING_TOLERANCE_RAD], colors="k", linestyles="--")
    ax.plot([s[1] * 1e3 for s in FIGURE5_STARTS], [s[0] * 1e3 for s in FIGURE5_STARTS], "k*", ms=10,
            label="seed Fig 5 starts")
    ax.plot(0.0, 0.0, "ws", mec="k",
            label=f"seed's requirement ({SEED_CLAIMS['required_tilt_rad'] * 1e9:g} nrad, "
                  f"{SEED_CLAIMS['required_offset_m'] * 1e6:g} µm)")
    ax.plot([], [], "k-", label=f"envelope = {nrad:g} nrad")
    ax.plot([], [], "k--", label=f"at t_cut = {nrad:g} nrad")
    ax.set(xlabel="initial tilt θ0 [mrad]", ylabel="initial offset X0 [mm]",
           title="Passive seed sail: flight direction |Vx|/Vz at cut-off")
    ax.legend(fontsize=8, loc="upper left")
    result = {
        "criterion": "|Vx|/Vz at beam cut-off <= tolerance; 'max_passive_*' use the phase-free envelope "
                     "with the other perturbation zero, '*_at_cutoff' the value at exactly t_cut",
        "tolerance_rad": POINTING_TOLERANCE_RAD, "cutoff_s": t_cut, "vz_at_cutoff_m_s": speed,
        "max_passive_tilt_rad": float(max_tilt), "max_passive_offset_m": float(max_offset),
        "max_passive_tilt_at_cutoff_rad": float(max_tilt_cut),
        "max_passive_offset_at_cutoff_m": float(max_offset_cut),
        "map_points_per_axis": n,
        "map_tilt_range_rad": [float(tilts[0]), float(tilts[-1])],
        "map_offset_range_m": [float(offsets[0]), float(offsets[-1])],
        "map_success_fraction_envelope": float(np.mean(map_envelope <= POINTING_TOLERANCE_RAD)),
        "map_success_fraction_at_cutoff": float(np.mean(map_cut <= POINTING_TOLERANCE_RAD)),
        "figure5_pointing_at_cutoff_rad": case_cut.tolist(),
        "figure5_pointing_envelope_rad": case_envelope.tolist(),
    }
    return result, fig


def mission() -> dict:
    """Seed eqs 20 and 24, its aluminium case, the power budget, distance and light delay at cut-off."""
    acceleration, t_cut = SEED.axial_acceleration_m_s2, SEED.beam_cutoff_s
    aluminium = {k: v for k, v in ALUMINIUM.items() if k != "density_kg_m3"}
    # a ∝ 1/ρd (eq 4): the areal density that gives the seed's 1.32 m/s².
    areal_density = thermal_acceleration_limit(**aluminium, areal_density_kg_m2=1.0) / SEED_CLAIMS[
        "aluminium_acceleration_m_s2"]
    full_push = push_force_from_laser(LASER_POWER_W)
    period = _period(PlanarModel(SEED))
    one_way = one_way_light_delay_s(acceleration, t_cut)
    return {
        "eq20_tolerance_rad": pointing_tolerance_rad(SEED_CLAIMS["eq20_miss_distance_m"]),
        "eq20_tolerance_mean_earth_moon_rad": pointing_tolerance_rad(),
        "eq24_required_figure_of_merit": required_figure_of_merit(**EQ24_INPUTS),
        "aluminium": {
            **ALUMINIUM,
            "areal_density_for_1.32_m_s2_kg_m2": areal_density,
            "thickness_for_1.32_m_s2_m": areal_density / ALUMINIUM["density_kg_m3"],
            "acceleration_at_seed_areal_density_m_s2": thermal_acceleration_limit(
                **aluminium, areal_density_kg_m2=EQ24_INPUTS["areal_density_kg_m2"]),
            "figure_of_merit": aluminium["emissivity"] * aluminium["reflectance"] / aluminium["absorptance"],
            "required_figure_of_merit_at_600K": required_figure_of_merit(
                **{**EQ24_INPUTS, "temperature_k": aluminium["temperature_k"]}),
        },
        "power": {
            "laser_power_w": LASER_POWER_W, "push_at_full_power_n": full_push,
            "seed_push_n": SEED.push_force_n,
            "fraction_of_full_push": SEED.push_force_n / full_push,
            "power_for_seed_push_w": SEED.push_force_n / push_force_from_laser(1.0),
        },
        "acceleration_m_s2": acceleration,
        "beta_at_cutoff_newtonian": PlanarModel(SEED).equilibrium_speed(t_cut) / SPEED_OF_LIGHT,
        "distance_at_cutoff_m": distance_flown_m(acceleration, t_cut),
        "one_way_light_delay_at_cutoff_s": one_way,
        "round_trip_light_delay_at_cutoff_s": 2 * one_way,
        "oscillation_periods_per_round_trip_at_cutoff": 2 * one_way / period,
        "round_trip_exceeds_period_after_s": scipy.optimize.brentq(
            lambda t: 2 * one_way_light_delay_s(acceleration, t) - period, 0.0, t_cut),
    }


def differences(report: dict) -> list[dict]:
    """Each disagreement with the seed: what it says, what we find, why, and how much."""
    rel, fig5, stab, tol, mis = (report[k] for k in SECTIONS)
    alu, power, case = mis["aluminium"], mis["power"], fig5["cases"][0]
    return [
        {"topic": "time to 0.2 c (1 g, 50 GW)",
         "seed": f"eq 7: {rel['t_0.2c_seed_eq7_s']:.1f} s",
         "here": f"{rel['t_0.2c_doppler_s']:.1f} s (without Doppler {rel['t_0.2c_no_doppler_s']:.1f} s)",
         "cause": "eq 6 has γ⁴ where p = γmβc gives γ³, and omits the Doppler loss of a receding "
                  "mirror",
         "size": f"{100 * (rel['doppler_over_seed_eq7'] - 1):+.0f} %"},
        {"topic": "pointing requirement",
         "seed": f"tilt ≲ {SEED_CLAIMS['required_tilt_rad']:.0e} rad, "
                 f"offset ≲ {SEED_CLAIMS['required_offset_m']:.0e} m",
         "here": f"passive sail tolerates {tol['max_passive_tilt_rad']:.2e} rad (offset 0) or "
                 f"{tol['max_passive_offset_m']:.2e} m (tilt 0)",
         "cause": "the flight direction after cut-off is |Vx|/Vz, not the sail's tilt θ",
         "size": f"×{tol['max_passive_tilt_rad'] / SEED_CLAIMS['required_tilt_rad']:.1e} in tilt, "
                 f"×{tol['max_passive_offset_m'] / SEED_CLAIMS['required_offset_m']:.0f} in offset"},
        {"topic": "spherical sail 'stable'",
         "seed": "R = Lc = 10 m is stable",
         "here": f"{stab['seed']['kind']}: θ never changes, X oscillates undamped; R = 1.01 Lc grows at "
                 f"{stab['growth_rate_R_1pc_above_Lc_s-1']:.2f} /s",
         "cause": "at R = Lc the torque vanishes identically; R > Lc is unstable, R < Lc undamped",
         "size": "the design point sits on the stability boundary"},
        {"topic": "Fig 5 initial tilt units",
         "seed": "text: θ0 = 0.001 degrees",
         "here": f"its {case['x_max_m'] * 100:.0f} cm needs radians; in degrees X would peak at "
                 f"{case['x_max_if_theta0_in_degrees_m']:.2e} m",
         "cause": "the appendix code passes 0.001 as radians",
         "size": f"×{case['x_max_m'] / case['x_max_if_theta0_in_degrees_m']:.0f} in the peak"},
        {"topic": "Fig 5 'amplitude'",
         "seed": f"{SEED_CLAIMS['figure5_x_max_m'][0]} m",
         "here": f"X oscillates between {case['x_min_m']:.1e} and {case['x_max_m']:.4f} m "
                 "about θ0(2R − Lc): "
                 f"amplitude {case['amplitude_m']:.4f} m",
         "cause": "the seed's '2 cm' is the largest X, not the amplitude",
         "size": f"×{case['x_max_m'] / case['amplitude_m']:.2f}"},
        {"topic": "aluminium areal density",
         "seed": "ρd = 2.71 g/cm³ gives 1.32 m/s²",
         "here": f"1.32 m/s² needs ρd = {alu['areal_density_for_1.32_m_s2_kg_m2']:.2e} kg/m² "
                 f"({alu['thickness_for_1.32_m_s2_m'] * 1e9:.0f} nm of aluminium)",
         "cause": "2.71 g/cm³ is aluminium's bulk density, not an areal density",
         "size": f"2.71 → {alu['areal_density_for_1.32_m_s2_kg_m2']:.2e} kg/m²"},
        {"topic": "push force",
         "seed": f"F = {power['seed_push_n']:g} N from a 50 GW laser",
         "here": f"2P/c = {power['push_at_full_power_n']:.1f} N; {power['seed_push_n']:g} N needs "
                 f"{power['power_for_seed_push_w'] / 1e9:.1f} GW",
         "cause": "its Fig 4 and eq 7 use the full 50 GW, its dynamics 100 N for 600 s: "
                  "two different flights",
         "size": f"{100 * power['fraction_of_full_push']:.0f} % of the available push"},
        {"topic": "distance at cut-off",
         "seed": f"~{SEED_CLAIMS['distance_at_cutoff_m'] / 1e3:.0e} km",
         "here": f"{mis['distance_at_cutoff_m'] / 1e3:.2e} km",
         "cause": "an order-of-magnitude statement",
         "size": f"×{mis['distance_at_cutoff_m'] / SEED_CLAIMS['distance_at_cutoff_m']:.1f}"},
    ]


QUICK_NOTE = ("> **A coarse run (`--quick`)**: fewer grid points and integration steps than the full "
              "report; its numbers check the code, not the paper: cite the report without `--quick`.")


def render_markdown(report: dict) -> str:
    """The human-readable report; every number is read from ``report``."""
    rel, fig5, stab, tol, mis = (report[k] for k in SECTIONS)
    alu, power = mis["aluminium"], mis["power"]
    lines = [
        "# The seed paper, reproduced and corrected",
        "",
        "Seed: Team 258, *Problem A: sending a light sail propelled nanocraft to Alpha Centauri* (MCM).",
        f"Command: `{report['command']}`  ",
        "Versions: " + ", ".join(f"{k} {v}" for k, v in report["versions"].items()),
        "",
        *([QUICK_NOTE, ""] if report["quick"] else []),
        "## Figure 4: relativity (`figure4_relativity.png`)",
        "",
        "Time to β = 0.2 at 50 GW, perfect mirror (correct law: d(γβ)/dt = (2P/mc²)(1−β)/(1+β), "
        "Kulkarni, Lubin & Zhang 2018):",
        "",
        "| mass | seed eq 7 | γ³, no Doppler | correct, with Doppler |",
        "|---|---:|---:|---:|",
        *(f"| {row['mass_kg'] * 1e3:g} g | {row['t_0.2c_seed_eq7_s']:.1f} s "
          f"| {row['t_0.2c_no_doppler_s']:.1f} s | {row['t_0.2c_doppler_s']:.1f} s |"
          for row in rel["by_mass"]),
        "",
        "## Figure 5: the perturbed seed sail (`figure5_perturbations.png`)",
        "",
        f"| X0 | θ0 | X range | amplitude about X_eq | θ after {fig5['zoom_s']:g} s |",
        "|---|---|---|---|---|",
        *(f"| {c['x0_m']:g} m | {c['theta0_rad']:g} rad | {c['x_min_m']:.2e} … {c['x_max_m']:.2e} m "
          f"| {c['amplitude_m']:.2e} m | {c['theta_at_zoom_end_rad']:g} rad |" for c in fig5["cases"]),
        "",
        f"Period {fig5['period_s']:.4f} s. The flat sail diverges at {fig5['flat_growth_rate_s-1']:.1f} /s; "
        f"its |Vx| passes c after {fig5['flat_vx_exceeds_c_after_s']:.3f} s (the seed: 'exceeds the "
        "relativistic limit').",
        "",
        "## Stability map (`stability_map.png`)",
        "",
        f"Seed point (R = Lc = 10 m): {stab['seed']['kind']}, frequencies "
        f"{', '.join(f'{f:.2f}' for f in stab['seed']['frequencies_rad_s'])} rad/s and a double zero. "
        f"R = 15 m: growth {stab['growth_rate_R15m_s-1']:.1f} /s; R = 1.01 Lc: "
        f"{stab['growth_rate_R_1pc_above_Lc_s-1']:.2f} /s; deep dish (R = 4 m): "
        f"{', '.join(f'{f:.1f}' for f in stab['deep_dish_frequencies_rad_s'])} rad/s; flat: "
        f"{stab['flat_growth_rate_s-1']:.1f} /s. Over the scan and the map, unstable for every R > Lc: "
        f"{stab['unstable_for_every_R_above_Lc']}. For R < Lc two undamped oscillations (largest growth "
        f"rate found there: {stab['max_growth_rate_R_below_Lc_s-1']:.1e} /s); their frequencies cross at "
        f"R ≈ {stab['frequency_crossing_R_over_Lc']:.3f} Lc (L = 2 Lc), where a strut shorter than 2 Lc "
        "turns them into flutter. No geometry damps.",
        "",
        "## Pointing verdict (`pointing_tolerance.png`)",
        "",
        f"Criterion: {tol['criterion']}; tolerance {tol['tolerance_rad']:g} rad (seed eq 20), "
        f"t_cut = {tol['cutoff_s']:g} s, Vz = {tol['vz_at_cutoff_m_s']:.3g} m/s.",
        "",
        "| | phase-free envelope | at exactly t_cut |",
        "|---|---:|---:|",
        f"| largest initial tilt (X0 = 0) | {tol['max_passive_tilt_rad']:.3e} rad "
        f"| {tol['max_passive_tilt_at_cutoff_rad']:.3e} rad |",
        f"| largest initial offset (θ0 = 0) | {tol['max_passive_offset_m']:.3e} m "
        f"| {tol['max_passive_offset_at_cutoff_m']:.3e} m |",
        f"| success share of the map | {tol['map_success_fraction_envelope']:.2f} "
        f"| {tol['map_success_fraction_at_cutoff']:.2f} |",
        *(f"| seed Fig 5 start ({s[0]:g} m, {s[1]:g} rad) | {env:.2e} rad | {cut:.2e} rad |"
          for s, env, cut in zip(FIGURE5_STARTS, tol["figure5_pointing_envelope_rad"],
                                 tol["figure5_pointing_at_cutoff_rad"])),
        "",
        "Offset and tilt compensate: success is a band along X0 = θ0 (2R − Lc), where the sail starts "
        "at its equilibrium. In the seed's own model the passive sail tolerates "
        f"{tol['max_passive_tilt_rad'] / SEED_CLAIMS['required_tilt_rad']:.1e} times the tilt the seed "
        "says is needed.",
        "",
        "## Material and mission numbers",
        "",
        f"- Eq 20: {mis['eq20_tolerance_rad']:.3e} rad for {SEED_CLAIMS['eq20_miss_distance_m']:g} m "
        f"({mis['eq20_tolerance_mean_earth_moon_rad']:.3e} rad for the mean Earth–Moon distance).",
        f"- Eq 24: εη/α ≥ {mis['eq24_required_figure_of_merit']:.3g} "
        f"(the seed: {SEED_CLAIMS['eq24_figure_of_merit']:.2g}).",
        f"- Aluminium (ε {alu['emissivity']}, η {alu['reflectance']}, α {alu['absorptance']}, "
        f"{alu['temperature_k']:g} K): εη/α = {alu['figure_of_merit']:.3f} against "
        f"{alu['required_figure_of_merit_at_600K']:.3g} needed at {alu['temperature_k']:g} K; 1.32 m/s² "
        f"means ρd = {alu['areal_density_for_1.32_m_s2_kg_m2']:.3g} kg/m² "
        f"({alu['thickness_for_1.32_m_s2_m'] * 1e9:.1f} nm); at the seed's 5e-5 kg/m² it is "
        f"{alu['acceleration_at_seed_areal_density_m_s2']:.3g} m/s².",
        f"- Power: 2P/c = {power['push_at_full_power_n']:.1f} N at {power['laser_power_w'] / 1e9:g} GW; the "
        f"seed's {power['seed_push_n']:g} N is {100 * power['fraction_of_full_push']:.0f} % of it "
        f"({power['power_for_seed_push_w'] / 1e9:.2f} GW).",
        f"- Acceleration {mis['acceleration_m_s2']:.3g} m/s², β at cut-off "
        f"{mis['beta_at_cutoff_newtonian']:.4f} (Newtonian), distance at cut-off "
        f"{mis['distance_at_cutoff_m']:.3e} m.",
        f"- Light delay at cut-off: {mis['one_way_light_delay_at_cutoff_s']:.1f} s one way, "
        f"{mis['round_trip_light_delay_at_cutoff_s']:.1f} s round trip "
        f"({mis['oscillation_periods_per_round_trip_at_cutoff']:.0f} oscillation periods); the round trip "
        f"exceeds a period after {mis['round_trip_exceeds_period_after_s']:.1f} s.",
        "",
        "## Where we differ from the paper",
        "",
        "| topic | seed | here | cause | size |",
        "|---|---|---|---|---|",
        *("| " + " | ".join(d[k].replace("|", r"\|") for k in DIFFERENCE_FIELDS) + " |"
          for d in report["differences"]),
        "",
    ]
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sail_env.analysis.paper", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="output directory")
    parser.add_argument("--quick", action="store_true", help="fewer grid points (for tests)")
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    report: dict = {"command": f"{parser.prog} {shlex.join(argv)}", "quick": args.quick,
                    "versions": package_versions("lightsail-gym", "numpy", "scipy", "matplotlib")}
    for name, section, figure_name in (("relativity", relativity, "figure4_relativity"),
                                       ("figure5", figure5, "figure5_perturbations"),
                                       ("stability", stability, "stability_map"),
                                       ("tolerance", tolerance, "pointing_tolerance")):
        report[name], fig = section(args.quick)
        fig.savefig(args.out / f"{figure_name}.png", dpi=110)
    report["mission"] = mission()
    report["differences"] = differences(report)
    (args.out / "report.json").write_text(json.dumps(report, indent=2, allow_nan=False) + "\n")
    (args.out / "report.md").write_text(render_markdown(report))
    print(f"wrote {args.out / 'report.md'}" + (" (--quick: a coarse run)" if args.quick else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
