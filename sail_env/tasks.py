"""The task suite: ids and the keyword arguments that define them (:data:`TASKS` holds every id,
:data:`PLANAR_TASKS` the planar ones, :data:`RIGID3D_TASKS` the 3D ones; ``ENTRY_POINTS`` says
which env class and vector entry point each family uses).

``LightSailRealistic-v0`` is what a ground station would face on the deep-dish sail
(the ±10 % parameter draw keeps ``R < Lc``, so it is never passively unstable):

| effect | size | physical meaning |
|--------|------|------------------|
| control start | 10 s into the flight | sail 5,000 km out, one-way light delay 17-20 ms |
| light delay | ``D(t)/c`` each way | 3-4 control steps each way; the round trip is 0.35-0.45 of the slow mode's period and 0.6-0.8 of the fast one's |
| sensor noise | 0.2 mm, 14 mm/s, 20 µrad, 1.4 mrad/s | ~2 % of the X and θ observation scales |
| beam jitter | 15 µm per 5 ms step (PSD 1.1e-12 m² s) | 3 prad of ground pointing jitter at 5,000 km; over the 590 s coast it alone leaves σ(V⊥) ≈ 0.21 m/s (3.4 nrad) |
| push noise | 1 % per 5 ms step | laser power fluctuation |
| cut-off time | 600 s ± 5 s | the phase of the oscillation at cut-off is unknown |
| parameters | ±10 % | masses, strut and CoM lengths, radius of curvature |

``LightSail3DRealistic-v0`` puts the same disturbances (ground pointing jitter as an angle instead of
the landing offset's, dust, a payload offset, the relativistic push and diffraction beyond ``L0``) on
the 3D deep dish in a flat-top spot of exactly the aperture's size, the seed's idealisation: its
edge on the rim makes the force kinked at zero offset. ``LightSail3DRealistic-v1`` is the same task
in a Gaussian beam of waist ``0.8 a`` (:data:`GAUSSIAN_WAIST_OVER_APERTURE`), with the ground
jitter's benchmark level recomputed for that beam (docs/physics.md §14): the realistic 3D task.
``LightSailUncertain-v1`` is v1 whose sail the station does not know: per episode, unobserved, the dish's
curvature under load (±20 %), the absorptivity (±50 %), the power that reaches the sail (±20 %) and a
constant beam offset at the sail (±1 cm per axis) are drawn (docs/physics.md §16, with each size's source
and which are guesses). ``LightSailUncertain-v0`` drew each of those within ±10 % instead (the beam offset
±1 mm), by mistake; it stays registered as it played.
"""

from __future__ import annotations

import dataclasses

from sail_env.physics.planar.config import DEEP_DISH, SEED
from sail_env.physics.rigid3d.uncertainty import TASK_UNCERTAINTY
from sail_env.physics.mission import diffraction_length_m

# The ground station's pointing jitter of the realistic 3D tasks, per control step: half of what
# their sail tolerates (``sail_env.analysis.jitter``, docs/physics.md §12; a test recomputes both).
#: That level, per 5 ms step, for the deep dish (R = 4 m) in a flat-top beam of its aperture on
#: the relativistic flight with the L0 of a 10 km array (it tolerates 3.1e-15).
GROUND_JITTER_BENCHMARK_RAD = 1.5e-15
#: The same rule for LightSail3DRealistic-v1's beam, a Gaussian of waist 0.8 a whose spot widens
#: beyond the same L0 (that of a spot of the aperture's radius): the deep dish tolerates 1.7e-15.
GROUND_JITTER_GAUSSIAN_BENCHMARK_RAD = 8.5e-16

#: Interplanetary dust at 1 AU (Grün et al. 1985): grains of 10 µm and up (≥ 1e-12 kg), 6e-10 per m³;
#: the realistic 3D task sweeps ~100 of them in a flight (docs/physics.md §15).
DUST_DENSITY_M3 = 6.0e-10
DUST_GRAIN_MASS_KG = 1.0e-12
#: Payload placement tolerance after deployment: 5 mm off the axis of the 4 m sail on 10 m struts.
PAYLOAD_OFFSET_M = 5.0e-3

#: The deep dish restores its tilt stiffly, so tilt barely reaches V⊥; a wider lateral
#: start (±3 cm, ±0.6 m/s) makes the passive sail fail on about half of the episodes.
DEEP_DISH_START_HALF_WIDTHS = (3e-2, 0.6, 2e-3, 1e-5)

REALISTIC_DISTURBANCES = {
    "sensor_noise_std": (2e-4, 1.4e-2, 2e-5, 1.4e-3),
    "beam_jitter_m": 1.5e-5,
    "push_noise": 1e-2,
    "cutoff_jitter_s": 5.0,
    "light_delay": True,
    "parameter_spread": 0.1,
}

PLANAR_TASKS: dict[str, dict] = {
    "LightSail-v0": {"config": SEED},
    "LightSailDeepDish-v0": {"config": DEEP_DISH, "start_half_widths": DEEP_DISH_START_HALF_WIDTHS},
    "LightSailRealistic-v0": {"config": DEEP_DISH.replace(control_start_s=10.0),
                              "start_half_widths": DEEP_DISH_START_HALF_WIDTHS, **REALISTIC_DISTURBANCES},
}

#: The rigid 3D sail (``sail_env.envs.rigid3d``): LightSail3D-v0 is the seed geometry and beam,
#: a perfect mirror, constant push, no delay, no spin.
RIGID3D_TASKS: dict[str, dict] = {
    "LightSail3D-v0": {},
    "LightSail3DRealistic-v0": {"curvature_radius_m": DEEP_DISH.curvature_radius_m, "absorptivity": 0.1,
                                "spin_rad_s": 1.0, "control_start_s": 10.0, "relativistic": True,
                                # The ground station's pointing jitter replaces the landing offset's (§12).
                                "ground_jitter_rad": GROUND_JITTER_BENCHMARK_RAD,
                                # The spot of a 10 km array widens beyond the L0 of its beam, the aperture's size (§14).
                                "diffraction_length_m": diffraction_length_m(SEED.aperture_radius_m),
                                "payload_offset_m": PAYLOAD_OFFSET_M, "dust_density_m3": DUST_DENSITY_M3,
                                "dust_grain_mass_kg": DUST_GRAIN_MASS_KG,
                                "start_half_widths": tuple(w for w in DEEP_DISH_START_HALF_WIDTHS for _ in range(2)),
                                **REALISTIC_DISTURBANCES, "beam_jitter_m": 0.0,
                                "sensor_noise_std": tuple(s for s in REALISTIC_DISTURBANCES["sensor_noise_std"]
                                                          for _ in range(2))},
}

#: LightSail3DRealistic-v1's beam: a Gaussian of this waist (1/e² intensity radius) over the aperture
#: radius ``a`` (docs/physics.md §14): 95.6 % of the beam's power lands on the sail and pushes it as
#: v0's flat-top did (within 1.4 %), between the Gaussian that best fits a filled array's Airy core
#: (0.69 a) and a waist of ``a``; FlexSailSim's test beams use ``w = 0.4 D``.
GAUSSIAN_WAIST_OVER_APERTURE = 0.8
RIGID3D_TASKS["LightSail3DRealistic-v1"] = {
    **RIGID3D_TASKS["LightSail3DRealistic-v0"], "beam_profile": "gaussian",
    "beam_radius_m": GAUSSIAN_WAIST_OVER_APERTURE * SEED.aperture_radius_m,
    "ground_jitter_rad": GROUND_JITTER_GAUSSIAN_BENCHMARK_RAD}

#: LightSailUncertain-v2: LightSail3DRealistic-v1 whose sail the station knows only to within
#: :data:`~sail_env.physics.rigid3d.uncertainty.TASK_UNCERTAINTY` (curvature ±20 %, absorptivity ±50 %,
#: power at the sail ±20 %, a beam offset ±1 cm; per episode, unobserved; docs/physics.md §16).
#: LightSailUncertain-v1 held each draw's difference from the nominal sail at its unwidened spot's value
#: beyond ``L0`` (``v1_widening``); v0 also drew every factor within ±parameter_spread (``v0_draws``).
_V1_UNCERTAINTY = dataclasses.replace(TASK_UNCERTAINTY, v1_widening=True)
RIGID3D_TASKS["LightSailUncertain-v0"] = {**RIGID3D_TASKS["LightSail3DRealistic-v1"],
                                          "model_uncertainty": dataclasses.replace(_V1_UNCERTAINTY, v0_draws=True)}
RIGID3D_TASKS["LightSailUncertain-v1"] = {**RIGID3D_TASKS["LightSail3DRealistic-v1"],
                                          "model_uncertainty": _V1_UNCERTAINTY}
RIGID3D_TASKS["LightSailUncertain-v2"] = {**RIGID3D_TASKS["LightSail3DRealistic-v1"],
                                          "model_uncertainty": TASK_UNCERTAINTY}

TASKS: dict[str, dict] = {**PLANAR_TASKS, **RIGID3D_TASKS}

#: The tasks the JAX backend (``sail_env.jax``) carries, registered as ``jax/<id>`` too (Gymnasium's
#: functional API): the planar ones, the 3D sail, the realistic 3D tasks (a coast whose model changes
#: along the flight, dust impacts, the payload's constant drive) and the uncertain tasks (each draw its own sail).
JAX_TASKS = (*PLANAR_TASKS, "LightSail3D-v0", "LightSail3DRealistic-v0", "LightSail3DRealistic-v1",
             "LightSailUncertain-v0", "LightSailUncertain-v1", "LightSailUncertain-v2")

#: ``(entry_point, vector_entry_point)`` of each family of tasks.
ENTRY_POINTS = {
    "planar": ("sail_env.envs.planar:LightSailEnv", "sail_env.envs.vector:LightSailVectorEnv"),
    "rigid3d": ("sail_env.envs.rigid3d:LightSail3DEnv", "sail_env.envs.rigid3d:rigid3d_vector_env"),
    "jax": ("sail_env.jax.functional:LightSailJaxEnv", "sail_env.jax.functional:LightSailJaxVectorEnv"),
}
