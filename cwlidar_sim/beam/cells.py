"""The probe volume cut into range cells, for every lidar: cells, sub-points, the tail rule, clouds.

Every sensor hands the signal chain the line-of-sight speeds of the same
structure: range cells along the beam with their weights (the exact integral
of the weighting over each cell), each cell sampled at one or more
sub-points, and one rule for the weight beyond the simulated span.

Cells and their growth
----------------------
The span ``[max(-span z_R, -r), span z_R]`` around the focus (clipped at the
telescope) is cut into cells.  With ``growth = 0`` they are equal, of about
``cell_length``.  With ``growth = g > 0`` a cell at distance ``|s|`` from the
focus is ``max(cell_length, g |s|)`` long (cells grow geometrically in the
tails, where the weighting falls like ``z_R / (pi s^2)``), so a long span
costs few cells; each cell is still sampled every ``cell_length`` (its
sub-points) and its speed is the weighting-weighted mean of its sub-points,
so tier 1 (the weighted line-of-sight average) is the same sum as with equal
cells of ``cell_length`` and only tiers 2 and 3 see fewer, wider cells (a
grown cell's Doppler line carries the sub-cell spread of the base grid, not
the resolved spread along its own length).

The tail rule (one rule for every sensor)
-----------------------------------------
The weight outside the simulated span, ``truncated_fraction``
(``~ 2 / (pi span)`` for the Lorentzian), is either

* ``'mean_wind'`` (default): carried by one more cell that sees the mean
  wind ``n . (U, 0, 0)``, so a uniform wind is returned exactly by the
  weighted average (tier 1); in the Doppler spectrum (tiers 2, 3) that far
  tail is a pedestal of the turbulence's whole speed distribution about the
  mean, below any threshold, and the signal chain leaves it out
  (:mod:`cwlidar_sim.signal.chain`); or
* ``'renormalise'``: dropped, the cells' weights divided by the kept fraction.

Why the mean wind: the far tail lies many turbulence length scales from the
focus along the beam, so its turbulent speeds are uncorrelated with those of
the core and, averaged over its great length, contribute almost nothing but
the mean; renormalising instead over-weights the core's turbulence by
``1 / kept_fraction`` at every wavenumber above ``1 / (span z_R)`` (for a
beam along the wind, the transfer function rises by ``2 truncated_fraction``,
6 % at span 20).  A 1-D model (a von Karman line along the beam) gives the
error of the lidar's standard deviation at span S for the two rules: with
``L / z_R = 3``, -1.4 % / -0.13 % / -0.01 % (mean wind) against +12.7 % /
+6.6 % / +3.3 % (renormalised) at S = 5 / 10 / 20; with ``L / z_R = 10``,
-4.7 % / -1.0 % / -0.13 % against +9 % / +5.7 % / +3.2 %.  The mean-wind
tail's error falls like ``truncated_fraction`` times the tail's correlation
with the core, and the span must be long enough for that to be negligible:
``growth`` makes long spans cheap.  (Placing the tail's weight on a point
cell that sees the field is worse: a point has a flat transfer function, so
it puts a floor of ``truncated_fraction^2`` under the transfer function.)

Clouds
------
A cloud layer crossed by the beam between ranges ``a`` and ``b`` carries
``w_c = strength * int_a^b phi`` of the aerosol probe volume's unit weight
(:func:`interval_weight`): the weighting's far tail (``~ z_R / (pi s^2)``)
times a backscatter orders of magnitude above the aerosol's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._repr import summary_repr
from .._validation import check_choice, check_int, check_real
from .optics import BeamOptics, _as_float_array
from .probe import ProbeVolume

__all__ = ["ProbeCells", "probe_cells", "interval_weight", "TAIL_RULES", "RangeCells", "weight_truncated"]

#: What the weight beyond the simulated span sees (module notes).
TAIL_RULES = ("mean_wind", "renormalise")


@dataclasses.dataclass(frozen=True)
class ProbeCells:
    """Range cells of a probe volume, their sub-points and the tail's weight.

    Attributes
    ----------
    s_s : ndarray, shape (n_s,)
        Cell centres, distance from the focus [m] (positive away from the lidar).
    weight_s : ndarray, shape (n_s,)
        Cell weights [-]: exact integrals of the weighting over the cells
        (divided by ``kept_fraction`` for the 'renormalise' rule).
    edges : ndarray, shape (n_s + 1,)
        Cell edges [m].
    sub_j : ndarray, shape (n_j,)
        Sub-points, distance from the focus [m]; cell ``s`` owns
        ``sub_j[ptr_s[s]:ptr_s[s + 1]]``.
    fraction_j : ndarray, shape (n_j,)
        Share of its cell's weight of each sub-point [-] (summing to 1 per cell).
    ptr_s : ndarray of int64, shape (n_s + 1,)
        Sub-point offsets of the cells.
    tail_weight : float
        Weight of the mean-wind tail cell [-] (0 for 'renormalise').
    kept_fraction, truncated_fraction : float
        Weight inside and outside the span [-].
    tail : str
        The tail rule.
    weighting : str
    rayleigh_length : float
        z_R [m].
    cell_length, growth : float
        The base cell length [m] and the growth factor [-].
    """

    s_s: np.ndarray
    weight_s: np.ndarray
    edges: np.ndarray
    sub_j: np.ndarray
    fraction_j: np.ndarray
    ptr_s: np.ndarray
    tail_weight: float
    kept_fraction: float
    truncated_fraction: float
    tail: str
    weighting: str
    rayleigh_length: float
    cell_length: float
    growth: float

    @property
    def n_cells(self) -> int:
        """Number of range cells (the tail cell not counted)."""
        return int(self.s_s.size)

    @property
    def weight_tail_s(self) -> np.ndarray:
        """Weights of the chain's aerosol cells: the range cells, then the tail cell if any [-]."""
        return self.weight_s if self.tail_weight == 0.0 else np.append(self.weight_s, self.tail_weight)

    def transfer(self, k):
        """Fourier transform of the sub-point weights, ``sum_j w_j exp(-i k s_j)`` [-], k in rad/m.

        The tail cell is not included (it sees the mean wind only).
        """
        k = np.asarray(k, dtype=np.float64)
        w_j = self.fraction_j * np.repeat(self.weight_s, np.diff(self.ptr_s))
        return np.exp(-1j * np.multiply.outer(k, self.sub_j)) @ w_j


def _grown_edges(lo, hi, cl, g):
    """Edges from ``lo`` < 0 <= ``hi``, cells ``max(cl, g |s|)`` long measured from the focus outward."""
    def side(end):
        e = [0.0]
        while e[-1] < end:
            e.append(e[-1] + max(cl, g * e[-1]))
        e[-1] = end
        if len(e) > 2 and e[-1] - e[-2] < 0.5 * max(cl, g * e[-2]):
            del e[-2]  # no sliver at the span's end
        return np.array(e)

    far = side(hi)
    near = -side(-lo)[::-1] if lo < 0.0 else np.array([0.0])
    return np.concatenate([near[:-1], far]) if lo < 0.0 else far


def probe_cells(optics: BeamOptics, weighting: str = "exact", span: float = 20.0, cell_length: float = 0.5, *,
                growth: float = 0.0, tail: str = "mean_wind") -> ProbeCells:
    """Range cells of the probe volume over ``+/- span`` Rayleigh lengths (module notes).

    Parameters
    ----------
    optics : BeamOptics
        Focus r and Rayleigh length z_R.
    weighting : str or Weighting
        A registered weighting (:data:`cwlidar_sim.beam.WEIGHTINGS`:
        'exact', :func:`cwlidar_sim.beam.weight_exact`; 'lorentzian', A2012
        Eq. 4; ...) or a :class:`~cwlidar_sim.beam.Weighting`.
    span : float
        Half-width of the simulated span [the weighting's scale: z_R]; in
        (0, 10000]; clipped to the weighting's support (the telescope).
    cell_length : float
        Base cell length and sub-point spacing [m]; in (0, 1000].  With
        ``growth = 0`` the span of length ``l`` is cut into
        ``ceil(l / cell_length)`` equal cells.
    growth : float
        Cells grow to ``growth |s|`` at distance ``|s|`` from the focus; in
        [0, 1] (0: equal cells).
    tail : {'mean_wind', 'renormalise'}
        What the weight beyond the span sees (module notes).

    Returns
    -------
    ProbeCells
    """
    if not isinstance(optics, BeamOptics):
        raise TypeError(f"optics must be a BeamOptics, got {type(optics).__name__}")
    pv = ProbeVolume(optics, weighting)
    span = check_real("span", span, lo=0.0, hi=1e4, lo_open=True)
    cl = check_real("cell_length", cell_length, lo=0.0, hi=1000.0, lo_open=True)
    g = check_real("growth", growth, lo=0.0, hi=1.0)
    check_choice("tail", tail, TAIL_RULES)
    zR = optics.rayleigh_length
    lo, half = pv.extent(span)
    if g == 0.0:
        n = max(1, int(math.ceil((half - lo) / cl - 1e-9)))
        if n > 100_000:
            raise ValueError(f"number of range cells={n} (span {span} z_R, cell_length {cl} m) is out of range; "
                             "allowed: <= 100000 "
                             "(use a longer cell_length or growth > 0)")
        edges = np.linspace(lo, half, n + 1)
    else:
        edges = _grown_edges(lo, half, cl, g)
    cdf = pv.primitive(edges)
    w = np.diff(cdf)
    kept = float(cdf[-1] - cdf[0])
    truncated = pv.truncated_fraction(lo, half, kept)
    s = 0.5 * (edges[:-1] + edges[1:])
    length = np.diff(edges)
    n_subpoints = np.maximum(1, np.ceil(length / cl - 1e-9).astype(np.int64))
    ptr = np.concatenate([[0], np.cumsum(n_subpoints)]).astype(np.int64)
    if np.all(n_subpoints == 1):
        sub, frac = s.copy(), np.ones(s.size)
    else:
        sub = np.empty(int(ptr[-1]))
        frac = np.empty(int(ptr[-1]))
        for c in range(s.size):
            if n_subpoints[c] == 1:
                sub[ptr[c]], frac[ptr[c]] = s[c], 1.0
                continue
            e = np.linspace(edges[c], edges[c + 1], n_subpoints[c] + 1)
            ws = np.diff(pv.primitive(e))
            sub[ptr[c]:ptr[c + 1]] = 0.5 * (e[:-1] + e[1:])
            frac[ptr[c]:ptr[c + 1]] = ws / ws.sum() if ws.sum() > 0 else 1.0 / n_subpoints[c]
    if tail == "renormalise":
        w = w / kept
        tail_weight_value = 0.0
    else:
        tail_weight_value = truncated
    return ProbeCells(s_s=s, weight_s=w, edges=edges, sub_j=sub, fraction_j=frac, ptr_s=ptr, tail_weight=tail_weight_value,
                      kept_fraction=kept, truncated_fraction=truncated, tail=tail, weighting=pv.name,
                      rayleigh_length=zR, cell_length=cl, growth=g)


def interval_weight(optics: BeamOptics, weighting, a: float, b: float) -> float:
    """Integral of the weighting between distances ``a < b`` from the focus [-] (module notes: clouds).

    :meth:`cwlidar_sim.beam.Weighting.interval`: closed form for the
    Cauchy densities (the exact and Lorentzian weightings,
    :mod:`cwlidar_sim.beam.optics`), without cancellation for a far interval.
    """
    pv = ProbeVolume(optics, weighting)
    a = check_real("a", a)
    b = check_real("b", b, lo=a)
    return pv.interval(a, b)


# ---------------------------------------------------------------------------
# range cells
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class RangeCells:
    """Discretised weighting over a finite span of the beam.

    Attributes
    ----------
    s_s : ndarray, shape (n_cells,)
        Cell centres, distance from the focus [m] (positive away from the lidar).
    weight_s : ndarray, shape (n_cells,)
        Cell weights [-]: the integral of phi over each cell (exact, from the
        analytic cumulative weight), divided by ``kept_fraction`` when
        ``renormalised``.
    edges : ndarray, shape (n_cells + 1,)
        Cell edges [m].
    kept_fraction : float
        Integral of phi over the span [-] (before any renormalisation).
    truncated_fraction : float
        ``1 - kept_fraction``: the weight of the tails outside the span [-].
    renormalised : bool
        True if ``weight_s`` sums to 1; False if it sums to ``kept_fraction``
        and the missing tail weight is left for the caller to account for.
    weighting : str
        The weighting's registry name (:data:`cwlidar_sim.beam.WEIGHTINGS`).
    rayleigh_length : float
        z_R of the optics [m] (A2012 Eq. 1).
    """

    __repr__ = summary_repr

    s_s: np.ndarray
    weight_s: np.ndarray
    edges: np.ndarray
    kept_fraction: float
    truncated_fraction: float
    renormalised: bool
    weighting: str
    rayleigh_length: float

    def transfer(self, k):
        """Fourier transform of the discrete weights, sum_s w_s exp(-i k s_s) [-], k in rad/m."""
        k = _as_float_array("k", k)
        return np.exp(-1j * np.multiply.outer(k, self.s_s)) @ self.weight_s


def weight_truncated(
    optics: BeamOptics,
    weighting: str = "exact",
    span: float = 20.0,
    n_cells: int = 201,
    renormalise: bool = True,
) -> RangeCells:
    """Range cells and weights of the probe volume over a finite span.

    The Lorentzian tails are heavy (``phi ~ z_R / (pi s^2)``): a span of
    +/- N z_R misses ``1 - (2/pi) arctan(N)`` of the weight (3.2 % for N = 20,
    0.64 % for N = 100).  This function reports that missing fraction, and
    either

    * ``renormalise=True`` (default): divides the weights by the kept
      fraction, so a uniform wind is returned exactly; the fluctuations of the
      kept cells are then over-weighted by ``1 / kept_fraction``, which is the
      right choice when the far tail sees mostly the mean wind; or
    * ``renormalise=False``: keeps the weights as the exact integrals of phi
      over the cells (summing to ``kept_fraction``) and leaves the missing
      weight explicit in ``truncated_fraction``, e.g. for a caller that adds
      ``truncated_fraction * n.U`` for the mean flow seen by the tails.

    Parameters
    ----------
    optics : BeamOptics
        Beam optics; sets r and z_R.
    weighting : str or Weighting
        A registered weighting (:data:`cwlidar_sim.beam.WEIGHTINGS`):
        'exact': :func:`~cwlidar_sim.beam.weight_exact` (asymmetric about the
        focus, zero behind the telescope); 'lorentzian': A2012 Eq. 4; ...
    span : float
        Half-width of the kept span in Rayleigh lengths [-]; > 0.  The cells
        cover ``[-span z_R, +span z_R]`` around the focus, clipped at the
        telescope (s = -r) for both weightings (no aerosol lies behind the
        telescope, and every weighting is zero there and integrates to 1
        in front of it).  The Lorentzian is Eq. 4 cut at the telescope and
        renormalised, so its truncated fraction is
        :func:`~cwlidar_sim.beam.truncated_fraction_lorentzian`'s only for
        ``r >> span z_R``.
    n_cells : int
        Number of equal cells over the span; >= 1.
    renormalise : bool
        See above.

    Returns
    -------
    RangeCells
        Cell centres ``s_s`` [m], weights ``weight_s`` [-] and the kept and
        truncated weight fractions.
    """
    if not isinstance(optics, BeamOptics):
        raise TypeError(f"optics must be a BeamOptics, got {type(optics).__name__}")
    pv = ProbeVolume(optics, weighting)
    span = check_real("span", span, lo=0.0, hi=1e6, lo_open=True)
    n_cells = check_int("n_cells", n_cells, lo=1, hi=10**7)
    if not isinstance(renormalise, (bool, np.bool_)):
        raise TypeError(f"renormalise must be a bool, got {type(renormalise).__name__}")
    lo, hi = pv.extent(span)
    edges = np.linspace(lo, hi, n_cells + 1)
    cdf = pv.primitive(edges)  # the weight of a cell is exact, from the primitive
    w = np.diff(cdf)
    kept = float(cdf[-1] - cdf[0])
    truncated = pv.truncated_fraction(lo, hi, kept)
    s = 0.5 * (edges[:-1] + edges[1:])
    if renormalise:
        w = w / kept
    return RangeCells(
        s_s=s,
        weight_s=w,
        edges=edges,
        kept_fraction=kept,
        truncated_fraction=truncated,
        renormalised=bool(renormalise),
        weighting=pv.name,
        rayleigh_length=optics.rayleigh_length,
    )
