"""What a ground station cannot know about its sail: the per-episode model uncertainty of
``LightSailUncertain-v1`` (docs/physics.md §16).

The station designs on the sail it built and the beam it sends. In flight four things differ from
that, per episode, and none is observed (sizes: the task's, :data:`TASK_UNCERTAINTY`):

| quantity | draw (uniform) | why it is unknown | source of the size |
|---|---|---|---|
| dish curvature ``R`` under load | ``R₀ (1 ± 0.2)`` | a membrane under light pressure billows to the shape its tension and the pressure set (Laplace: ``R = 2T/p``); the tension of a nm-thick film at ~1000 K is known to tens of per cent | Campbell et al. 2022 (sails must billow; the shape is set under load); ±20 % is a **guess** for the tension's uncertainty |
| absorptivity ``α`` | ``α₀ (1 ± 0.5)`` | manufacturing (film thickness, dopants) and contamination (outgassing, dust) change the absorption of a thin film by factors | Ilic & Atwater 2019 (absorption is set by impurities and thickness); ±50 % is a **guess** |
| power reaching the sail | ``P₀ (1 ± 0.2)`` | atmospheric transmission (water vapour, aerosols) and the adaptive optics' Strehl ratio of an upward beam, which the station cannot measure at the sail | Lubin 2016 (transmission and Strehl of the ground array); ±20 % is an **estimate** of their variation between nights |
| a constant beam offset at the sail | ``± 1 cm`` per axis | an offset fixed at the sail (its optical centre's, say), sized as 2 nrad of the array's pointing at the window's 5,000 km; a pointing calibration error would be an angle that a beam-rider follows, another model (docs/physics.md §16) | a **guess** (half the largest beam command) |

They act on top of the realistic task's ±10 % spread of mass, inertia and beam power, which the station
also does not observe. Every draw is cheap: no surface quadrature runs at a reset.

* The radiation force is linear in the absorptivity at a fixed sail (``ρ = 1 − α``: per unit area
  the element's force is ``(I/c)(2 cos²θᵢ n + α cos θᵢ (k − 2 cos θᵢ n))``, docs/physics.md §7), so its
  Jacobian, push and every radiation term of §9 is ``X₀ + α X₁``: two linearisations span every ``α``.
* The curvature changes the geometry, the push and the inertia: :class:`CurvatureTable` linearises at
  :data:`CURVATURE_NODES` radii over the draws' range (at ``α = 0`` and ``α = 1``) and interpolates each
  entry by a cubic spline in ``R`` (tested against a direct linearisation between nodes).
* The power and the mass scale rows (as the realistic spread's factors do); the beam offset is a
  constant drive ``B[:, :2] b`` carried in the plant's constant-term column (as the payload's, §15).

The draw's terms enter the model as differences from the nominal sail's, so a draw of all ones is
exactly the nominal model. In a spot widened beyond ``L0`` the difference is the drawn sail's own in that
spot (:class:`WidenedCurvatureTable`: the 9 radii at every point of the widened spot's grid): against a
direct quadrature of the drawn sail in that spot each entry is within 1e-3 (``∂v̇x/∂θy`` 3.5e-3), nearly all
of it the interpolation in ``ln s`` the nominal ``ScaleTable`` shares; against a ``RigidPlant`` of the drawn
sail (R ×1.15, α ×1.4, power ×0.85), which shares it too, 6e-5 off at ``s = 1.03``, 4e-4 at 1.24 and 6e-3
at 1.79 (the draw flies the nominal push law scaled by its ``F/m``, so its spot is a little off that sail's
own flight's: docs/physics.md §16). ``LightSailUncertain-v1`` (``v1_widening``) added
the difference at ``s = 1`` undiminished instead: first order in the draw times the widening, 1.3 % off at
``s = 1.03``, 17 % at 1.24 (the task's fastest draws reach 1.38 by the latest cut-off; ~19 % of its
episodes widen before cut-off) and 3.8 times the terms at 1.79.

The gyroscopic coupling ``I_a Ω / I_t`` is held at the nominal dish's: it is 1.05e-2 rad/s at the
task's 1 rad/s spin (1.7e-4 of the slow mode, 60.6 rad/s) and changes by −1.3 % to +2.5 % over
``R₀ ± 20 %``, 4e-6 of the slow mode.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from sail_env.physics.checks import boolean, real_number
from sail_env.physics.disturbance import Disturbance
from sail_env.physics.memo import built_once
from sail_env.physics.rigid3d.plant import (OMEGA_Y, SPREAD_FIELDS, X, FlightModel, RigidParams, RigidTaskConfig,
                                             RigidPlant)
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.damping import damped_linearisation
from sail_env.physics.rigid3d.scales import blend_weights, cleaned, scale_grid

#: Radii at which :class:`CurvatureTable` linearises (equally spaced over the draws' range).
CURVATURE_NODES = 9
#: The quantities :class:`UncertainPlant` draws after the realistic spread's, in draw order.
UNCERTAIN_FIELDS = ("curvature", "absorptivity", "transmission", "bias_x", "bias_y")


#: The sizes a :class:`ModelUncertainty` takes and their largest values (the beam offset's, the sail's
#: aperture radius, is checked with the sail: :class:`UncertainTaskConfig`).
SIZE_LIMITS = (("curvature", 0.5), ("absorptivity", 1.0), ("power", 0.5), ("pointing_bias_m", math.inf))
#: Why the beam offset ends at the aperture radius ``a``: a constant offset beyond the rim centres the
#: spot off the sail, where the model's linearisation about the centred spot (and its divergence rule,
#: ``|X| ≤ a``) no longer describes it.
BIAS_LIMIT_REASON = "a constant beam offset beyond the rim centres the spot off the sail"


@dataclasses.dataclass(frozen=True)
class ModelUncertainty:
    """Per-episode uniform draws a ground station cannot observe (module docstring).

    Attributes:
        curvature: Relative half-width of the dish's radius of curvature, in [0, 0.5].
        absorptivity: Relative half-width of the absorptivity, in [0, 1] (the draw stays ``≤ 1``).
        power: Relative half-width of the power that reaches the sail, in [0, 0.5].
        pointing_bias_m: Half-width [m] of a constant beam offset at the sail on each axis, in
            ``[0, a]`` with ``a`` the sail's aperture radius (:data:`BIAS_LIMIT_REASON`).
        v0_draws: Draw the factors as ``LightSailUncertain-v0`` did by mistake (lightsail-gym 0.3.0):
            every one uniform within ``1 ± parameter_spread`` whatever the sizes above (with the
            realistic spread of 0.1: curvature, absorptivity and power ±10 %, the beam offset ±10 %
            of ``pointing_bias_m``), and none at all without a spread. Kept so that v0 plays as it
            did; a new task leaves it False.
        v1_widening: In a spot widened beyond ``L0``, add the draw's difference from the nominal sail
            at ``s = 1``, undiminished, as ``LightSailUncertain-v1`` (and v0) did (lightsail-gym 0.4.0):
            first order in the draw times the widening, 17 % of the coast's radiation terms at
            ``s = 1.24``. Kept so that v0 and v1 play as they did; a new task leaves it False and
            takes the drawn sail's own terms in the widened spot (:class:`WidenedCurvatureTable`).
    """

    curvature: float = 0.0
    absorptivity: float = 0.0
    power: float = 0.0
    pointing_bias_m: float = 0.0
    v0_draws: bool = False
    v1_widening: bool = False

    def __post_init__(self) -> None:
        for name, high in SIZE_LIMITS:
            given = getattr(self, name)
            try:
                value = real_number(given, name)
            except ValueError:
                value = math.nan  # not a real number: refused below, with the field's range
            if not (0 <= value <= high and math.isfinite(value)):
                bound = f"[0, {high}]" if math.isfinite(high) else f"[0, aperture_radius_m] ({BIAS_LIMIT_REASON})"
                raise ValueError(f"model_uncertainty.{name} must be a real number in {bound}, got {given!r}")
            object.__setattr__(self, name, value)  # NumPy scalars and ints stored as float
        for name in ("v0_draws", "v1_widening"):
            object.__setattr__(self, name, boolean(getattr(self, name), f"model_uncertainty.{name}"))

    @property
    def active(self) -> bool:
        return any(getattr(self, name) for name, _ in SIZE_LIMITS)

    def scaled(self, k: float) -> ModelUncertainty:
        """Every size times ``k`` (the benchmarks' sweep)."""
        return dataclasses.replace(self, **{name: k * getattr(self, name) for name, _ in SIZE_LIMITS})


#: LightSailUncertain-v1's sizes (module docstring's table).
TASK_UNCERTAINTY = ModelUncertainty(curvature=0.2, absorptivity=0.5, power=0.2, pointing_bias_m=1e-2)


@dataclasses.dataclass(frozen=True)
class UncertainTaskConfig(RigidTaskConfig):
    """A :class:`RigidTaskConfig` whose sail the station knows only to within ``uncertainty``."""

    uncertainty: ModelUncertainty = ModelUncertainty()

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.uncertainty, ModelUncertainty):
            raise ValueError(f"uncertainty must be a ModelUncertainty, got {self.uncertainty!r}")
        u, sail = self.uncertainty, self.sail
        if not u.pointing_bias_m <= sail.aperture_radius_m:
            raise ValueError(f"model_uncertainty.pointing_bias_m must be a real number in [0, aperture_radius_m = "
                             f"{sail.aperture_radius_m} m] ({BIAS_LIMIT_REASON}), got {u.pointing_bias_m!r}")
        if u.curvature and sail.shape != "dish":
            raise ValueError(f"model_uncertainty.curvature needs the dish (sail_shape 'dish'), got {sail.shape!r}")
        low_r = sail.curvature_radius_m * (1 - u.curvature)
        if u.curvature and not low_r > sail.aperture_radius_m:
            raise ValueError(f"model_uncertainty.curvature must keep R > a = {sail.aperture_radius_m} m, "
                             f"got R down to {low_r:.4g} m")
        if sail.absorptivity * (1 + u.absorptivity) > 1.0:
            raise ValueError(f"model_uncertainty.absorptivity must keep α <= 1, got up to "
                             f"{sail.absorptivity * (1 + u.absorptivity):.4g}")
        if sail.reflectivity + sail.absorptivity != 1.0 and u.absorptivity:
            raise ValueError("model_uncertainty.absorptivity needs reflectivity = 1 - absorptivity (nothing "
                             "transmitted)")
        if u.active and self.velocity_terms:
            raise ValueError("model_uncertainty with velocity_terms is not tabulated: switch one off")


class CurvatureTable:
    """The radiation terms of a dish over its radius of curvature and absorptivity, minus the nominal's.

    At each of :data:`CURVATURE_NODES` radii over ``R₀ (1 ± c)`` the sail is linearised at ``α = 0``
    and ``α = 1`` (cleaned of round-off, :func:`~sail_env.physics.rigid3d.scales.cleaned`); each
    quantity is ``X₀(R) + α X₁(R)`` with ``X₀``, ``X₁`` cubic splines in ``R``. Quantities: the
    radiation part of ``A`` (8, 8), ``B`` (8, 4), the centred push [N] and ``I_t`` [kg m²].
    """

    def __init__(self, sail: RigidSailConfig, spin: float, curvature: float) -> None:
        r0 = sail.curvature_radius_m
        self.radii = r0 * np.linspace(1 - curvature, 1 + curvature, CURVATURE_NODES) if curvature else np.array([r0])
        values = [[self._linearise(sail.replace(curvature_radius_m=float(r), absorptivity=a, reflectivity=1.0 - a),
                                   spin) for a in (0.0, 1.0)] for r in self.radii]
        stacked = [np.stack([[v[a][q] for a in (0, 1)] for v in values]) for q in range(4)]  # (nodes, 2, ...)
        self._parts = [(s[:, 0], s[:, 1] - s[:, 0]) for s in stacked]
        import scipy.interpolate  # here: ~0.4 s to import, which every other task would pay

        self._splines = None if len(self.radii) == 1 else [
            tuple(scipy.interpolate.CubicSpline(self.radii, part, axis=0) for part in pair) for pair in self._parts]

    @staticmethod
    def _linearise(config: RigidSailConfig, spin: float) -> tuple[np.ndarray, np.ndarray, float, float]:
        sail = RigidSail(config)
        lin = damped_linearisation(sail, spin=spin)
        radiation, b = cleaned(lin, config.aperture_radius_m)
        return radiation, b, lin.push_n, sail.inertia[0, 0]

    def at(self, radius: np.ndarray, absorptivity: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(A_rad (k, 8, 8), B (k, 8, 4), push (k,), I_t (k,))`` at radii and absorptivities (k,)."""
        radius, absorptivity = np.asarray(radius, float), np.asarray(absorptivity, float)
        if self._splines is None:
            parts = [(np.repeat(p0, len(radius), axis=0), np.repeat(p1, len(radius), axis=0)) for p0, p1 in self._parts]
        else:
            if np.any((radius < self.radii[0] * (1 - 1e-12)) | (radius > self.radii[-1] * (1 + 1e-12))):
                raise ValueError(f"radius must be in [{self.radii[0]}, {self.radii[-1]}] m, got {radius}")
            parts = [(s0(radius), s1(radius)) for s0, s1 in self._splines]
        out = []
        for p0, p1 in parts:
            alpha = absorptivity.reshape((-1,) + (1,) * (p0.ndim - 1))
            out.append(p0 + alpha * p1)
        return tuple(out)


@built_once
def curvature_table(sail: RigidSailConfig, spin: float, curvature: float) -> CurvatureTable:
    """The :class:`CurvatureTable` of ``sail``, built once per process and shared read-only
    (:func:`~sail_env.physics.memo.built_once`)."""
    return CurvatureTable(sail, spin, curvature)


class WidenedCurvatureTable:
    """The radiation part of ``A`` (8, 8), ``B`` (8, 4) and the centred push of a dish over its radius of
    curvature, its absorptivity and the spot's widening ``s ≥ 1`` beyond ``L0``.

    At each of :data:`CURVATURE_NODES` radii (:class:`CurvatureTable`'s) and each point of the widened
    spot's grid (:func:`~sail_env.physics.rigid3d.scales.scale_grid`, the nominal sail's
    :class:`~sail_env.physics.rigid3d.scales.ScaleTable`'s) the sail is linearised at ``α = 0`` and
    ``α = 1``: a cubic spline in ``R`` at every point, exact in ``α``, and along the grid read as the
    ScaleTable reads its own (``s² X`` linearly in ``ln s``,
    :func:`~sail_env.physics.rigid3d.scales.blend_weights`), so the nominal sail's entries here and there
    interpolate alike. Built once per sail and top (936 quadratures for ``LightSailUncertain-v2``, ~12 s,
    then read from the table cache).
    """

    def __init__(self, sail: RigidSailConfig, spin: float, curvature: float, top: float) -> None:
        r0 = sail.curvature_radius_m
        self.radii = r0 * np.linspace(1 - curvature, 1 + curvature, CURVATURE_NODES) if curvature else np.array([r0])
        self.sail, self.top = sail, top
        self.log_scales, _ = scale_grid(sail, top)
        weight = np.exp(2.0 * self.log_scales)
        values = [[self._linearise(sail.replace(curvature_radius_m=float(r), absorptivity=a, reflectivity=1.0 - a),
                                   spin, weight) for a in (0.0, 1.0)] for r in self.radii]
        # (nodes, 2 (α = 0, 1), grid, ...) per quantity; each α's part: X₀ and X₁ = X(α = 1) − X₀.
        stacked = [np.stack([[v[a][q] for a in (0, 1)] for v in values]) for q in range(3)]
        parts = [np.stack([q[:, 0], q[:, 1] - q[:, 0]], axis=1) for q in stacked]
        import scipy.interpolate  # here: ~0.4 s to import, which every other task would pay

        self._parts = parts if len(self.radii) == 1 else [scipy.interpolate.CubicSpline(self.radii, part, axis=0)
                                                          for part in parts]

    def _linearise(self, config: RigidSailConfig, spin: float,
                   weight: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``s² A_rad`` (grid, 8, 8), ``s² B`` (grid, 8, 4) and ``s² push`` (grid,) of one sail."""
        sail = RigidSail(config)
        lins = [damped_linearisation(sail, spin=spin, beam_scale=float(math.exp(x))) for x in self.log_scales]
        parts = [cleaned(lin, config.aperture_radius_m) for lin in lins]
        return (weight[:, None, None] * np.stack([part[0] for part in parts]),
                weight[:, None, None] * np.stack([part[1] for part in parts]),
                weight * np.array([lin.push_n for lin in lins]))

    def values(self, radius: np.ndarray) -> list[np.ndarray]:
        """The table's entries at radii (k,): ``s²`` times the radiation part of ``A`` (k, 2, G, 8, 8), of
        ``B`` (k, 2, G, 8, 4) and the push (k, 2, G), the second axis ``X₀`` and ``X₁`` (``X = X₀ + α X₁``)."""
        radius = np.asarray(radius, float)
        return [np.repeat(part, len(radius), axis=0) if isinstance(part, np.ndarray) else part(radius)
                for part in self._parts]

    def at(self, radius: np.ndarray, absorptivity: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, ...]:
        """``(A_rad (k, 8, 8), B (k, 8, 4), push (k,))`` of sails with radii, absorptivities and spot
        scales (k,) (up to ``s = 1``: the unwidened spot's)."""
        absorptivity = np.asarray(absorptivity, float)
        index, upper, mix, inverse = blend_weights(self.log_scales, self.top, scale)
        rows = np.arange(len(absorptivity))
        out = []
        for values in self.values(radius):
            trailing = (slice(None),) + (None,) * (values.ndim - 3)
            alpha = absorptivity[trailing]
            below = values[rows, 0, index] + alpha * values[rows, 1, index]
            above = values[rows, 0, upper] + alpha * values[rows, 1, upper]
            out.append(inverse[trailing] * ((1 - mix[trailing]) * below + mix[trailing] * above))
        return tuple(out)


@built_once
def widened_curvature_table(sail: RigidSailConfig, spin: float, curvature: float,
                            top: float) -> WidenedCurvatureTable:
    """The :class:`WidenedCurvatureTable` of ``sail``, built once per process and shared read-only
    (:func:`~sail_env.physics.memo.built_once`)."""
    return WidenedCurvatureTable(sail, spin, curvature, top)


class UncertainPlant(RigidPlant):
    """:class:`RigidPlant` with the draws of :class:`ModelUncertainty` on top of the parameter spread.

    Factors per episode: mass, inertia and beam power (``1 ± parameter_spread``), then
    :data:`UNCERTAIN_FIELDS`: curvature, absorptivity and transmission as relative factors, the
    beam offsets as ``1 + b / pointing_bias_m`` in [0, 2] (one: none). A draw of all ones is the
    nominal model.
    """

    spread_fields = SPREAD_FIELDS + UNCERTAIN_FIELDS
    always_biased = True
    light_speed_settings = "parameter_spread, model_uncertainty.power and cutoff_jitter_s"

    def __init__(self, config: UncertainTaskConfig, parameter_spread: float = 0.0, push_noise: float = 0.0,
                 disturbances: Sequence[Disturbance] = ()) -> None:
        u = config.uncertainty
        self.uncertainty = u
        self.table = curvature_table(config.sail, config.spin_rad_s, u.curvature)
        sail = config.sail
        self._nominal_terms = self.table.at(np.array([sail.curvature_radius_m]), np.array([sail.absorptivity]))
        pushes = [self.table.at(np.array([r]), np.array([a]))[2][0] for r in self.table.radii
                  for a in sail.absorptivity * np.array([1 - u.absorptivity, 1 + u.absorptivity])]
        self._push_range = np.array([min(pushes), max(pushes)]) / self._nominal_terms[2][0]
        half = np.array([u.curvature, u.absorptivity, u.power, 1.0, 1.0])
        self._low, self._high = 1 - half, 1 + half
        self.widened = None
        super().__init__(config, parameter_spread, push_noise, disturbances)
        if self.scales is not None and not u.v1_widening:
            self.widened = widened_curvature_table(sail, config.spin_rad_s, u.curvature, self.scales.top)
        if u.active:
            self._shared = None

    def largest_ratio(self, parameter_spread: float) -> float:
        s, p = parameter_spread, self.uncertainty.power
        fastest = (1 + s) * (1 + p) * self._push_range[1] / (1 - s)
        slowest = (1 - s) * (1 - p) * self._push_range[0] / (1 + s)
        return max(fastest, 1.0 / slowest)

    @property
    def n_draws(self) -> int:
        return 3 * bool(self.parameter_spread) + len(UNCERTAIN_FIELDS) * self.uncertainty.active

    def factors(self, uniforms: np.ndarray) -> np.ndarray:
        """Mass, inertia and power within ``1 ± parameter_spread`` (the first three uniforms, if there is a
        spread), then :data:`UNCERTAIN_FIELDS` over the uncertainty's own ranges (the next five)."""
        if self.uncertainty.v0_draws:
            return super().factors(uniforms)
        out = np.ones((len(uniforms), self.n_factors))
        spread = 3 if self.parameter_spread else 0
        if spread:
            out[:, :3] = super().factors(uniforms[:, :3])
        if self.uncertainty.active:
            out[:, 3:] = self._low + (self._high - self._low) * uniforms[:, spread:]
        return out

    def params(self, factors: np.ndarray):
        return self._shared if self._shared is not None else self._build(factors, shared=False)

    def _sail_terms(self, factors: np.ndarray) -> tuple[np.ndarray, ...]:
        sail = self.config.sail
        return self.table.at(sail.curvature_radius_m * factors[:, 3], sail.absorptivity * factors[:, 4])

    def draw_rows(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The spread's rows with the transmission on the power; ``F/m`` with the draw's own push."""
        scaled = factors[:, :3].copy()
        scaled[:, 2] *= factors[:, 5]
        rows, ratio = super().draw_rows(scaled)
        push = self._sail_terms(factors)[2] if self.uncertainty.curvature or self.uncertainty.absorptivity else None
        return rows, ratio if push is None else ratio * push / self._nominal_terms[2][0]

    def draw_radiation(self, factors: np.ndarray, ratio: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nominal sail's terms in the spot at ``t`` plus the draw's difference from them in that
        spot (:class:`WidenedCurvatureTable`; with ``v1_widening``, or where the spot has not widened, the
        difference at ``s = 1``), with the draw's payload torque and beam offset in the constant column
        (:func:`with_draw_terms`). Each row's numbers are its own, whatever the other rows' spots (a batch
        plays the single episodes)."""
        base_a, base_b = self._radiation(ratio, t)
        delta_a, delta_inputs, delta_push = self._near_differences(factors)
        if self.widened is not None:
            scale = self.flights.beam_scale(ratio, t) * np.ones(len(factors))
            far = scale > 1.0
            if np.any(far):
                sail, k = self.config.sail, len(factors)
                inertia = self._sail_terms(factors)[3]
                drawn = self.widened.at(sail.curvature_radius_m * factors[:, 3], sail.absorptivity * factors[:, 4],
                                        scale)
                nominal = self.widened.at(np.full(k, sail.curvature_radius_m), np.full(k, sail.absorptivity), scale)
                delta_a = np.where(far[:, None, None], drawn[0] - nominal[0], delta_a)
                delta_inputs = np.where(far[:, None, None], drawn[1] - nominal[1], delta_inputs)
                delta_push = np.where(far, drawn[2] / inertia - nominal[2] / self._nominal_terms[3][0], delta_push)
        offsets = (self.radiation_b[None] if self.uncertainty.v1_widening else base_b)[:, :, :2]
        return with_draw_terms(base_a, base_b, delta_a, delta_inputs, delta_push, self._bias(factors), offsets,
                               self._payload_offset)

    def _near_differences(self, factors: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The draws' differences from the nominal sail in the unwidened spot: of the radiation part of
        ``A`` (k, 8, 8), of ``B`` (k, 8, 4) and of the push over ``I_t`` (k,)."""
        radiation, b, push, inertia = self._sail_terms(factors)
        nominal_a, nominal_b, nominal_push, nominal_inertia = (q[0] for q in self._nominal_terms)
        return radiation - nominal_a, b - nominal_b, push / inertia - nominal_push / nominal_inertia

    def _bias(self, factors: np.ndarray) -> np.ndarray:
        """The draws' constant beam offsets at the sail [m] (k, 2)."""
        return (factors[:, 6:8] - 1.0) * self.uncertainty.pointing_bias_m

    @property
    def _payload_offset(self) -> float:
        """How far the payload moves the CoM off the axis [m] (:func:`~sail_env.physics.rigid3d.plant.payload_term`)."""
        return self.config.payload_offset_m * self.config.sail.craft_mass_kg / self.linearisation.mass_kg

    def flight_model(self, p: RigidParams) -> FlightModel | None:
        """:meth:`RigidPlant.flight_model` with each draw's own sail terms (:class:`DrawTerms`)."""
        model = super().flight_model(p)
        if model is None:
            return None
        sail, factors = self.config.sail, p.factors * np.ones((len(model.ratio), 1))
        delta_a, delta_inputs, delta_push = self._near_differences(factors)
        terms = DrawTerms(near_a=delta_a, near_inputs=delta_inputs, near_push=delta_push, bias=self._bias(factors),
                          inertia=self._sail_terms(factors)[3], nominal_inertia=float(self._nominal_terms[3][0]),
                          payload_offset=self._payload_offset, v1_widening=self.uncertainty.v1_widening,
                          widened=self.widened, radii=sail.curvature_radius_m * factors[:, 3],
                          absorptivities=sail.absorptivity * factors[:, 4])
        return dataclasses.replace(model, draw=terms)


@dataclasses.dataclass(frozen=True)
class DrawTerms:
    """What a coast along the flight reads of each uncertain draw's own sail (K, ...): its differences
    from the nominal sail in the unwidened spot, its beam offset and ``I_t``, and where the spot widens
    (``widened``; None: ``v1_widening``, or a spot that never widens) the draw's radii and absorptivities
    that :meth:`grids` reads the table at. :meth:`UncertainPlant.draw_radiation` with these arrays is
    :func:`with_draw_terms`; the JAX backend's coast (``sail_env.jax.along``) is handed them."""

    near_a: np.ndarray  # (K, 8, 8) the radiation part of A minus the nominal sail's, unwidened spot
    near_inputs: np.ndarray  # (K, 8, 4) and of B
    near_push: np.ndarray  # (K,) the push over I_t [1/(m s²)·m], minus the nominal sail's
    bias: np.ndarray  # (K, 2) the constant beam offset at the sail [m]
    inertia: np.ndarray  # (K,) the draw's I_t [kg m²]
    nominal_inertia: float
    payload_offset: float  # the CoM's distance from the axis [m] the payload makes
    v1_widening: bool  # the unwidened difference and offset columns everywhere (ModelUncertainty.v1_widening)
    widened: WidenedCurvatureTable | None
    radii: np.ndarray  # (K,) the draw's radius of curvature [m]
    absorptivities: np.ndarray  # (K,)

    def grids(self, points: int, chunk: int = 256) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
        """The widened table's entries (``s²`` times the radiation part of ``A``, of ``B``, the push) on
        its first ``points`` grid points: the draws' (K, points, ...) and the nominal sail's (points, ...),
        each combined in ``α`` as :meth:`WidenedCurvatureTable.at` combines them (the same numbers it
        blends). Built ``chunk`` draws at a time: the whole grid of 4,096 draws would be 165 MB."""
        table, config = self.widened, self.widened.sail
        radii = np.append(self.radii, config.curvature_radius_m)
        alphas = np.append(self.absorptivities, config.absorptivity)
        out: list[list[np.ndarray]] = [[], [], []]
        for start in range(0, len(radii), chunk):
            rows = slice(start, start + chunk)
            for q, values in enumerate(table.values(radii[rows])):
                alpha = alphas[rows].reshape((-1,) + (1,) * (values.ndim - 3))
                out[q].append(values[:, 0, :points] + alpha[:, None] * values[:, 1, :points])
        stacked = [np.concatenate(q) for q in out]
        return tuple(q[:-1] for q in stacked), tuple(q[-1] for q in stacked)


def with_draw_terms(base_a: Any, base_b: Any, delta_a: Any, delta_inputs: Any, delta_push: Any, bias: Any,
                    offsets: Any, payload_offset: float, xp: Any = np) -> tuple[Any, Any]:
    """A draw's radiation part of ``A`` (..., 8, 8) and ``B`` (..., 8, c): the nominal sail's ``base_a``,
    ``base_b`` in the spot plus the draw's differences ``delta_a``, ``delta_inputs`` (..., 8, 4) and
    ``delta_push`` (the push over ``I_t``, (...)), the difference carried into the constant column: the
    payload's term (:func:`~sail_env.physics.rigid3d.plant.payload_term`) of the differences and the beam
    offset ``bias`` (..., 2) acting through the offset columns ``offsets`` (..., 8, 2) plus the draw's
    difference of them. ``xp``: the array module (the JAX backend's coast calls it with ``jax.numpy``)."""
    column = -payload_offset * delta_a[..., :, X]
    torque = payload_offset * delta_push
    if xp is np:
        column[..., OMEGA_Y] += torque
    else:
        column = column.at[..., OMEGA_Y].add(torque)
    column = column + xp.einsum("...ij,...j->...i", offsets + delta_inputs[..., :, :2], bias)
    between = base_b.shape[-1] - delta_inputs.shape[-1] - 1  # inputs without a column (none on these tasks)
    delta_b = xp.concatenate([delta_inputs, xp.zeros(delta_inputs.shape[:-1] + (between,), delta_inputs.dtype), column[..., None]],
                             axis=-1)
    return base_a + delta_a, base_b + delta_b


def __getattr__(name: str) -> type:
    """The configuration's name before version 0.4, kept a while with a warning."""
    if name == "UncertainFlight":
        warnings.warn("UncertainFlight is now UncertainTaskConfig", DeprecationWarning, stacklevel=2)
        return UncertainTaskConfig
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
