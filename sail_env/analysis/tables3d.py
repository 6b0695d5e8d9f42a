"""Print the 3D model's tables: planar comparison, quadrature convergence, stability (docs/physics.md §9–§10).

    python -m sail_env.analysis.tables3d
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from sail_env.physics import DEEP_DISH, SEED, PlanarModel
from sail_env.physics.constants import SPEED_OF_LIGHT
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.config import BEAM_PROFILES, SHAPES, RigidSailConfig
from sail_env.physics.rigid3d.forces import RadiationModel
from sail_env.physics.rigid3d.linearise import linearise

#: (name, 3D row, 3D column, planar row, planar column) of the x-axis coefficients.
COEFFICIENTS = (("dvx/dx", 2, 0, 1, 0), ("dvx/dθ", 2, 5, 1, 2), ("dω/dx", 7, 0, 3, 0), ("dω/dθ", 7, 5, 3, 2))
ABSORPTIVITIES = (0.0, 0.1)


def planar_comparison() -> list[str]:
    lines = ["| geometry | coefficient | 3D | planar (seed eqs 16–17) | 3D/planar |", "|---|---|---|---|---|"]
    for name, planar_config in (("seed R = Lc = 10 m", SEED), ("deep dish R = 4 m", DEEP_DISH)):
        lin = linearise(RigidSail(RigidSailConfig(curvature_radius_m=planar_config.curvature_radius_m)))
        planar = PlanarModel(planar_config)
        rows = [(label, lin.A[r, c], planar.A[pr, pc]) for label, r, c, pr, pc in COEFFICIENTS]
        rows += [("B dvx/dd", lin.B[2, 0], planar.B[1, 0]), ("B dvx/dψ", lin.B[2, 2], planar.B[1, 1]),
                 ("B dω/dd", lin.B[7, 0], planar.B[3, 0]), ("B dω/dψ", lin.B[7, 2], planar.B[3, 1]),
                 ("push [N]", lin.push_n, planar_config.push_force_n)]
        for label, value_3d, value_planar in rows:
            ratio = f"{value_3d / value_planar:.4f}" if value_planar != 0 else "(planar 0)"
            lines.append(f"| {name} | {label} | {value_3d:.6g} | {value_planar:.6g} | {ratio} |")
        freq_3d = ", ".join(f"{f:.2f}" for f in lin.frequencies if f > 1e-2)
        freq_planar = ", ".join(f"{f:.2f}" for f in planar.stability.frequencies)
        lines.append(f"| {name} | frequencies [rad/s] | {freq_3d} | {freq_planar} | |")
    return lines


def convergence() -> list[str]:
    lines = ["| radial × angular nodes | seed dvx/dx | seed dvx/dθ | deep dish dω/dθ | flat, beam offset 0.6 m: "
             "dτy/dd error vs closed form |", "|---|---|---|---|---|"]
    a, delta, h = 2.0, 0.6, 1e-5
    intensity = RigidSailConfig().beam_power_w / (math.pi * a**2)

    def lens_torque(d: float) -> float:
        area = 2 * a**2 * math.acos(d / (2 * a)) - 0.5 * d * math.sqrt(4 * a**2 - d**2)
        return -2 * intensity / SPEED_OF_LIGHT * area * d / 2

    exact = (lens_torque(delta + h) - lens_torque(delta - h)) / (2 * h)
    for radial, angular in ((2, 12), (4, 24), (8, 48), (16, 96), (16, 192), (32, 384)):
        nodes = {"radial_nodes": radial, "angular_nodes": angular}
        seed = linearise(RigidSail(RigidSailConfig(**nodes)))
        deep = linearise(RigidSail(RigidSailConfig(curvature_radius_m=4.0, **nodes)))
        flat = RadiationModel(RigidSailConfig(shape="flat", **nodes))
        torque = [flat.wrench(np.zeros((1, 3)), np.eye(3)[None], np.array([[d, 0.0]]), np.zeros((1, 2)),
                              flat.config.beam_power_w)[1][0, 1] for d in (delta + h, delta - h)]
        error = ((torque[0] - torque[1]) / (2 * h) - exact) / exact
        lines.append(f"| {radial} × {angular} | {seed.A[2, 0]:.9g} | {seed.A[2, 5]:.9g} | {deep.A[7, 5]:.9g} | "
                     f"{error:.1e} |")
    return lines


def stability() -> list[str]:
    lines = ["| shape | R [m] | beam | α | push [N] | growth [1/s] | frequencies [rad/s] | rank B | cond B |",
             "|---|---|---|---|---|---|---|---|---|"]
    for shape, radius in [(s, r) for s in SHAPES if s != "flat" for r in (10.0, 4.0)] + [("flat", math.inf)]:
        for beam, alpha in itertools.product(BEAM_PROFILES, ABSORPTIVITIES):
            config = RigidSailConfig(shape=shape, curvature_radius_m=10.0 if math.isinf(radius) else radius,
                                     beam_profile=beam, absorptivity=alpha, reflectivity=1.0 - alpha)
            lin = linearise(RigidSail(config))
            frequencies = ", ".join(f"{f:.1f}" for f in lin.frequencies if f > 1e-2) or "–"
            growth = f"{lin.growth_rate:.1f}" if lin.growth_rate > 1e-2 else "0"
            lines.append(f"| {shape} | {radius:g} | {beam} | {alpha:g} | {lin.push_n:.1f} | {growth} | "
                         f"{frequencies} | {lin.input_rank} | {lin.input_condition:.2g} |")
    return lines


def main() -> None:
    for title, section in (("3D linearisation next to the planar coefficients", planar_comparison),
                           ("Quadrature convergence", convergence),
                           ("Stability over shapes × beams × absorptivity (Lc = 10 m)", stability)):
        print(f"### {title}\n")
        print("\n".join(section()))
        print()


if __name__ == "__main__":
    main()
