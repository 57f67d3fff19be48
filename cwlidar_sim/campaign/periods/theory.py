"""The linear functionals of the scenes' instruments: the sensors' own geometry as :mod:`~cwlidar_sim.analysis.linear_theory` looks.

The sensors (:mod:`cwlidar_sim.sensors`) and the theory
(:mod:`cwlidar_sim.analysis`) sit side by side and do not import each other;
this module, above both, reads a sensor's geometry -- its position, beam
directions, focus, probe weighting and optics, its scan schedule -- and
writes the :class:`~cwlidar_sim.analysis.linear_theory.LinearFunctional` of
what a period compares:

* :func:`staring_functionals`: a staring lidar's probe-volume weighted
  line-of-sight speed and a sonic's wind along the same beam (A2012), and
  :func:`staring_transfer_theory` their transfer functions binned as measured;
* :func:`conical_functionals`: a conical lidar's VAD fit of one block of
  revolutions at one height (every sub-dwell look at its own azimuth and
  time, the estimates' mid-azimuths in the fit, as
  :meth:`cwlidar_sim.sensors.ConicalLidar.plan_record` samples them) and a
  cup at that height (first-order response of its distance constant);
* :func:`nacelle_functionals`: a nacelle lidar's REWS estimate over one
  revolution (delays and preview) and a rotor of weighted nodes.
* :func:`node_interpolated_variance`: a point sensor's period variance
  as the simulation reads it, between the box's nodes along x (its own
  line lowered, aliases at the node frequency), through the cup's
  response on its samples.

The field's frame: the mean wind U along +x.  A look's probe is, with
``probe="continuous"`` (default), its beam's continuous weighting
(:func:`cwlidar_sim.analysis.rews_theory.beam_transfer` of the lidar's
``weighting`` with the instrument's optics, over the whole beam); with
``probe="cells"``, what the simulation samples at tier ``los``: the lidar's
range cells (:meth:`cwlidar_sim.sensors.base.LidarBase.probe_cells`: its
span, cell length, growth and tail rule), the sub-points' weights summed
(:func:`cells_probe`; the mean-wind tail carries no fluctuation), kept up to
the sub-points' Nyquist ``pi / d`` and 0 beyond it: their sum's grating lobes
return at ``2 pi / d``, where no field resolved at ``d`` shows the lidar anything.

The nacelle lidar's yaw misalignment turns its beams in the field
(:meth:`cwlidar_sim.sensors.NacelleLidar.yaw_matrix`); a platform motion is
taken where it is a fixed offset and attitude (every sample equal: a tilted
or displaced lidar), refused by name where it moves (the functional would
change with time: no stationary spectrum describes it).
"""

from __future__ import annotations

import math

import numpy as np

from ...analysis import linear_theory as lt
from ...analysis.rews_theory import beam_transfer, scan_beams
from ...beam.cells import ProbeCells
from ...sensors.cup import cup_response
from ..._validation import check_choice, check_int, check_real

#: The looks' probe weightings (module notes).
PROBES = ("continuous", "cells")
#: Most entries of a :func:`cells_probe` table (the sum itself beyond).
_CELLS_TABLE = 200_000


#: The theory already computed in this process, by what it depends on (geometry, tensor, U, T, numerics), not the
#: realisation (:func:`cached`).
_CACHE: dict = {}
_CACHE_SIZE = 32


def cached(key, compute, *, store=None, size=None):
    """``compute()``, once per ``key`` in this process (the oldest of ``_CACHE_SIZE`` entries dropped).

    The periods' theory depends on the scene, not the realisation: every
    period that shares a geometry, tensor, U and duration reuses it.
    ``store`` and ``size``: a module's own cache dict and its size (a
    theory of small results, more entries than a scene's distinct units).
    """
    store = _CACHE if store is None else store
    size = _CACHE_SIZE if size is None else int(size)
    if key not in store:
        if len(store) >= size:
            store.pop(next(iter(store)))
        store[key] = compute()
    return store[key]


def _probe(lidar, instrument):
    """``phi_hat`` of the lidar's weighting at the instrument's focus, with its optics."""
    return beam_transfer(instrument.focus, lidar.weighting, wavelength=instrument.wavelength,
                         radius=instrument.telescope_radius)


def _look_probe(lidar, instrument, probe):
    """``phi_hat`` of a look: the continuous weighting or the simulation's range cells (``probe``)."""
    if check_choice("probe", probe, PROBES) == "cells":
        return _band_limited_cells_probe(lidar, instrument)
    return _probe(lidar, instrument)


class _CellsProbe:
    """``phi_hat(q) = sum_j w_j exp(-i q s_j)`` of range cells' sub-points, tabulated (:func:`cells_probe`)."""

    def __init__(self, cells):
        self.w_j = cells.fraction_j * np.repeat(cells.weight_s, np.diff(cells.ptr_s))
        self.s_j = np.asarray(cells.sub_j, dtype=float)
        length = max(float(np.ptp(cells.edges)), float(cells.cell_length))
        # linear interpolation on steps of 2 pi / (128 L): within 1e-4 of the sum (its phases turn by L q)
        self.dq = 2.0 * np.pi / (128.0 * length)
        n_q = min(int(np.ceil(4.0 * np.pi / float(np.min(np.diff(cells.edges))) / self.dq)), _CELLS_TABLE)
        q = np.arange(n_q + 2) * self.dq
        self.q_max = float(q[-1])
        v = np.concatenate([self._exact(q[i:i + 4096]) for i in range(0, q.size, 4096)])
        self.re, self.im = v.real.copy(), v.imag.copy()

    def _exact(self, q):
        return np.exp(-1j * np.multiply.outer(q, self.s_j)) @ self.w_j

    def __call__(self, q):
        q = np.asarray(q, dtype=float)
        a = np.abs(q).ravel()
        out = np.empty(a.size, dtype=complex)
        inside = a <= self.q_max
        x = a[inside] / self.dq
        i = np.minimum(x.astype(np.int64), self.re.size - 2)
        t = x - i
        out.real[inside] = self.re[i] + t * (self.re[i + 1] - self.re[i])
        out.imag[inside] = self.im[i] + t * (self.im[i + 1] - self.im[i])
        far = np.flatnonzero(~inside)
        for lo in range(0, far.size, 4096):
            out[far[lo:lo + 4096]] = self._exact(a[far[lo:lo + 4096]])
        out = out.reshape(q.shape)
        return np.where(q < 0, np.conj(out), out)


def cells_probe(cells):
    """``phi_hat`` of a lidar's range cells as the simulation samples them at tier ``los`` [-].

    ``phi_hat(q) = sum_j w_j exp(-i q s_j)`` over the cells' sub-points
    ``s_j`` [m] with weights ``w_j`` (the cell's weight times the
    sub-point's share, :meth:`cwlidar_sim.beam.cells.ProbeCells.transfer`);
    the mean-wind tail cell is left out (it sees no fluctuation), so
    ``phi_hat(0)`` is the kept weight (1 for the 'renormalise' rule).
    Tabulated on steps of ``2 pi / (128 L)`` (L the cells' extent: within
    about 1e-4 of the sum) up to ``4 pi / (shortest cell)`` or 200000
    steps, the sum itself beyond.

    Parameters
    ----------
    cells : ProbeCells
        :class:`cwlidar_sim.beam.cells.ProbeCells` (a sensor's ``cells``).

    Returns
    -------
    callable
        ``q [rad/m] -> phi_hat(q)`` (complex, vectorised), a
        :class:`~cwlidar_sim.analysis.linear_theory.Looks` probe.
    """
    if not isinstance(cells, ProbeCells):
        raise TypeError(f"cells must be a ProbeCells, got {type(cells).__name__}")
    return _CellsProbe(cells)


def node_interpolated_variance(k1_k, line_variance_k, mean_speed: float, times_t, dx: float, *, offset: float = 0.0,
                               distance_constant: float | None = None) -> float:
    """A point sensor's within-period variance as simulated: read between the box's nodes along x [m^2 s^-2].

    The simulation reads a point sensor (a cup, a sonic: on a node across
    the wind) by linear interpolation between the box's nodes along x as
    the box is advected past it (position ``offset - U t`` on nodes ``n
    dx``), samples it at ``times_t`` and, for a cup, runs
    :func:`cwlidar_sim.sensors.cup_response` (its first-order step on the
    samples, started at the first) over them.  A line ``exp(i k x)`` of the
    box reaches it lowered (to ``sinc^4(k dx / 2)`` of its variance,
    ``16 / pi^4`` at the Nyquist) with aliases at the node frequency ``U / dx``
    (in all, the mean square ``(2 + cos(k dx)) / 3``) -- which the
    samples fold back coherently -- so each line's sampled series is formed
    as the simulation forms it, and its variance about its own mean (``1 /
    N``) is summed with the line's weight.  The lines are those of a point
    functional (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`
    without a response: density times ``dk1``); the lidars' looks, averaged
    over their probe and the scan, are left to the functionals.

    Parameters
    ----------
    k1_k : array_like
        The box's lines k1 [rad/m], >= 0.
    line_variance_k : array_like
        Each line's variance [m^2 s^-2] (one value per k1).
    mean_speed : float
        U [m/s], > 0.
    times_t : array_like
        The sensor's sample times over the period [s] (uniform, >= 2; a cup's every 0.1 s).
    dx : float
        The box's spacing along x [m], > 0.
    offset : float
        The sensor's x minus a node's at t = 0 [m].
    distance_constant : float, optional
        A cup's distance constant [m] (its response, linear: ``tau = l / U``); None: a sensor without response.

    Returns
    -------
    float
        The expected sample variance about the period's mean [m^2 s^-2].
    """
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    d = check_real("dx", dx, lo=0.0, lo_open=True)
    x0 = check_real("offset", offset)
    k = np.asarray(k1_k, dtype=float).ravel()
    var_k = np.asarray(line_variance_k, dtype=float).ravel()
    if k.shape != var_k.shape or k.size < 1 or np.any(k < 0) or not np.all(np.isfinite(var_k)):
        raise ValueError("k1_k must be wavenumbers >= 0 [rad/m] with one finite line_variance_k value each")
    t = np.asarray(times_t, dtype=float).ravel()
    if t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError("times_t must be >= 2 increasing sample times [s]")
    if distance_constant is not None:
        distance_constant = check_real("distance_constant", distance_constant, lo=0.0, lo_open=True)
    s = (x0 - U * t) / d
    n = np.floor(s)
    f = s - n
    total = 0.0
    for k_i, v_i in zip(k, var_k):
        g = np.exp(1j * k_i * d * n) * ((1.0 - f) + f * np.exp(1j * k_i * d))
        if distance_constant is not None:
            g = (cup_response(g.real, t[1] - t[0], distance_constant, mean_speed=U)
                 + 1j * cup_response(g.imag, t[1] - t[0], distance_constant, mean_speed=U))
        total += v_i * float(np.mean(np.abs(g - g.mean()) ** 2))
    return total


class _Average:
    """``H(omega) = sum_j a_j exp(i omega t_j)``: a look's value averaged over samples at ``t + t_j`` [-]."""

    def __init__(self, times_j, weights_j):
        self.t_j = np.asarray(times_j, dtype=float).ravel()
        self.a_j = np.asarray(weights_j, dtype=float).ravel()
        if self.t_j.size < 1 or self.t_j.shape != self.a_j.shape or not np.all(np.isfinite(self.t_j)) \
                or not np.all(np.isfinite(self.a_j)):
            raise ValueError("an average must be (times_j [s], weights_j [-]): finite, one weight per time")

    def __call__(self, omega):
        return np.exp(1j * np.multiply.outer(np.asarray(omega, dtype=float), self.t_j)) @ self.a_j


class _BandLimitedCells(_CellsProbe):
    """:class:`_CellsProbe` tabulated up to ``q_max`` [rad/m] only, 0 beyond it (every look's ``probe="cells"``).

    The same table steps (its values equal ``cells_probe``'s there), a
    quarter of its length at the sub-points' Nyquist.
    """

    def __init__(self, cells, q_max):
        self.w_j = cells.fraction_j * np.repeat(cells.weight_s, np.diff(cells.ptr_s))
        self.s_j = np.asarray(cells.sub_j, dtype=float)
        length = max(float(np.ptp(cells.edges)), float(cells.cell_length))
        self.dq = 2.0 * np.pi / (128.0 * length)
        q = np.arange(int(np.ceil(q_max / self.dq)) + 2) * self.dq
        self.q_max = float(q_max)
        v = np.concatenate([self._exact(q[i:i + 4096]) for i in range(0, q.size, 4096)])
        self.re, self.im = v.real.copy(), v.imag.copy()

    def __call__(self, q):
        q = np.asarray(q, dtype=float)
        out = np.zeros(q.shape, dtype=complex)
        inside = np.abs(q) <= self.q_max
        out[inside] = super().__call__(q[inside])
        return out


def _band_limited_cells_probe(lidar, instrument):
    """The lidar's range cells band-limited at their sub-points' Nyquist, once per cells in a process (:func:`cached`).

    A plain table the fused kernel of :mod:`cwlidar_sim.analysis.linear_theory`
    takes (the unlimited sum's grating lobes fail its table check and send
    the whole theory to the numpy path: a nacelle period's theory 71 s of
    CPU per focus).
    """
    key = ("cells_probe", repr(instrument), lidar.weighting, lidar.span, lidar.cell_length, lidar.cell_growth,
           lidar.tail)

    def make():
        cells = lidar.probe_cells(instrument)
        sub = np.unique(np.asarray(cells.sub_j, dtype=float))
        return _BandLimitedCells(cells, np.pi / float(np.min(np.diff(sub))) if sub.size > 1 else 1e3)

    return cached(key, make)


def staring_functionals(lidar, sonic_position, *, probe: str = "continuous", lidar_average=None,
                        sonic_average=None):
    """A staring lidar's line-of-sight speed and a sonic's wind along the same beam, as linear functionals.

    Parameters
    ----------
    lidar : StaringLidar
        The lidar (:class:`cwlidar_sim.sensors.StaringLidar`), in the field's frame.
    sonic_position : (x, y, z)
        The sonic's position [m].
    probe : {"continuous", "cells"}
        The beam's weighting or the simulation's range cells (module notes).
        The cells' sum over sub-points ``d`` apart is periodic in q (its
        grating lobes return to ``|phi_hat| = 1`` at ``2 pi / d``), which a
        field resolved at ``d`` never shows the lidar: it is kept up to the
        sub-points' Nyquist ``pi / d`` and set to 0 beyond.
    lidar_average, sonic_average : (times_j, weights_j), optional
        A reading that is the weighted sum of samples at ``t + t_j`` [s]
        (the staring period's 50 Hz looks block-averaged to 10 Hz, the
        sonic's 32 Hz samples resampled by A2012 Eqs. 5-7): the look's time
        filter ``H(omega) = sum_j a_j exp(i omega t_j)``; None: one sample.

    Returns
    -------
    (LinearFunctional, LinearFunctional)
        Outputs ``"lidar"`` (``n . u`` averaged by the probe weighting about
        the focus) and ``"sonic"`` (``n . u`` at the sonic), n the beam's
        direction (the lidar's sign: positive away from the telescope).
    """
    inst = lidar.instrument
    n = np.asarray(lidar.direction, dtype=float)
    focus = np.asarray(lidar.position, dtype=float) + inst.focus * n
    phi = _look_probe(lidar, inst, probe)
    h_l = None if lidar_average is None else _Average(*lidar_average)
    h_s = None if sonic_average is None else _Average(*sonic_average)
    beam = lt.lidar_functional(lt.Looks([focus], [n], None, phi, h_l), [1.0], ["lidar"])
    sonic = lt.LinearFunctional(lt.Looks(np.asarray(sonic_position, dtype=float).reshape(1, 3), [n], None, None, h_s),
                                n.reshape(1, 1, 3), ["sonic"])
    return beam, sonic


#: The staring transfer theory's numerics: k1 per decade of its grid, the polar quadrature's resolution
#: (:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`).  A2012 period C, bins below 0.5 rad/m: 24 per
#: decade are within 2.6e-4 of 48 (12: 1.3e-3, 8: 3.7e-3); resolutions 8, 15 and 30 agree within 2e-6.
STARING_PER_DECADE = 24
STARING_RESOLUTION = 8.0


def staring_transfer_theory(lidar, sonic_position, params, mean_speed: float, k_edges, *, segment_duration: float,
                            sample_rate: float, lidar_average=None, sonic_average=None, probe: str = "cells",
                            window: str = "hann", per_decade: int = STARING_PER_DECADE,
                            resolution: float = STARING_RESOLUTION, plane=None) -> dict:
    """The expected A2012 transfer functions (methods 1 and 2) of a staring lidar against a sonic, binned as measured.

    The spectra of :func:`staring_functionals` (continuum, frozen Taylor
    field, the beam's direction and probe, the sonic's position, both
    readings' time filters) on a log grid of ``per_decade`` k1 per decade;
    each periodogram value's expectation at its own wavenumber ``k_n = 2 pi
    n / (U T_seg)`` (the spectra smoothed by the segment window's kernel:
    its leakage and the probe's reach beyond the segment's ends), up to
    the Nyquist of ``sample_rate``, averaged over each bin of ``k_edges``
    as :func:`cwlidar_sim.analysis.transfer_functions` averages the raw
    values; then ``F_vr / F_vs`` (A2012 Eq. 8) and ``Re(chi)^2 / F_vs^2``
    (Eq. 11) of the bin means.  The spectra are interpolated log-log (the
    sonic's and the lidar's over it) and linearly in ln k1 (the
    cross-spectrum over the sonic's), held flat below the grid.  The
    field's own lines along x (a generated field's length instead of the
    continuum in k1) move these bins by < 1e-4 with a Hann window (A2012
    period C), so the continuum is kept.
    Not included: the sampling's aliasing, the mean's (or a line's)
    removal before the window (the lowest bins), the estimator (tier
    ``los``'s statistic).  Computed once per geometry, tensor, U and grid in a
    process (:func:`cached`; the lidar moved to the origin with the sonic).

    Parameters
    ----------
    lidar : StaringLidar
    sonic_position : (x, y, z)
        [m], in the lidar's frame.
    params : MannParameters
    mean_speed : float
        U [m/s], > 0.
    k_edges : array_like
        Bin edges [rad/m], increasing.
    segment_duration, sample_rate : float
        The spectra's segment [s] and the series' rate [Hz].
    lidar_average, sonic_average, probe
        As :func:`staring_functionals`.
    window : {"hann", "none"}
        The segments' window (``analysis.window``): the kernel is its
        ``|W|^2``, normalised as :func:`cwlidar_sim.analysis.segment_spectra`
        normalises (Hann's sidelobes fall as the sixth power: almost no
        leakage; none: the Fejer kernel's second power).
    per_decade : int
        The theory's k1 per decade (>= 4).
    resolution : float
        The polar quadrature's inner disc (:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`).
    plane : (shape, spacing, origin), optional
        The generated plane the period flies through (``generate_plane``'s
        ``(Nx, Ny)``, ``(dx, dy)`` [m], and the telescope's ``(x, y)`` [m]
        in it): the spectra are then its lattice
        (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`, on
        the plane's rows nearest the log grid), the beam's range cells
        expanded into their sub-points, each and the sonic read bilinearly
        across y from the plane's nodes as the simulation reads them (along
        x the reading's gain is common to both and their aliases lie above
        the series' Nyquist: x is taken on the modes); ``probe`` must be
        ``"cells"``.

    Returns
    -------
    dict
        ``F_r_k``, ``F_s_k`` [m^3 s^-2], ``chi_k`` (complex), ``transfer_ratio_k``,
        ``transfer_cross_k`` [-] per bin (NaN where it holds no wavenumber).
    """
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    T = check_real("segment_duration", segment_duration, lo=0.0, lo_open=True)
    fs = check_real("sample_rate", sample_rate, lo=0.0, lo_open=True)
    nd = check_int("per_decade", per_decade, lo=4, hi=1000)
    e = np.asarray(k_edges, dtype=float).ravel()
    if e.size < 2 or not np.all(np.isfinite(e) & (e > 0)) or np.any(np.diff(e) <= 0):
        raise ValueError("k_edges must be >= 2 increasing wavenumbers > 0 [rad/m]")
    pos = np.asarray(lidar.position, dtype=float)
    rel = tuple(float(x) for x in np.asarray(sonic_position, dtype=float) - pos)
    at0 = lidar.replace(position=(0.0, 0.0, 0.0))
    avg = tuple(None if a is None else tuple(tuple(float(x) for x in np.ravel(b)) for b in a)
                for a in (lidar_average, sonic_average))
    window = check_choice("window", window, ("hann", "none"))
    if plane is not None:
        if probe != "cells":
            raise ValueError(f"probe must be 'cells' with a plane's lattice (its sub-points are read), got {probe!r}")
        shape, spacing, origin = plane
        plane = (tuple(int(n) for n in shape), tuple(float(d) for d in spacing),
                 tuple(float(x) for x in np.ravel(origin)[:2]))
    key = ("staring_transfer", repr(at0), rel, repr(params), U, tuple(e), T, fs, avg, probe, window, nd,
           float(resolution)) + (() if plane is None else (plane,))
    return cached(key, lambda: _staring_transfer(at0, rel, params, U, e, T, fs, lidar_average, sonic_average, probe,
                                                 window, nd, resolution, plane))


def _window_kernel(x, window):
    """``|W(x)|^2 / integral |W|^2`` of the segment's window at ``x = (k - k_n) / dk`` [-] (unit integral in x)."""
    if window == "none":
        return np.sinc(x) ** 2
    return (0.5 * np.sinc(x) + 0.25 * np.sinc(x - 1.0) + 0.25 * np.sinc(x + 1.0)) ** 2 / 0.375


def _cells_points(lidar, lidar_average):
    """The staring beam as point looks at its range cells' sub-points (weights as :func:`cells_probe`'s)."""
    cells = lidar.probe_cells(lidar.instrument)
    w_j = cells.fraction_j * np.repeat(cells.weight_s, np.diff(cells.ptr_s))
    n = np.asarray(lidar.direction, dtype=float)
    pts = np.asarray(lidar.position, dtype=float) + np.multiply.outer(np.maximum(lidar.instrument.focus + np.asarray(
        cells.sub_j, dtype=float), 0.0), n)
    h = None if lidar_average is None else _Average(*lidar_average)
    return lt.lidar_functional(lt.Looks(pts, np.repeat(n[None], w_j.size, axis=0), None, None, h), w_j, ["lidar"])


def _staring_transfer(lidar, sonic_position, params, U, e, T, fs, lidar_average, sonic_average, probe, window, nd,
                      resolution, plane=None):
    from scipy.signal import fftconvolve

    from ...analysis.spectra import bin_average

    n_per = int(round(T * fs))
    k_nyq = np.pi * fs / U
    dk = 2.0 * np.pi / (U * n_per / fs)  # the periodogram's spacing in k1
    k_n = np.arange(1, n_per // 2 + 1) * dk
    k_n = k_n[(k_n >= e[0]) & (k_n < e[-1])]
    nan = np.full(e.size - 1, np.nan)
    if k_n.size == 0:
        return {"F_r_k": nan, "F_s_k": nan, "chi_k": nan + 0j, "transfer_ratio_k": nan, "transfer_cross_k": nan}
    lo, hi = np.log10(0.25 * dk), np.log10(k_nyq)
    k = np.logspace(lo, hi, max(int(np.ceil((hi - lo) * nd)) + 1, 2))
    beam, sonic = staring_functionals(lidar, sonic_position, probe=probe, lidar_average=lidar_average,
                                      sonic_average=sonic_average)
    if plane is None:
        s = lt.functional_spectra(k, params, [beam, sonic], U, resolution=resolution)
    else:
        shape, spacing, origin = plane
        dk1 = 2.0 * np.pi / (shape[0] * spacing[0])
        rows = np.unique(np.clip(np.rint(k / dk1).astype(np.int64), 1, shape[0] // 2))
        s = lt.lattice_spectra(params, [_cells_points(lidar, lidar_average), sonic], U, shape, spacing, rows=rows,
                               interpolation=("none", "linear"), origin=origin)
        k = s.k1_k
    F_s, F_r, chi = s.spectrum("1.sonic"), s.spectrum("0.lidar"), s.cross("0.lidar", "1.sonic")
    lk = np.log(k)

    def on(kk):  # (F_r, F_s, Re chi, Im chi) at |kk|, Hermitian in the sign of kk, held flat below the grid
        lg = np.log(np.maximum(np.abs(kk), k[0]))
        f_s = np.exp(np.interp(lg, lk, np.log(F_s)))
        return np.stack([f_s * np.exp(np.interp(lg, lk, np.log(F_r / F_s))), f_s, f_s * np.interp(lg, lk, chi.real / F_s),
                         np.sign(kk) * f_s * np.interp(lg, lk, chi.imag / F_s)])

    # each periodogram value's expectation: the spectra through the window's kernel (1 / dk) K((q - k_n) / dk)
    # (the continuum on a grid of dk / 8 over (-k_nyq, k_nyq): a convolution)
    h = dk / 8.0
    m = int(np.floor(k_nyq / h))
    rows = on(np.arange(-m, m + 1) * h)
    kern = (h / dk) * _window_kernel(np.arange(-2 * m, 2 * m + 1) * h / dk, window)  # unit sum
    smooth = np.stack([fftconvolve(r, kern)[2 * m:4 * m + 1] for r in rows])
    sm = smooth[:, m + np.rint(k_n / h).astype(np.int64)]
    raw = np.stack([sm[0], sm[1], sm[2] + 1j * sm[3]])
    mean_ck, _ = bin_average(k_n, raw, e)
    Fr, Fs, c = mean_ck[0].real, mean_ck[1].real, mean_ck[2]
    with np.errstate(invalid="ignore", divide="ignore"):
        return {"F_r_k": Fr, "F_s_k": Fs, "chi_k": c, "transfer_ratio_k": Fr / Fs, "transfer_cross_k": c.real ** 2 / Fs ** 2}


def conical_functionals(lidar, height: float, mean_speed: float, *, revolutions: int = 1, cup=None,
                        probe: str = "continuous"):
    """A conical lidar's VAD fit (u, v, w) of ``revolutions`` at one height, and a cup there, as linear functionals.

    The looks: each estimate of the first block of ``revolutions`` at
    ``height`` in the lidar's schedule (:meth:`~cwlidar_sim.sensors.ConicalLidar.schedule`)
    is the mean of its ``sub_dwells`` looks at their own azimuths and times;
    the fit uses the estimates' mid-azimuths (the simulation's VAD).  Times
    are taken from the block's middle.

    Parameters
    ----------
    lidar : ConicalLidar
        The lidar (:class:`cwlidar_sim.sensors.ConicalLidar`), in the field's frame.
    height : float
        One of ``lidar.heights`` [m].
    mean_speed : float
        U [m/s] (the cup's time constant ``l / U``).
    revolutions : int
        Revolutions per fit, >= 1 (at most ``revs_per_height`` for a lidar
        cycling through several heights).
    cup : Cup, optional
        The cup (:class:`cwlidar_sim.sensors.Cup`: its position and distance
        constant); None: no cup.
    probe : {"continuous", "cells"}
        The beams' weighting or the simulation's range cells (module notes).

    Returns
    -------
    LinearFunctional or (LinearFunctional, LinearFunctional)
        The fit's outputs ``"u"``, ``"v"``, ``"w"``; with a cup, also its ``"u"``.
    """
    z = check_real("height", height)
    if z not in tuple(lidar.heights):
        raise ValueError(f"height={height!r} m is not one of the lidar's heights {tuple(lidar.heights)}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    n_rev = check_int("revolutions", revolutions, lo=1, hi=1000)
    if len(lidar.heights) > 1 and n_rev > lidar.revs_per_height:
        raise ValueError(f"revolutions={revolutions} exceeds a block of {lidar.revs_per_height} revolutions per "
                         f"height of a lidar cycling through {len(lidar.heights)} heights; allowed: 1 .. "
                         f"{lidar.revs_per_height}")
    ih = tuple(lidar.heights).index(z)
    n_e = n_rev * lidar.estimates_per_rev
    block = lidar.revs_per_height * lidar.revolution_time + lidar.refocus_time
    sch = lidar.schedule(len(lidar.heights) * block + n_rev * lidar.revolution_time)
    idx = np.flatnonzero(sch.focus_index_e == ih)[:n_e]
    t_e, az_e = sch.time_e[idx], sch.azimuth_e[idx]
    nsub = lidar.sub_dwells
    off_s = (np.arange(nsub) + 0.5) / nsub - 0.5  # as ConicalLidar.plan_record: the looks within a dwell
    t_l = (t_e[:, None] + off_s[None, :] * lidar.dwell_time).ravel()
    az_l = (az_e[:, None] + off_s[None, :] * lidar.dwell_angle_deg).ravel()
    n_lc = np.asarray(lidar.direction(az_l), dtype=float).reshape(-1, 3)
    inst = lidar.instrument_at(z)
    focus_lc = np.asarray(lidar.position, dtype=float)[None, :] + inst.focus * n_lc
    looks = lt.Looks(focus_lc, n_lc, t_l - 0.5 * (t_e[0] + t_e[-1]), _look_probe(lidar, inst, probe))
    coef_oe = np.linalg.pinv(np.asarray(lidar.direction(az_e), dtype=float).reshape(-1, 3))  # the fit of estimates
    vad = lt.lidar_functional(looks, np.repeat(coef_oe, nsub, axis=1) / nsub, ["u", "v", "w"])
    if cup is None:
        return vad
    return vad, lt.point_functional(cup.position, ("u",), response=lt.first_order_response(cup.distance_constant / U))


def _nacelle_frame(lidar):
    """``(origin, R, R_known)``: the lidar's position, the nacelle frame's axes in the field, the known attitude.

    The yaw misalignment, and a platform motion that holds one offset and
    attitude (module notes); a moving platform is refused by name.
    """
    yaw = lidar.yaw_matrix()
    origin = np.asarray(lidar.position, dtype=float)
    m = lidar.motion
    if m is None:
        return origin, yaw, np.eye(3)
    moving = [k for k in ("surge", "sway", "heave", "roll_deg", "pitch_deg", "yaw_deg") if np.ptp(getattr(m, k)) > 0]
    if moving:
        raise ValueError(f"lidar.motion: a platform that moves ({', '.join('motion.' + k for k in moving)} vary) "
                         "makes the lidar's looks change with time, which no stationary linear functional describes; "
                         "allowed: motion None, or one fixed offset and attitude (every sample equal)")
    d, _, rot = m.at(np.array([m.time[0]]))
    return origin + d[0], yaw @ rot[0], (rot[0] if lidar.motion_correction else np.eye(3))


def nacelle_functionals(lidar, focus: float, mean_speed: float, rotor_nodes, *, n_beams: int | None = 8,
                        preview_shift: float | None = None, probe: str = "continuous", phase: int = 0):
    """A nacelle lidar's REWS estimate over one revolution and a rotor of weighted nodes, as linear functionals.

    With ``n_beams`` N: the scan as :func:`cwlidar_sim.analysis.rews_theory.scan_beams`
    discretises the lidar's cone (its geometry, revolution time and first
    azimuth, in the nacelle frame, the hub at the origin): N beams evenly
    over the revolution, beam b's sample ``tau_b = (N - 1 - b) T / N`` old
    when the estimate is formed (the phase after the last beam); each beam's
    line-of-sight speed enters as ``v_b / m_bx`` with weight 1/N.  With
    ``n_beams=None``: the simulation's own looks
    (:meth:`cwlidar_sim.sensors.NacelleLidar.plan_record`): the first
    revolution at ``focus`` of the lidar's schedule, ``estimates_per_rev``
    estimates of ``sub_dwells`` looks each at their azimuths and times, each
    estimate's mean line-of-sight speed over the x component of its looks'
    mean known direction, averaged over the revolution (the period's
    trailing revolution mean), formed at the last estimate's time; with
    ``phase`` j, the revolution of estimates j .. j + estimates_per_rev - 1
    (the scan's azimuths turned by j dwells against the looks' ages).  The
    trailing mean at full rate is cyclostationary: its period statistics
    are the average over the ``estimates_per_rev`` phases' spectra (on the
    bundled scene at 100 m one phase's variance differs from that average
    by up to 3 %; studies/theory_vs_simulation.py).  Either
    way the beams are turned by the yaw misalignment (and a fixed platform
    attitude: module notes) in the field, the known directions (``m``) are
    the nacelle frame's, and the estimate is shifted by the preview
    ``preview_shift`` [s] (default ``r cos a / U``, the focus's upwind
    distance).

    Parameters
    ----------
    lidar : NacelleLidar
        The lidar (:class:`cwlidar_sim.sensors.NacelleLidar`); its ``position`` relative to the hub.
    focus : float
        One of ``lidar.focus_distances`` [m].
    mean_speed : float
        U [m/s].
    rotor_nodes : (y_n, z_n, w_n)
        The rotor's nodes in the rotor plane (x = 0) relative to the hub [m]
        and their weights (summing to 1).
    n_beams : int or None
        N >= 1, or None: the simulation's looks.
    preview_shift : float, optional
        The shift of the estimate [s].
    probe : {"continuous", "cells"}
        The beams' weighting or the simulation's range cells (module notes).
    phase : int
        The first estimate of the revolution (``n_beams=None`` only), >= 0;
        the revolution must not cross a refocus.

    Returns
    -------
    (LinearFunctional, LinearFunctional)
        Outputs ``"rotor"`` (the nodes' weighted u) and ``"lidar"``.
    """
    r = check_real("focus", focus)
    if r not in tuple(lidar.focus_distances):
        raise ValueError(f"focus={focus!r} m is not one of the lidar's focus_distances {tuple(lidar.focus_distances)}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    n = None if n_beams is None else check_int("n_beams", n_beams, lo=1, hi=10_000)
    y_n, z_n, w_n = (np.asarray(a, dtype=float).ravel() for a in rotor_nodes)
    if not (y_n.size == z_n.size == w_n.size) or abs(w_n.sum() - 1.0) > 1e-9:
        raise ValueError("rotor_nodes must be (y_n, z_n, w_n) of one length with weights summing to 1")
    j0 = check_int("phase", phase, lo=0, hi=10**6)
    if n is not None and j0 != 0:
        raise ValueError(f"phase={phase!r} needs n_beams=None (the simulation's looks); allowed: 0 with n_beams")
    shift = lidar.preview_distance(r) / U if preview_shift is None else check_real("preview_shift", preview_shift)
    inst = lidar.instrument_at(r)
    origin, rot, known = _nacelle_frame(lidar)
    if n is not None:
        beams = scan_beams(lidar.geometry, n, r, all_phases=False, origin=(0.0, 0.0, 0.0))
        m_lc, coef_l = beams.direction_bc, beams.weight_b / (beams.direction_bc @ known.T)[:, 0]
        # the look sees u_0(p - U (t + t_l) e1): a sample tau_b old and shifted by T is taken at t_l = -(T + tau_b)
        t_l = -(shift + beams.delay_pb[0])
    else:
        i = tuple(lidar.focus_distances).index(r)
        nf, epr, nsub = len(lidar.focus_distances), lidar.estimates_per_rev, lidar.sub_dwells
        cycle = nf * (lidar.revs_per_focus * lidar.revolution_time + (lidar.refocus_time if nf > 1 else 0.0))
        time_e, az_e, fidx_e, _ = lidar.schedule(cycle * (1 + math.ceil(j0 / (lidar.revs_per_focus * epr))))
        idx = np.flatnonzero(fidx_e == i)[j0:j0 + epr]
        if idx.size != epr or np.any(np.diff(idx) != 1):
            raise ValueError(f"phase={phase!r}: the revolution of estimates {j0} .. {j0 + epr - 1} at focus {r:g} m "
                             f"crosses a refocus (revs_per_focus = {lidar.revs_per_focus} of {nf} focus distances); "
                             f"allowed: 0 .. {lidar.revs_per_focus * epr - epr if nf > 1 else 'any'}")
        off = (np.arange(nsub) + 0.5) / nsub - 0.5  # as NacelleLidar.plan_record: the looks within a dwell
        dang = 360.0 / epr if lidar.circle else 0.0
        t_el = time_e[idx, None] + off[None, :] * lidar.dwell_time
        m_elc = lidar.nacelle_direction(az_e[idx, None] + off[None, :] * dang)
        mx_e = (m_elc @ known.T).mean(axis=1)[:, 0]  # the x of the estimate's mean known direction
        m_lc = m_elc.reshape(-1, 3)
        coef_l = np.repeat(1.0 / (epr * nsub * mx_e), nsub)
        t_l = (t_el - time_e[idx[-1]]).ravel() - shift
    n_lc = m_lc @ rot.T
    looks = lt.Looks(origin[None, :] + r * n_lc, n_lc, t_l, _look_probe(lidar, inst, probe))
    est = lt.lidar_functional(looks, coef_l, ["lidar"])
    rotor_looks = lt.Looks(np.stack([0.0 * y_n, y_n, z_n], axis=1), np.tile([1.0, 0.0, 0.0], (y_n.size, 1)))
    rotor = lt.LinearFunctional(rotor_looks, w_n[None, :, None] * np.array([1.0, 0.0, 0.0]), ["rotor"])
    return rotor, est
