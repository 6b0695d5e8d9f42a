"""How long a coast piece can be: the midpoint rule (today's coast) against a fourth-order Magnus step,
both against DOP853 of the linear time-varying model over the last 100 s of the realistic coast.

    python -m research.coast_pieces [--out research/results/coast_pieces.json]

The 3D realistic coast holds the model at each ≤ 5 s piece's middle (``COAST_SEGMENT_S``): the
midpoint rule, second order in the piece's length, 0.8 % of ``V⊥`` at cut-off over the 589 s coast
(docs/physics.md §14). Each piece costs one exponential of the 45×45 moment generator with noise,
so the coast's cost is proportional to the number of pieces. A fourth-order Magnus step (Blanes,
Casas, Oteo & Ros 2009, Phys. Rep. 470, 151: two Gauss points, ``Ω = h/2 (G₁ + G₂) + √3 h²/12
[G₂, G₁]``) costs one more generator and one commutator per piece; if it holds the error with pieces
several times longer, the coast is that many times cheaper. This script measures it on the mean
(the noise-free propagation of the augmented state ``(s, 1)``, the same model the moment generator
carries) over the last 100 s before cut-off, where the power factor falls fastest, for the realistic
sail (deep dish, spin, relativistic push; no diffraction: the nominal draw reaches ``L0`` only after
cut-off) with a typical state and command. Prints and writes ``|ΔV⊥| / |V⊥|`` at cut-off for each
method and length, and the largest real part of the Magnus step's ``Ω/h`` (the sail has none: its
modes only oscillate).

Result (docs/physics.md §14; research/results/coast_pieces.json): the Magnus series converges only
while ``∫‖G‖ dt < π`` (Blanes et al. 2009), and a 1 s piece already turns this sail's fastest mode
(110 rad/s after the window, 96 at cut-off; v1's: 156) by 110 rad. The commutator term
``(√3/12) h² [G₊, G₋] = (√3/12) h² (f₋ − f₊) [K, R]`` is then no small correction: the Magnus step
is off by 2.9 % at 1 s pieces (the midpoint rule: 0.16 %), by 80–125 % at 2–5 s, and at 20 s its
``Ω/h`` has a real eigenvalue of 90 /s (the sail grows by e^1800 a piece; it has no growing mode). A higher-order step in the lab frame is no route to fewer pieces; a step
taken relative to the middle's exact exponential (an interaction picture, where what remains of the
generator is small) or averaged over the fast phase is.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import scipy.integrate
import scipy.linalg

from sail_env.physics.config import DEEP_DISH
from sail_env.physics.rigid3d.plant import RigidTaskConfig, RigidPlant
from sail_env.physics.rigid3d.config import RigidSailConfig

RESULTS = Path(__file__).parent / "results"
START_S, END_S = 500.0, 600.0
X0 = np.array([1e-3, -2e-3, 0.01, 0.02, 1e-4, -2e-4, 1e-3, 5e-4])
U = np.array([2e-3, -1e-3, 1e-4, 5e-5])


def augmented(plant: RigidPlant, a_rad: np.ndarray, b: np.ndarray, window: float, t: float) -> np.ndarray:
    """``[[A(t), B(t) u], [0, 0]]`` of the coast with the power factor at ``t``."""
    scale = float(plant.flight.power_factor(t)) / window
    out = np.zeros((9, 9))
    out[:8, :8] = plant.kinematics + scale * a_rad
    out[:8, 8] = scale * (b @ U)
    return out


def propagate(plant, a_rad, b, window, piece: float, method: str) -> np.ndarray:
    """The augmented state at ``END_S`` by pieces of ``piece`` seconds."""
    count = math.ceil((END_S - START_S) / piece - 1e-9)
    h = (END_S - START_S) / count
    z = np.append(X0, 1.0)
    offset = h / (2 * math.sqrt(3))
    for i in range(count):
        middle = START_S + (i + 0.5) * h
        if method == "midpoint":
            omega = h * augmented(plant, a_rad, b, window, middle)
        else:
            first = augmented(plant, a_rad, b, window, middle - offset)
            second = augmented(plant, a_rad, b, window, middle + offset)
            omega = 0.5 * h * (first + second) + math.sqrt(3) / 12 * h * h * (second @ first - first @ second)
        z = scipy.linalg.expm(omega) @ z
    return z[:8]


def coast_model() -> tuple[RigidPlant, np.ndarray, np.ndarray, float]:
    """The realistic sail of this measurement (nominal draw), its radiation's part of ``A`` and its
    ``B`` (held at the window's power factor), and that power factor."""
    sail = RigidSailConfig(curvature_radius_m=DEEP_DISH.curvature_radius_m, absorptivity=0.1, reflectivity=0.9)
    plant = RigidPlant(RigidTaskConfig(sail, spin_rad_s=1.0, relativistic=True, control_start_s=10.0))
    p = plant.params(np.ones((1, 3)))
    return plant, p.a[0] - plant.kinematics, p.b[0], float(plant.flight.power_factor(plant.config.window_middle_s))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_pieces.json")
    args = parser.parse_args()
    plant, a_rad, b, window = coast_model()

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        g = augmented(plant, a_rad, b, window, t)
        return g[:8, :8] @ x + g[:8, 8]

    started = time.perf_counter()
    reference = scipy.integrate.solve_ivp(rhs, (START_S, END_S), X0, method="DOP853", rtol=1e-11,
                                          atol=1e-15).y[:, -1]
    print(f"reference (DOP853, rtol 1e-11, {START_S:.0f}-{END_S:.0f} s): {time.perf_counter() - started:.0f} s, "
          f"|V⊥| = "
          f"{np.hypot(*reference[2:4]):.4e} m/s")
    rows = []
    for method, pieces in (("midpoint", (1.0, 2.0, 5.0, 10.0, 20.0)), ("magnus4", (1.0, 2.0, 5.0, 20.0))):
        for piece in pieces:
            with np.errstate(all="ignore"):
                x = propagate(plant, a_rad, b, window, piece, method)
            error = float(np.hypot(*(x[2:4] - reference[2:4])) / np.hypot(*reference[2:4]))
            row = {"method": method, "piece_s": piece, "pieces": math.ceil((END_S - START_S) / piece - 1e-9),
                   "velocity_error": error if math.isfinite(error) else None}
            if method == "magnus4":
                middle, offset = 0.5 * (START_S + END_S), piece / (2 * math.sqrt(3))
                first = augmented(plant, a_rad, b, window, middle - offset)
                second = augmented(plant, a_rad, b, window, middle + offset)
                rate = 0.5 * (first + second) + math.sqrt(3) / 12 * piece * (second @ first - first @ second)
                row["largest_growth_per_s"] = float(np.linalg.eigvals(rate).real.max())
            rows.append(row)
            print(f"{method:9s} pieces of {piece:5.1f} s ({row['pieces']:4d}): |ΔV⊥|/|V⊥| = {error:.2e}"
                  + (f", Ω/h's largest real part {row['largest_growth_per_s']:.3g} /s" if method == "magnus4" else ""),
                  flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"start_s": START_S, "end_s": END_S, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
