"""LightSail3D-v0: the rigid 3D sail on both lateral axes, on the same episode core as LightSail-v0."""

from __future__ import annotations

from typing import Any

from sail_env.core.spec import EpisodeSpec, task_spec
from sail_env.envs.params import Rigid3DParams, split
from sail_env.envs.planar import LightSailEnv
from sail_env.envs.vector import LightSailVectorEnv

#: ``(x, y, vx, vy, θx, θy, ωx, ωy)``: LightSail-v0's start box on each axis.
START_HALF_WIDTHS_3D = (5e-3, 5e-3, 0.1, 0.1, 2e-3, 2e-3, 1e-5, 1e-5)


def rigid3d_spec(**keywords: Any) -> EpisodeSpec:
    """The :class:`EpisodeSpec` of the 3D keywords (:class:`~sail_env.envs.params.Rigid3DParams`, the
    table of :class:`LightSail3DEnv`) and the episode keywords of :func:`~sail_env.core.spec.task_spec`;
    a bad value is a ``ValueError`` naming its keyword."""
    own, episode = split(Rigid3DParams, keywords)
    return task_spec(Rigid3DParams(**own).make_plant, START_HALF_WIDTHS_3D, **episode)


class LightSail3DEnv(LightSailEnv):
    """
    ## Description

    LightSail-v0 in three dimensions: the sail moves and tilts on both lateral axes, and
    the radiation force and torque are integrated over the real sail surface in the real
    beam (``sail_env.physics.rigid3d``, docs/physics.md §6–§10) instead of the seed's
    small-aperture formulas. By default it is the seed's dish (``a = 2 m``,
    ``R = Lc = 10 m``) in a flat-top beam of its own size, a perfect mirror, constant push,
    no light delay and no spin: on each axis it is LightSail-v0 with coefficients 2–4 %
    smaller (the 3D lateral frequency is 70.0 rad/s against 70.7), and the two axes do not
    interact. The physics is the 8-state linearisation about the centred sail, stepped
    exactly (zero-order hold); the beam time after the window is one exact propagation
    with the last command held, and the flight is scored by ``|V⊥| / Vz`` at cut-off.
    For a perfect spherical mirror the beam's offset and tilt act through one combination
    per axis (rank 2 of 4, docs/physics.md §9); ``absorptivity > 0`` or ``power_control``
    give the controller independent channels.

    ## Action Space

    ``Box(-1, 1, (4,), float32)`` (``(5,)`` with ``power_control``), scaled inside:

    | Num | Action | Physical range |
    |-----|--------|----------------|
    | 0 | beam offset ``d_x`` at the CoM's range | ± ``max_beam_offset_m`` (2 cm) |
    | 1 | beam offset ``d_y`` | ± ``max_beam_offset_m`` |
    | 2 | beam tilt ``ψ_x`` (slope ``k_x/k_z`` of the beam) | ± ``max_beam_tilt_rad`` (2 mrad) |
    | 3 | beam tilt ``ψ_y`` | ± ``max_beam_tilt_rad`` |
    | 4 | relative laser power (only with ``power_control``) | ± 10 % (or the value given) |

    Actions outside [-1, 1] are clipped; a NaN or infinite action raises ``ValueError``.
    The power scales every radiation term (push and stiffnesses) during the step
    (docs/physics.md §9): a parametric input, not a column of ``B``.

    ## Observation Space

    ``Box(-1e3, 1e3, (9 + m n,), float32)`` (``m`` actions, clipped to that range):

    | Num | Observation | Scale |
    |-----|-------------|-------|
    | 0, 1 | CoM offsets ``x``, ``y`` | / 1 cm |
    | 2, 3 | lateral speeds ``vx``, ``vy`` | / (1 cm · ω₀) |
    | 4, 5 | tilts ``θx``, ``θy`` (rotation-vector components; the axis leans to ``(θy, −θx)``) | / 1 mrad |
    | 6, 7 | tilt rates ``ωx``, ``ωy`` | / (1 mrad · ω₀) |
    | 8 | progress through the control window | -1 at start, +1 at the end |
    | 9.. | the last ``n`` commands sent, newest first (normalised) | as actions |

    ω₀ is the model's fastest rate (70.0 rad/s at the seed point); ``n`` is 0 without light
    delay and the largest round trip in steps with it, as in LightSail-v0.

    ## Rewards

    LightSail-v0's: with ``ρ(p) = clip(log10(p / 10 nrad), -2, 3)``, each step
    ``-ρ(envelope) / N`` (the envelope is the largest ``√(vx² + vy²) / Vz`` with the
    command held), at the last step ``-ρ(pointing at cut-off)`` and ``+1`` on success,
    ``-10`` on divergence.

    ## Starting State

    At launch, uniform in ``x, y ∈ ±5 mm``, ``vx, vy ∈ ±0.1 m/s``, ``θx, θy ∈ ±2 mrad``,
    ``ωx, ωy ∈ ±10 µrad/s`` (``start_half_widths``, in state order).
    ``reset(options={"initial_state": {...}})`` with keys ``x, y, vx, vy, theta_x, theta_y,
    omega_x, omega_y`` in SI sets it instead (missing keys are zero); the key ``spin`` may
    be given too but must equal the task's ``spin_rad_s`` (the spin is part of the linear model).
    Starts are limited radially, as divergence is: ``√(x² + y²) ≤ a``, ``√(θx² + θy²)`` ≤ the tilt
    limit, and the speeds and rates so that no start leaves them within one step (a box of
    ``start_half_widths`` at its corner). ``options`` takes no other key.

    ## Episode End

    1. Termination: the end of the control window; the flight is scored at cut-off:
       ``info["terminal_pointing_rad"]`` (``√(vx² + vy²) / Vz``), ``info["terminal_envelope_rad"]``,
       ``info["is_success"]`` (pointing ≤ 10 nrad); with ``expected_paths``, ``info["expected_success"]``.
    2. Termination: divergence: the CoM leaves the aperture (``√(x² + y²) > a``) or the
       tilt exceeds ``min(a/Lc, 0.05 rad)``, during the window or the coast.

    ## Arguments

    | Parameter | Default | Description | Valid range (why) |
    |-----------|---------|-------------|-------------------|
    | ``sail_shape`` | ``"dish"`` | ``dish``, ``balloon``, ``flat``, ``cone`` | one of these strings |
    | ``beam_profile`` | ``"flat-top"`` | ``flat-top``, ``gaussian``, ``multi-gaussian``, ``annulus`` | one of these strings |
    | ``beam_radius_m`` | None | flat-top / annulus radius, Gaussian waist or ring radius (None: the aperture) | from the wavelength 1.06 µm (annulus: its inner edge; a Gaussian waist: 1.6 radial node spacings of the quadrature, ``a/10``) to where the sail catches 1 % of the power (flat-top ``10 a``, Gaussian ``14.1 a``, annulus ``1.97 a``, ring of lobes ``1.56 a``) |
    | ``curvature_radius_m`` | 10 | ``R`` of the dish, balloon and cone | ``(a, 10⁴ a]``: flatter is the flat sail within the quadrature's accuracy (1e-4) |
    | ``com_distance_m`` | 10 | ``Lc``, vertex to CoM | ``(0, 20]``: between the sail and the payload (20 m behind the vertex) |
    | ``absorptivity`` | 0 | absorbed fraction; the rest is reflected | ``[0, 1]`` |
    | ``spin_rad_s`` | 0 | spin about the sail axis (couples the tilt axes) | ``|Ω| ≤ π / dt``: half a turn per control step (628 rad/s at 5 ms, about the films' breakup) |
    | ``power_control`` | False | ``True`` (±10 %), ``False`` or ``0`` (no power input), or a relative power: a fifth action | ``[0, 0.5]``: the push stays above half |
    | ``relativistic`` | False | relativistic push with the Doppler factor (see below) | a bool |
    | ``ground_jitter_rad`` | 0 | σ of the ground pointing angle per step: the spot moves by ``D(t)·δ`` on both axes | ``D·δ ≤ a`` at the farthest cut-off |
    | ``diffraction_length_m`` | inf | ``L0``: beyond it the spot widens as ``D/L0`` and its intensity falls as ``(L0/D)²`` (see below) | the widened spot still puts 1 % of the beam on the sail at the window's end |
    | ``payload_offset_m`` | 0 | payload's distance from the sail axis (along x): a constant torque ``F e m_craft/m`` | ``[0, a]`` |
    | ``dust_density_m3``, ``dust_grain_mass_kg`` | 0, 0 | dust grains swept up at the sail's speed: random kicks of the tilt rates and lateral speeds (both > 0 to switch on) | grains of a hydrogen atom's mass or more; the swept dust's drag under 1 % of the push; no grain throwing the sail out of the beam in a step |
    | ``velocity_terms`` | False | the radiation forces' v/c terms (Doppler, aberration): a weak passive damping | a bool |
    | ``control_start_s`` | 0 | flight time at which control starts | ``≥ 0``, the window ending before the cut-off |
    | ``max_beam_offset_m``, ``max_beam_tilt_rad`` | 0.02, 0.002 | beam input at action +1 | finite, ``> 0`` |
    | ``start_half_widths`` | see above | 8 half-widths in state order | the box's corner inside the start limits (``√(x² + y²) ≤ a`` and so on) |
    | ``sensor_noise_std`` (8 values), ``beam_jitter_m`` (per axis), ``push_noise``, ``cutoff_jitter_s``, ``light_delay`` | off | see :class:`~sail_env.physics.randomisation.Randomisation`; ``light_delay``: :class:`~sail_env.core.EpisodeSpec` | ``beam_jitter_m ≤ a``; ``cutoff_jitter_s`` up to the cut-off minus the last command's arrival |
    | ``expected_paths`` | 0 | further coasts from the window's end behind the expected success (Episode End) | an int in ``[0, 1024]`` |
    | ``parameter_spread`` | 0 | relative spread of the mass, the inertia tensor and the beam power | ``[0, 0.5)`` |
    | ``model_uncertainty`` | None | unobserved per-episode draws of the dish's curvature, the absorptivity, the power reaching the sail and a constant beam offset (a :class:`~sail_env.physics.rigid3d.uncertainty.ModelUncertainty` or a dict of its fields; ``LightSailUncertain-v2``, see below) | curvature ``[0, 0.5]`` keeping ``R > a``, absorptivity ``[0, 1]`` keeping ``α ≤ 1``, power ``[0, 0.5]``, beam offset ``[0, a]``: a constant offset beyond the rim centres the spot off the sail |

    ``reset(options={"params": {...}})`` changes these keywords for this and the later episodes, as
    :class:`~sail_env.envs.planar.LightSailEnv`'s Reset Options say (a
    :class:`~sail_env.envs.params.Rigid3DParams` sets all of the 3D ones).

    Numbers may be ints, floats or NumPy real scalars; bools (except for the bool keywords and
    ``power_control``), strings and arrays are refused, each with one ``ValueError`` naming the keyword
    and its range (``sail_env.physics.rigid3d.limits`` says why each limit is where it is).

    ``info["state"]`` holds the true state in SI by name and ``info["t"]`` the flight
    time; the control step is ``env.unwrapped.dt``. With ``relativistic=True`` the axial flight
    follows ``d(γβ)/dt ∝ (1−β)/(1+β)`` (docs/physics.md §14): every radiation term, push and
    stiffnesses, falls by that power factor along the flight (to 0.75 at the realistic task's
    600 s cut-off), the window holds the factor at its middle, the coast holds it piecewise
    over pieces of at most 5 s, and ``Vz`` in the pointing comes from the same law. With a finite
    ``diffraction_length_m`` the spot the sail sees beyond ``L0`` is the beam's profile widened by
    ``s = D/L0`` with the intensity ``/s²`` (Kulkarni, Lubin & Zhang 2018): the push falls and every
    stiffness follows the distance, in the window, over the coast, in ``Vz`` and in the ground
    jitter's ``D(t)`` (docs/physics.md §14).

    Dust and payload (docs/physics.md §15). Dust impacts are a compound Poisson process: the sail
    sweeps ``n π a² v`` grains a second (``v`` the impact speed, the sail's speed and the grains'
    20 km/s), each kicking the tilt rates by ``m_g v y / I_t`` (``y`` the random impact point,
    RMS ``a/2``) and the lateral speeds by the grain's own lateral momentum over ``m``. In the
    window each step draws its Poisson count and Gaussian kicks given the count (rate and size at
    the window's middle), which land at the step's end; over the coast the impacts act as white
    noise of the same intensity (rate × mean squared kick, growing as ``v³``), exact in the first two
    moments. The payload offset ``e`` puts the CoM ``e m_craft/m`` off the axis: the push exerts a
    constant torque about y and the equilibrium tilts until the force line passes through the CoM;
    it is modelled fixed in the lab frame (with spin it turns at ``Ω`` in truth, see §15).

    ``model_uncertainty`` (``LightSailUncertain-v2``: curvature ±20 %, absorptivity ±50 %, power at the
    sail ±20 %, a beam offset ±1 cm; docs/physics.md §16) draws per episode what the ground station
    designs on but cannot know in flight, on top of ``parameter_spread``; nothing of it is observed:

    | drawn (uniform) | acts on | reset cost |
    |---|---|---|
    | curvature ``R₀(1 ± c)`` | every radiation term, the push, the inertia | a cubic spline over 9 radii tabled once |
    | absorptivity ``α₀(1 ± u)`` | every radiation term, the input matrix's rank, the push | exact: the force is linear in ``α`` |
    | power ``(1 ± p)`` | the push and every stiffness | a row scaling |
    | beam offset ``± b`` per axis | a constant drive ``B[:, :2] b`` | a column |

    ## Version History

    * ``LightSailUncertain-v2`` (lightsail-gym 0.5.0): in a spot widened beyond ``L0`` each draw has its
      own sail's radiation terms in that spot (a table over curvature, absorptivity and the spot's
      scale), and its beam offset drives through the widened spot's ``B``. ``-v1`` added the draw's
      difference from the nominal sail at the unwidened spot undiminished, a first-order error: 17 % of
      the coast's radiation terms at ``s = 1.24``, 3.8 times them at 1.79; ~19 % of its episodes widen
      before cut-off. v0 and v1 keep playing so (``ModelUncertainty.v1_widening``), their numbers
      unchanged; v2's episodes that never widen are v1's to the bit (docs/physics.md §16).
    * ``LightSailUncertain-v1`` (lightsail-gym 0.4.0): the uncertain factors are drawn over their
      documented ranges (curvature ±20 %, absorptivity ±50 %, power ±20 %, beam offset ±1 cm).
      ``-v0``'s episodes drew every one of them within ``1 ± parameter_spread`` (±10 %, the offset
      ±1 mm) and none without a spread, because the episode core's batched draw bypassed the plant's
      own; v0 keeps playing so (``ModelUncertainty.v0_draws``), its numbers unchanged.
    * 0.3.0, every id (no new version: no result changes): the window's step is compiled
      (observations bit for bit, rewards to 1e-11); the axial flight of the relativistic and
      diffracting tasks (``LightSail3DRealistic-v0``/``-v1``) is read from a table 1e-12 from a tight
      integration instead of an rtol-1e-10 ODE solution that was 2e-10 off, which moves their
      episodes' terminal pointing by at most 1e-8 relative (the same seed now gives the same
      numbers under two OpenBLAS kernels to 4e-8 instead of 1e-6; docs/physics.md §3, §14).
    * ``LightSailUncertain-v0`` (lightsail-gym 0.3.0): initial release; ``LightSail3DRealistic-v1``'s
      keywords plus ``model_uncertainty`` (``sail_env.tasks``, docs/physics.md §16).
    * ``LightSail3DRealistic-v1`` (lightsail-gym 0.2.0): the realistic task in a Gaussian beam of
      waist ``0.8 a`` instead of a flat-top spot of exactly the aperture's size, whose edge on the
      rim made the force kinked at zero offset (the linear window 31 % of the amplitude off the
      rigid body, the coast's phase lost, the sail's lateral stiffness gone beyond ``L0``); its
      ground jitter recomputed for that beam by the same rule (docs/physics.md §14, ``sail_env.tasks``).
    * v0 (lightsail-gym 0.2.0): the end state of a noisy coast (and of the pre-control flight) is
      drawn with the symmetric square root of its correlation matrix, no longer with eigenvectors
      whose signs depended on the LAPACK driver and the CPU's BLAS kernel (docs/physics.md §3):
      ``LightSail3DRealistic-v0`` and any env with noise over the coast draw other end states for
      the same seed, from the same distribution; noise-free episodes are unchanged.
    * v0 (lightsail-gym 0.1.0): initial release.
    """

    make_spec = staticmethod(rigid3d_spec)

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        self._start(kwargs, render_mode)


def rigid3d_vector_env(num_envs: int = 1, render_mode: str | None = None, **kwargs: Any) -> LightSailVectorEnv:
    """The vector entry point of the 3D ids: :class:`LightSailVectorEnv` of the same keywords."""
    return LightSailVectorEnv.of_keywords(rigid3d_spec, kwargs, num_envs, render_mode)

