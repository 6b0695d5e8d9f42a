"""The centred sail's radiation terms over the spot's widening ``s ≥ 1`` (docs/physics.md §7, §12, §14).

Beyond the diffraction length the sail sees its beam's profile widened by ``s = D/L0`` with the
intensity ``/s²`` (:mod:`.beams`): the radiation part of ``A`` and ``B`` (:func:`.linearise`) changes
with ``s``. The surface quadrature is too slow to repeat along a flight, so :class:`ScaleTable`
linearises once on a grid of ``ln s`` and interpolates. It interpolates ``s² R(s)`` linearly in
``ln s`` and divides by ``s²``: a sail inside a uniform spot (a flat-top wider than it) feels
everything in proportion to the intensity ``∝ 1/s²``, for which this is exact (raw ``R`` interpolated on
the 5 % grid is off by ~1e-3 there). A Gaussian's far field is not uniform to the sail's lateral
stiffness, which only the intensity's curvature makes (``∝ 1/s⁴``; the tilt terms and the push
``∝ 1/s²``): there the interpolation is within ~1e-3 of each entry (docs/physics.md §16). A hard beam edge that meets
the rim as the spot widens changes the stiffnesses discontinuously: the grid keeps clear of such
scales and never interpolates across them.
"""

from __future__ import annotations

import math

import numpy as np

from sail_env.physics.memo import built_once
from sail_env.physics.rigid3d.body import RigidSail
from sail_env.physics.rigid3d.config import RigidSailConfig
from sail_env.physics.rigid3d.damping import damped_linearisation
from sail_env.physics.rigid3d.linearise import Linearisation

#: Entries of the radiation part of ``A`` and ``B`` below this fraction of their natural
#: scale (push/(m a), push/m, push Lc/(I a), push Lc/I) are central-difference round-off
#: (~1e-8 relative) of quantities that vanish by symmetry; left in, they give a neutral
#: sail a spurious √ε growth that 600 s of propagation would amplify.
ROUND_OFF = 1e-6
#: Ratio of neighbouring beam scales at which the wrench Jacobian is evaluated.
SCALE_STEP = 1.05
#: A hard beam edge crossing the rim (beam radius × scale = aperture) changes the stiffnesses
#: discontinuously: the grid takes points this far (in ln scale) on either side, never across.
EDGE_CLEARANCE = 1e-4


def cleaned(lin: Linearisation, aperture_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Radiation part of ``A`` and ``B`` with round-off of vanishing entries set to zero."""
    force, torque = lin.push_n / lin.mass_kg, lin.push_n * lin.com_distance_m / lin.inertia[0, 0]
    rows = np.array([0, 0, force, force, 0, 0, torque, torque])[:, None]
    length, angle = 1.0 / aperture_m, 1.0
    a_scale = rows * np.array([length, length, 0, 0, angle, angle, 0, 0])
    b_scale = rows * np.array([length, length, angle, angle])
    radiation = np.where(np.abs(lin.push_sensitivity) > ROUND_OFF * a_scale, lin.push_sensitivity, 0.0)
    b = np.where(np.abs(lin.B) > ROUND_OFF * b_scale, lin.B, 0.0)
    return radiation, b


def scale_grid(config: RigidSailConfig, top: float) -> tuple[np.ndarray, list[float]]:
    """Grid of ``ln s`` on ``[0, ln top]``: ``s = 1`` itself, then pieces between the scales where a
    hard beam edge meets the rim (``s r_edge = a``), each kept :data:`EDGE_CLEARANCE` clear of them;
    and the piece ends inside ``[0, ln top)`` (where ``A`` has kinks or jumps)."""
    if top <= 1.0:
        return np.zeros(1), []
    end = math.log(top)
    edges = {0.0, end}
    edges |= {x for r in config.beam().edges if 0 < (x := math.log(config.aperture_radius_m / r)) < end}
    edges = sorted(edges)
    points = [np.zeros(1)]
    step = math.log(SCALE_STEP)
    for lo, hi in zip(edges[:-1], edges[1:]):
        lo, hi = lo + EDGE_CLEARANCE, max(hi - EDGE_CLEARANCE, lo + EDGE_CLEARANCE)
        # Spaced from the piece's start, not spread over it: ``top`` comes from an integrated flight
        # whose last digits differ between BLAS kernels (1e-9), and a grid spread over [lo, ln top]
        # moved every point, and with them the interpolated matrices by 2e-10 (docs/physics.md §3).
        # Now only the last interval, beyond every draw's reach, depends on ``top``.
        inner = lo + step * np.arange(max(1, math.ceil((hi - lo) / step - 1e-9)))
        points.append(np.append(inner, hi))
    return np.concatenate(points), edges[:-1]


class ScaleTable:
    """Radiation part of ``A`` (8, 8) and ``B`` (8, 4) of the centred sail at the configured power,
    no Doppler factor, for spots widened by ``1 ≤ s ≤ top`` (cleaned of round-off, :func:`cleaned`;
    with ``velocity_terms`` the v/c terms of :mod:`.damping` included).

    Attributes:
        top: The largest scale it serves (the last grid point is :data:`EDGE_CLEARANCE` below it).
        log_scales: The grid (:func:`scale_grid`); ``kinks``: the ``ln s`` where pieces start.
    """

    def __init__(self, sail: RigidSail, top: float, velocity_terms: bool = False) -> None:
        self.top = top
        self.log_scales, self.kinks = scale_grid(sail.config, top)
        lins = [damped_linearisation(sail, beam_scale=float(math.exp(x)), velocity_terms=velocity_terms)
                for x in self.log_scales]
        parts = [cleaned(lin, sail.config.aperture_radius_m) for lin in lins]
        weight = np.exp(2.0 * self.log_scales)
        self._radiation = weight[:, None, None] * np.stack([p[0] for p in parts])
        self._inputs = weight[:, None, None] * np.stack([p[1] for p in parts])
        self._push = weight * np.array([sail.centred_push(1.0, float(math.exp(x))) for x in self.log_scales])

    def at(self, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Radiation ``A`` (k, 8, 8) and ``B`` (k, 8, 4) at scales (k,); up to ``s = 1`` the table's
        first entry, beyond never mixed with it (an edge may sit at ``s = 1``)."""
        return self._blend(self._radiation, scale), self._blend(self._inputs, scale)

    def push_at(self, scale: np.ndarray) -> np.ndarray:
        """The centred sail's push [N] (k,) at scales (k,), interpolated as :meth:`at`."""
        return self._blend(self._push, scale)

    def _blend(self, table: np.ndarray, scale: np.ndarray) -> np.ndarray:
        """``table`` (grid, ...) interpolated as ``s² R`` linearly in ``ln s``, divided by ``s²``."""
        index, upper, mix, inverse = blend_weights(self.log_scales, self.top, scale)
        trailing = (slice(None),) + (None,) * (table.ndim - 1)
        return inverse[trailing] * ((1 - mix[trailing]) * table[index] + mix[trailing] * table[upper])


def blend_weights(log_scales: np.ndarray, top: float,
                  scale: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """How a table weighted by ``s²`` on the grid ``log_scales`` (:func:`scale_grid`, up to ``top``) is
    read at scales (k,): the grid points below and above each, the weight of the upper one and
    ``1/s²``, so that the read is ``inverse ((1 − mix) T[index] + mix T[upper])``. Up to ``s = 1`` the
    first point alone, beyond never mixed with it (an edge may sit at ``s = 1``). ``ValueError``
    beyond ``top``."""
    log_scale = np.log(np.asarray(scale, float))
    if np.any(log_scale > math.log(max(top, 1.0)) + 1e-12):
        raise ValueError(f"beam scale {float(np.exp(log_scale.max()))} is beyond the table's {top}")
    index = np.zeros(log_scale.shape, dtype=np.int64)
    frac = np.zeros(log_scale.shape)
    beyond = log_scale > 0.0
    if np.any(beyond):
        grid = log_scales[1:]
        weight = np.interp(log_scale[beyond], grid, np.arange(grid.size))
        low = np.minimum(weight.astype(np.int64), grid.size - 2)
        index[beyond], frac[beyond] = 1 + low, weight - low
    upper = np.minimum(index + 1, log_scales.size - 1)
    return index, upper, frac, 1.0 / np.maximum(scale, 1.0) ** 2


@built_once
def scale_table(sail: RigidSailConfig, top: float, velocity_terms: bool) -> ScaleTable:
    """The :class:`ScaleTable` of ``sail``, built once per process and shared read-only
    (:func:`~sail_env.physics.memo.built_once`)."""
    return ScaleTable(RigidSail(sail), top, velocity_terms)
