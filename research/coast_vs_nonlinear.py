"""The 3D coast against the nonlinear rigid body over a whole flight (docs/physics.md §14).

    python -m research.coast_vs_nonlinear [--start 11] [--every 10] [--rtol 1e-9] [--mesh 6 48]
    python -m research.coast_vs_nonlinear --beam-profile gaussian --beam-radius 0.8 --rtol 1e-7   # v1's beam

From the end of the control window to cut-off, the episode core propagates the linearised
model held piecewise (``RigidPlant.coast``, noise off). Here the same start is integrated with
the nonlinear rigid body (quaternion attitude, Euler's equations, the radiation wrench
integrated over the surface at every evaluation; DOP853) under the same relativistic flight:
the power factor ``f(t)`` of ``plant.flight`` scales the beam. Both use the same surface mesh,
so the difference is the propagation's alone (linearisation and piecewise holding). Every
``--every`` seconds and at cut-off it prints the lateral velocity's difference relative to the
largest lateral speed so far (the amplitude; the value at one instant depends on the phase), the
pointing from both, and the amplitudes (nonlinear: the largest |V⊥| over the last 0.2 s; linear:
the reward's envelope). The whole flight takes hours of one core (the flat-top spot's edge makes
the force kinked at zero offset, and the steps collapse there); ``--rtol 1e-5`` is about twice as
fast and within 5e-3 of 1e-7 in the pointing.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.integrate

from sail_env.physics.config import DEEP_DISH
from sail_env.physics.rigid3d.plant import RigidTaskConfig, RigidPlant
from sail_env.physics.rigid3d import BEAM_PROFILES, RigidSail, RigidSailConfig, state_from_small
from sail_env.physics.rigid3d.body import small_state

#: A start typical of the window's end: offsets and speeds of a sail the controller left on the beam.
START = {"x": 1e-3, "y": -5e-4, "vx": 2e-3, "vy": 1e-3, "theta_x": 1e-5, "theta_y": -2e-5,
         "omega_x": 1e-4, "omega_y": 5e-5}
#: Sizes of the body state's components in this motion (position, velocity, quaternion, body rates):
#: the absolute tolerance is rtol times these. One tiny absolute tolerance for all would make every
#: zero crossing of an oscillating component demand 1e-15 m or m/s: steps of ~1e-8 s, days of flight.
STATE_SCALES = np.array([1e-3] * 3 + [1e-1] * 3 + [1e-5] * 4 + [1e-4] * 3)
#: Spacing [s] of the kept states: 1/60 of the lateral period (|V⊥|'s maxima within 0.2 %).
SAMPLE_S = 1.5e-3


def main(argv: list[str] | None = None) -> dict[str, float]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--start", type=float, default=11.0, help="coast start [s] (the realistic window ends at 11 s)")
    parser.add_argument("--mesh", type=int, nargs=2, default=(6, 48), metavar=("RADIAL", "ANGULAR"),
                        help="surface quadrature nodes (both models)")
    parser.add_argument("--rtol", type=float, default=1e-9)
    parser.add_argument("--every", type=float, default=10.0, help="compare every N seconds of flight (and at cut-off)")
    parser.add_argument("--beam-profile", default="flat-top", choices=BEAM_PROFILES,
                        help="the beam; a Gaussian's force is smooth at zero offset")
    parser.add_argument("--beam-radius", type=float, default=1.0,
                        help="the beam's radius (a Gaussian's waist) over the aperture's radius "
                             "(LightSail3DRealistic-v0: flat-top 1; v1: gaussian 0.8)")
    args = parser.parse_args(argv)

    # LightSail3DRealistic-v0's (or v1's) sail and flight (its noise aside).
    sail = RigidSailConfig(curvature_radius_m=DEEP_DISH.curvature_radius_m, absorptivity=0.1, reflectivity=0.9,
                           beam_profile=args.beam_profile, beam_radius_m=args.beam_radius * DEEP_DISH.aperture_radius_m,
                           radial_nodes=args.mesh[0], angular_nodes=args.mesh[1])
    spin = 1.0
    plant = RigidPlant(RigidTaskConfig(sail, spin_rad_s=spin, relativistic=True, control_start_s=10.0))
    params = plant.params(np.ones((1, plant.n_factors)))
    cutoff = plant.config.beam_cutoff_s
    x0 = np.array([[START[name] for name in plant.state_names]])
    held = np.zeros((1, plant.n_inputs))
    body = RigidSail(sail)

    def rates(t: float, y: np.ndarray) -> np.ndarray:
        return body.rates(y[None], held[:, :4], power_factor=float(plant.flight.power_factor(t)))[0]

    solver = scipy.integrate.DOP853(rates, args.start, state_from_small(**START, spin=spin)[0], cutoff,
                                    rtol=args.rtol, atol=args.rtol * STATE_SCALES)
    checkpoints = [*np.arange(args.start + args.every, cutoff - 1e-9, args.every), cutoff]
    # |V⊥| every SAMPLE_S from the solver's dense output (its own steps are too sparse for the amplitudes).
    times = np.append(np.arange(args.start, cutoff, SAMPLE_S), cutoff)
    speeds = np.empty_like(times)
    kept = 0
    print(f"coast from {args.start:g} s to {cutoff:g} s, {args.beam_profile} beam of radius {args.beam_radius:g} a, mesh {args.mesh[0]}×{args.mesh[1]}, relativistic, "
          f"spin {spin} rad/s, DOP853 rtol {args.rtol:g}; |ΔV⊥| against the largest |V⊥| so far (the amplitude: "
          f"V⊥ at one time depends on the oscillation's phase); amplitudes over the last 0.2 s (nonlinear) and "
          f"the reward's envelope ahead (linear)", flush=True)
    started = time.perf_counter()
    result: dict[str, float] = {}
    while checkpoints:
        if solver.step() is not None:
            raise RuntimeError(f"the nonlinear integration failed at {solver.t} s: {solver.status}")
        dense = solver.dense_output()
        upto = int(np.searchsorted(times, solver.t, side="right"))
        speeds[kept:upto] = np.hypot(*small_state(dense(times[kept:upto]).T)[:, 2:4].T)
        kept = upto
        while checkpoints and checkpoints[0] <= solver.t:
            t = checkpoints.pop(0)
            linear, _ = plant.coast(params, x0, held, np.array([t - args.start]), None, np.array([args.start]))
            v_lin, v_non = linear[0, 2:4], small_state(dense(t)[None])[0, 2:4]
            amplitude = float(np.max(speeds[:kept][times[:kept] <= t]))
            end_amplitude = float(np.max(speeds[:kept][(times[:kept] <= t) & (times[:kept] >= t - 0.2)]))
            ratio = float(plant.peak_speed(params, linear, held)[0]) / end_amplitude
            vz = plant.speed(params, np.array([t]))[0]
            result = {"time_s": t, "relative_velocity_error": float(np.hypot(*(v_lin - v_non)) / amplitude),
                      "amplitude_ratio": ratio, "nonlinear_s": time.perf_counter() - started}
            print(f"  {t:7.2f} s: |ΔV⊥|/amplitude {result['relative_velocity_error']:.2e} "
                  f"(amplitude {amplitude:.4e} m/s), pointing {np.hypot(*v_non) / vz:.4e} rad nonlinear, "
                  f"{np.hypot(*v_lin) / vz:.4e} rad linear; amplitude ratio linear/nonlinear {ratio:.4f} "
                  f"({solver.nfev} evaluations, {result['nonlinear_s']:.0f} s)", flush=True)
    return result


if __name__ == "__main__":
    main()
