"""How long a coast piece can be: the midpoint rule (today's coast) against a fourth-order Magnus step,
both against DOP853 of the linear time-varying model over the realistic task's whole coast.

    python -m benchmarks.coast_pieces [--out benchmarks/results/coast_pieces.json]

The 3D realistic coast holds the model at each ≤ 5 s piece's middle (``COAST_SEGMENT_S``): the
midpoint rule, second order in the piece's length, 0.8 % of ``V⊥`` at cut-off over the 589 s coast
(docs/physics.md §14). Each piece costs one exponential of the 45×45 moment generator with noise,
so the coast's cost is proportional to the number of pieces. A fourth-order Magnus step (Blanes,
Casas, Oteo & Ros 2009, Phys. Rep. 470, 151: two Gauss points, ``Ω = h/2 (G₁ + G₂) + √3 h²/12
[G₂, G₁]``) costs one more generator and one commutator per piece; if it holds the error with pieces
several times longer, the coast is that many times cheaper. This script measures it on the mean
(the noise-free propagation of the augmented state ``(s, 1)``, the same model the moment generator
carries), from the window's end (11 s) to cut-off (600 s), for the realistic sail (deep dish, spin,
relativistic push; no diffraction: the nominal draw reaches ``L0`` only after cut-off) with a
typical state and command. Prints and writes ``|ΔV⊥| / |V⊥|`` at cut-off for each method and length.
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
from sail_env.physics.plant3d import RigidFlight, RigidPlant
from sail_env.physics.rigid3d.config import RigidSailConfig

RESULTS = Path(__file__).parent / "results"
START_S, END_S = 11.0, 600.0
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=RESULTS / "coast_pieces.json")
    args = parser.parse_args()
    sail = RigidSailConfig(curvature_radius_m=DEEP_DISH.curvature_radius_m, absorptivity=0.1, reflectivity=0.9)
    plant = RigidPlant(RigidFlight(sail, spin_rad_s=1.0, relativistic=True, control_start_s=10.0))
    p = plant.params(np.ones((1, 3)))
    a_rad, b = p.a[0] - plant.kinematics, p.b[0]
    window = float(plant.flight.power_factor(plant.config.window_middle_s))

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        g = augmented(plant, a_rad, b, window, t)
        return g[:8, :8] @ x + g[:8, 8]

    started = time.perf_counter()
    reference = scipy.integrate.solve_ivp(rhs, (START_S, END_S), X0, method="DOP853", rtol=1e-11,
                                          atol=1e-15).y[:, -1]
    print(f"reference (DOP853, rtol 1e-11): {time.perf_counter() - started:.0f} s, |V⊥| = "
          f"{np.hypot(*reference[2:4]):.4e} m/s")
    rows = []
    for method, pieces in (("midpoint", (2.0, 5.0, 10.0, 20.0)), ("magnus4", (5.0, 10.0, 20.0, 40.0, 80.0))):
        for piece in pieces:
            x = propagate(plant, a_rad, b, window, piece, method)
            error = float(np.hypot(*(x[2:4] - reference[2:4])) / np.hypot(*reference[2:4]))
            rows.append({"method": method, "piece_s": piece, "pieces": math.ceil((END_S - START_S) / piece - 1e-9),
                         "velocity_error": error})
            print(f"{method:9s} pieces of {piece:5.1f} s ({rows[-1]['pieces']:4d}): |ΔV⊥|/|V⊥| = {error:.2e}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"start_s": START_S, "end_s": END_S, "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
