"""The WindScanner's and the SpinnerLidar's linear theory: their estimates as :mod:`~cwlidar_sim.analysis.linear_theory` functionals.

Beside :mod:`cwlidar_sim.campaign.periods.theory` (the staring, conical and nacelle lidars), above the
sensors and the analysis, this module reads a
:class:`~cwlidar_sim.sensors.windscanner.WindScanner`'s or a
:class:`~cwlidar_sim.sensors.spinner.SpinnerLidar`'s geometry and schedule and
writes the :class:`~cwlidar_sim.analysis.linear_theory.LinearFunctional` of
what its period compares:

* :func:`windscanner_functionals`: the reconstructed (u, v, w), the
  reconstruction matrix ``N^-1`` (:func:`cwlidar_sim.analysis.reconstruction.reconstruct_uvw`)
  applied to the three units' probe-weighted line-of-sight speeds, each unit
  at its own range and clock offset (so every component carries the others'
  cross-contamination through the beams' weightings); for a held point, or
  averaged over one Lissajous pattern; and a sonic (u, v, w) at the target;
* :func:`windscanner_theory`: from them, each component's A2012 transfer
  functions against the sonic's, method 1 ``F_rr / F_ss`` and method 2
  ``Re(F_rs)^2 / F_ss^2`` (:func:`cwlidar_sim.analysis.transfer_functions`'s
  definitions), and the ratio of the reconstructed w's variance within a
  period to the sonic's;
* :func:`windscanner_lattice_variances`: the reconstructed and the sonic's
  within-period variances over a box's lattice, read as the simulation
  reads them (the range cells trilinearly, the sonic between its nodes,
  :func:`node_sonic`): the std ratios' acceptance
  (studies/theory_vs_simulation.py ``--kind windscanner``);
* :func:`spinner_functionals`: the SpinnerLidar's REWS estimate of one
  rosette, the disc fit's ``u0`` (:func:`cwlidar_sim.analysis.disc_fit.fit_disc`,
  a linear least squares: its row of the pseudo-inverse of the design,
  without ``du/dy``, ``w0`` dropped when ``w = 0`` is assumed) over the
  rosette's looks with their probe weighting, taken the preview earlier; and
  the rotor's REWS along its axis, a disc average of ``u cos gamma + v sin
  gamma`` on polar nodes;
* :func:`spinner_theory`: their coherence.

The field's frame: the mean wind U along +x; frozen turbulence (Taylor).  A
look's probe is its beam's continuous weighting
(:func:`cwlidar_sim.analysis.rews_theory.beam_transfer` of the lidar's
``weighting`` with the instrument's optics, as :mod:`cwlidar_sim.campaign.periods.theory` takes it),
not the simulation's discrete range cells (``probe="cells"``: those); the field is the continuum's
(:func:`~cwlidar_sim.analysis.linear_theory.functional_spectra`) unless a
box's lattice is asked for (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`).
Not included: evolving turbulence, the platform's motion, the chain's noise
and estimators (the theory is tier ``los``'s), the box's trilinear
interpolation (except :func:`windscanner_lattice_variances`).

The periods' theory (:func:`windscanner_variables`, :func:`windscanner_std_ratio_variables`,
:func:`spinner_variables`)
depends on the scene, not the realisation: it is computed once per geometry,
tensor, U (and T) in a process and reused by every period that shares them.
Its cost is cut where the cut is measured to be small:

* WindScanner: the spectra at the bins' centres, ``resolution`` 20 (60
  moves the published layout's transfer functions by < 1e-4), and for the
  w-variance ratio 3 more below them and, where the bins stop short of 1
  rad/m, 3 up to it; above, each spectrum's last power law (the
  quadrature's nodes grow with k: the old tail to 20 rad/m was most of
  the cost; the ratio moves by 0.7 %);
* SpinnerLidar: every 4th estimate of the rosette (the fit over those),
  the rotor's disc on 12 x 32 nodes, one look per dwell, ``resolution``
  20: on the bundled scene's frozen periods (aligned and yawed, 0.005 to
  0.125 rad/m) the coherence moves by at most 0.008 from every estimate's
  with 24 x 64 nodes, at a quarter of the cost.
"""

from __future__ import annotations

import math

import numpy as np

from ...analysis import linear_theory as lt
from ...analysis.disc_fit import disc_design
from ...analysis.spectra import bin_average, segment_spectra
from ..._validation import check_int, check_real
from .theory import _band_limited_cells_probe, _probe, cached, node_interpolated_variance

__all__ = ["windscanner_functionals", "windscanner_theory", "windscanner_lattice_variances", "node_sonic",
           "spinner_functionals", "spinner_theory",
           "rotor_disc_nodes", "windscanner_variables", "windscanner_std_ratio_variables", "spinner_variables",
           "spinner_k_edges"]

#: Wavenumbers of each coarse tail of the w-variance ratio's spectra, below and above the asked k1 (log-spaced from 1e-4
#: rad/m; log-log interpolated between).
_W_TAIL = 4
#: Up to where [rad/m] the w-variance ratio's spectra are computed (a coarse log grid above the asked k1 when
#: they stop short of it); above it each spectrum's last power law: stopping at 0.3 rad/m instead puts the published
#: layout's ratio (160 s) 15 % low, stopping at 1 rather than 20 rad/m moves it by 0.7 %.
_W_TOP = 1.0
#: The polar quadrature's resolution of the periods' theory (20 and 60 agree to 1e-4 in the published layout's
#: transfer functions, 0.01 .. 1 rad/m).
_RESULTS_RESOLUTION = 20.0
#: Coherence bins of a spinner period.
_SPINNER_BINS = 8
#: The spinner periods' theory: every 4th estimate of the rosette, the rotor's disc on 12 x 32 nodes.
_SPINNER_STRIDE, _SPINNER_ROTOR = 4, (12, 32)

# --------------------------------------------------------------------------
# WindScanner
# --------------------------------------------------------------------------
def windscanner_functionals(scanner, *, probe: bool | str = True):
    """The WindScanner's reconstructed wind and a sonic at its target, as linear functionals (module notes).

    Held point (``pattern = 'point'``): unit i looks along ``n_i`` at the
    target, focused at its range ``r_i``, at the time offset
    ``time_offsets[i]`` from the common clock; the outputs are ``N^-1 v``
    with ``N`` the directions' matrix (rows ``n_i``) and ``v_i`` the probe-
    weighted line-of-sight speeds.  Lissajous: the mean over one pattern
    of each point's reconstruction (its own ``N_k^-1``, its looks at their
    ranges, directions and times, taken from the pattern's middle).

    Parameters
    ----------
    scanner : WindScanner
        The scanner (:class:`cwlidar_sim.sensors.windscanner.WindScanner`), in the field's frame.
    probe : bool or {"continuous", "cells"}
        The beams' continuous weighting (True, ``"continuous"``), the
        simulation's range cells at tier ``los`` (``"cells"``, band-limited
        at their sub-points' Nyquist as :mod:`~cwlidar_sim.campaign.periods.theory`
        takes them) or points at the foci (False: ``z_R -> 0``).

    Returns
    -------
    (LinearFunctional, LinearFunctional)
        The reconstruction's and the sonic's outputs ``"u"``, ``"v"``, ``"w"``.
    """
    if probe not in (True, False, "continuous", "cells"):
        raise ValueError(f"probe must be True, False, 'continuous' or 'cells', got {probe!r}")
    n_kic = scanner.directions()
    r_ki = scanner.ranges()
    focus_kc = scanner.focus_points()
    P = n_kic.shape[0]
    rate = scanner.instrument.estimate_rate
    t_k = (np.arange(P) + 0.5) / rate - 0.5 * P / rate
    coef = np.linalg.inv(n_kic) / P  # (P, 3 outputs, 3 units): the reconstruction, averaged over the pattern
    probes = {}
    pts, dirs, times, prb, coef_ol = [], [], [], [], []
    for i in range(3):
        for k in range(P):
            pts.append(focus_kc[k])
            dirs.append(n_kic[k, i])
            times.append(t_k[k] + scanner.time_offsets[i])
            if probe:
                r = float(round(r_ki[k, i], 9))
                if r not in probes:
                    inst = scanner.instrument_at(r)
                    probes[r] = (_band_limited_cells_probe(scanner, inst) if probe == "cells"
                                 else _probe(scanner, inst))
                prb.append(probes[r])
            coef_ol.append(coef[k, :, i])
    looks = lt.Looks(np.array(pts), np.array(dirs), np.array(times), prb if probe is not False else None)
    recon = lt.lidar_functional(looks, np.array(coef_ol).T, ["u", "v", "w"])
    return recon, lt.point_functional(scanner.target, ("u", "v", "w"))


def windscanner_theory(scanner, params, mean_speed: float, k1, *, period: float | None = None,
                       lattice=None, resolution: float = 60.0, probe: bool = True) -> dict:
    """Each reconstructed component's transfer functions against the sonic, and the w-variance ratio (module notes).

    Parameters
    ----------
    scanner : WindScanner
    params : MannParameters
    mean_speed : float
        U [m/s], > 0.
    k1 : array_like
        Wavenumbers [rad/m], > 0, increasing (at least 2 for ``period``).
    period : float, optional
        Period [s]: also the expected ratio of the reconstructed w's variance
        within it (samples every ``1 / estimate_rate``, mean removed) to the
        sonic's, from the spectra at ``k1`` and on coarse log grids from
        1e-4 rad/m up to them and from them up to 1 rad/m, each extended
        above by its last power law (the quadrature's cost grows with k;
        the reconstructed w holds little variance there).
    lattice : (shape, spacing), optional
        A box's grid: the spectra as that box holds them
        (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`, on its
        own rows nearest ``k1``); default the continuum.
    resolution : float
        The polar quadrature's resolution (continuum only).
    probe : bool
        The beams' weighting, or points at the foci.

    Returns
    -------
    dict
        ``k1`` [rad/m]; ``ratio_ck``, ``cross_ck`` (components u, v, w by
        k) [-]; ``spectra`` (the :class:`~cwlidar_sim.analysis.linear_theory.FunctionalSpectra`,
        outputs ``0.u .. 0.w`` reconstructed, ``1.u .. 1.w`` sonic); with
        ``period``, ``w_variance_ratio`` [-].
    """
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    fs = windscanner_functionals(scanner, probe=probe)
    k = np.array(k1, dtype=float, ndmin=1)
    if period is not None and lattice is not None:
        raise ValueError("period: the w-variance ratio is computed on the continuum (lattice=None)")
    if lattice is not None:
        shape, spacing = lattice
        dk = 2.0 * math.pi / (shape[0] * spacing[0])
        rows = np.unique(np.clip(np.rint(k / dk).astype(np.int64), 1, shape[0] // 2))
        s = lt.lattice_spectra(params, fs, U, shape, spacing, rows=rows)
        at = np.arange(s.k1_k.size)
    else:
        # the asked k1 and, for the period's variance, a coarse log grid below them (log-log interpolated between)
        kk = k
        if period is not None:
            lo = np.geomspace(1e-4, k.min(), _W_TAIL)[:-1]
            hi = np.geomspace(k.max(), _W_TOP, _W_TAIL)[1:]
            kk = np.concatenate([lo[lo < k.min()], k, hi[hi > k.max()]])
        kk = np.unique(kk)
        s = lt.functional_spectra(kk, params, fs, U, resolution=resolution)
        at = np.searchsorted(s.k1_k, k)
    ratio, cross = np.empty((3, at.size)), np.empty((3, at.size))
    for c, name in enumerate("uvw"):
        frr, fss, frs = s.spectrum(f"0.{name}"), s.spectrum(f"1.{name}"), s.cross(f"0.{name}", f"1.{name}")
        ratio[c], cross[c] = (frr / fss)[at], (frs.real**2 / fss**2)[at]
    out = {"k1": s.k1_k[at], "ratio_ck": ratio, "cross_ck": cross, "spectra": s}
    if period is not None:
        T = check_real("period", period, lo=0.0, lo_open=True)
        dt = 1.0 / scanner.instrument.estimate_rate
        var = [lt.period_variance(s.k1_k, s.spectrum(n), U, T, sample_interval=dt)["within"] for n in ("0.w", "1.w")]
        out["w_variance_ratio"] = var[0] / var[1]
    return out


def node_sonic(position, origin, spacing):
    """A sonic as the box's sampler reads it across the wind: (u, v, w) bilinear between its four (y, z) nodes.

    Along x the advection sweeps the nodes past the sensor
    (:func:`~cwlidar_sim.campaign.periods.theory.node_interpolated_variance`);
    across the wind the sonic stays at one offset from the nodes, so its
    reading is the fixed bilinear mix of the four nodes' values, not a point's.

    Parameters
    ----------
    position : (x, y, z)
        The sonic [m].
    origin : (x0, y0, z0)
        A node of the box (its first) [m].
    spacing : (dx, dy, dz)
        The box's spacing [m], each > 0.

    Returns
    -------
    LinearFunctional
        Outputs ``"u"``, ``"v"``, ``"w"`` over four looks at ``x`` and the nodes' ``(y, z)``.
    """
    x, y, z = (check_real("position", c) for c in position)
    d = [check_real("spacing", c, lo=0.0, lo_open=True) for c in spacing]
    pts, wts = [], []
    f = [(c - float(o)) / dd for c, o, dd in zip((y, z), tuple(origin)[1:], d[1:])]
    j = [math.floor(a) for a in f]
    for a, wa in ((j[0], 1.0 - (f[0] - j[0])), (j[0] + 1, f[0] - j[0])):
        for b, wb in ((j[1], 1.0 - (f[1] - j[1])), (j[1] + 1, f[1] - j[1])):
            pts.append((x, float(origin[1]) + a * d[1], float(origin[2]) + b * d[2]))
            wts.append(wa * wb)
    w = np.zeros((3, 4, 3))
    for c in range(3):
        w[c, :, c] = wts
    return lt.LinearFunctional(lt.Looks(np.array(pts), np.tile([1.0, 0.0, 0.0], (4, 1))), w, ("u", "v", "w"))


def windscanner_lattice_variances(scanner, params, mean_speed: float, shape, spacing, origin, n_samples: int, *,
                                  probe="cells", sonic: str = "nodes", aliases: int = 0) -> dict:
    """Within-period variances of the reconstructed and the sonic's (u, v, w) over a box, as simulated at tier ``los``.

    The expectation over the boxes of one grid
    (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`: the
    generated shape, laterally doubled, its spacing, cell correction,
    Nyquist modes) of what a held-point period samples every ``1 /
    estimate_rate`` over ``n_samples`` steps, each series' variance about
    its period mean (``1 / N``): the reconstruction
    (:func:`windscanner_functionals`) read trilinearly
    (``interpolation="linear"``, the sampler's gains ``sinc^2(k d / 2)`` per
    axis, ``aliases`` kept), and the sonic as
    :func:`~cwlidar_sim.sensors.sample_sonic` reads it (``sonic="nodes"``:
    :func:`node_sonic` across the wind, between the nodes along x on its
    samples, :func:`~cwlidar_sim.campaign.periods.theory.node_interpolated_variance`;
    ``"point"``: across the wind the box's modes at the target itself, as
    on a node; along x still between the nodes).

    Parameters
    ----------
    scanner : WindScanner
        Pattern ``'point'``.
    params : MannParameters
    mean_speed : float
        U [m/s], > 0.
    shape, spacing : (N1, N2, N3), (dx, dy, dz)
        The generated box's (before the lateral crop) [-], [m].
    origin : (x0, y0, z0)
        A node of the box [m] (the sonic's offset from the nodes).
    n_samples : int
        The period's steps (>= 2).
    probe : bool or {"continuous", "cells"}
        As :func:`windscanner_functionals` (the simulation's: ``"cells"``).
    sonic : {"nodes", "point"}
    aliases : int
        :func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`'s.

    Returns
    -------
    dict
        ``lidar``, ``sonic``: arrays (u, v, w) [m^2 s^-2].
    """
    if scanner.pattern != "point":
        raise ValueError(f"pattern={scanner.pattern!r}: the lattice variances are a held point's; allowed: 'point'")
    if sonic not in ("nodes", "point"):
        raise ValueError(f"sonic must be 'nodes' or 'point', got {sonic!r}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    n = check_int("n_samples", n_samples, lo=2)
    dt = 1.0 / scanner.instrument.estimate_rate
    shape, spacing = tuple(int(a) for a in shape), tuple(float(a) for a in spacing)
    recon, point = windscanner_functionals(scanner, probe=probe)
    s = lt.lattice_spectra(params, recon, U, shape, spacing, interpolation="linear", aliases=aliases)
    lidar = [lt.period_variance(s.k1_k, s.spectrum(c), U, n * dt, sample_interval=dt, lines=True)["within"]
             for c in "uvw"]
    f = node_sonic(scanner.target, origin, spacing) if sonic == "nodes" else point
    s = lt.lattice_spectra(params, f, U, shape, spacing)
    dk1 = 2.0 * math.pi / (shape[0] * spacing[0])
    t = np.arange(n) * dt
    son = [node_interpolated_variance(s.k1_k, s.spectrum(c) * dk1, U, t, spacing[0],
                                      offset=float(scanner.target[0]) - float(origin[0])) for c in "uvw"]
    return {"lidar": np.array(lidar), "sonic": np.array(son)}


# --------------------------------------------------------------------------
# SpinnerLidar
# --------------------------------------------------------------------------
def rotor_disc_nodes(radius: float, exponent: float = 0.0, *, n_radial: int = 24, n_azimuth: int = 64):
    """Polar nodes of a rotor disc's REWS weight ``(r / R)^p`` per area, summing to 1 [-].

    Gauss-Legendre in r over [0, R] (``n_radial``), ``n_azimuth`` even angles.

    Returns
    -------
    (y_n, z_n, w_n)
        Node offsets from the hub in the rotor plane [m] and weights [-].
    """
    R = check_real("radius", radius, lo=0.0, lo_open=True)
    p = check_real("exponent", exponent, lo=0.0, hi=10.0)
    nr = check_int("n_radial", n_radial, lo=1, hi=10_000)
    na = check_int("n_azimuth", n_azimuth, lo=1, hi=100_000)
    x, w = np.polynomial.legendre.leggauss(nr)
    r = 0.5 * R * (x + 1.0)
    wr = 0.5 * R * w * r * (r / R) ** p
    psi = (np.arange(na) + 0.5) * (2.0 * math.pi / na)
    y = (r[:, None] * np.cos(psi)[None, :]).ravel()
    z = (r[:, None] * np.sin(psi)[None, :]).ravel()
    wn = np.repeat(wr / na, na)
    return y, z, wn / wn.sum()


def spinner_functionals(lidar, mean_speed: float, rotor_radius: float, *, rotor_exponent: float = 0.0,
                        w_zero: bool = True, exclude_blocked: bool = True, sub_dwells: int | None = None,
                        stride: int = 1, probe: bool = True, rotor_nodes=None):
    """The SpinnerLidar's REWS estimate of one rosette and the rotor's REWS, as linear functionals (module notes).

    The estimate: the disc fit's ``u0`` without ``du/dy`` (as the period's
    REWS), i.e. row ``u0`` of the pseudo-inverse of the rosette's design
    (:func:`cwlidar_sim.analysis.disc_fit.disc_design` of the looks' known
    directions at :attr:`~cwlidar_sim.sensors.spinner.SpinnerLidar.probe_centre`),
    each estimate the mean of its ``sub_dwells`` looks along their field
    directions (yaw and tilt), focused at ``focus_distance``.  Its time: the
    rosette's mid-time plus the preview ``d / U`` (d the probe centre's mean
    upwind distance over the rosette, as the period takes it), at which the
    rotor's REWS is compared.  The first rosette from t = 0 (the rotor's
    azimuth enters the blades and the rosette's turning).

    Parameters
    ----------
    lidar : SpinnerLidar
        The lidar (:class:`cwlidar_sim.sensors.spinner.SpinnerLidar`), its ``position`` the hub.
    mean_speed : float
        U [m/s].
    rotor_radius : float
        The REWS's disc radius R [m].
    rotor_exponent : float
        The disc's weight ``(r / R)^p`` per area.
    w_zero : bool
        The fit assumes w = 0 (``w0`` not a column).
    exclude_blocked : bool
        Leave out the estimates the blades block (the period's main estimate
        does; its ``tier1`` keeps them).
    sub_dwells : int, optional
        Looks per estimate (default the lidar's; fewer: a faster theory).
    stride : int
        Every ``stride``-th estimate of the rosette (from the first), the fit
        over those: a faster theory (the periods' take 4 for the bundled 984-estimate
        rosette: the coherence moves by less than 0.01, module notes).
    probe : bool
        The beam's weighting, or points at the focus.
    rotor_nodes : (y_n, z_n, w_n), optional
        The rotor's nodes (default :func:`rotor_disc_nodes`).

    Returns
    -------
    (LinearFunctional, LinearFunctional)
        Outputs ``"rotor"`` and ``"lidar"``.
    """
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    nsub = lidar.sub_dwells if sub_dwells is None else check_int("sub_dwells", sub_dwells, lo=1, hi=256)
    stride = check_int("stride", stride, lo=1, hi=lidar.estimates_per_rosette // 8)
    T = lidar.rosette_time
    t_all, _ = lidar.schedule(T)
    # the period's preview: the probe centre's mean upwind distance over the rosette (the lidar's own sub-dwells)
    off_s = (np.arange(lidar.sub_dwells) + 0.5) / lidar.sub_dwells - 0.5
    n_mid = lidar.look_geometry((t_all[:, None] + off_s[None, :] * lidar.dwell_time).ravel())[2]
    preview = float(-n_mid[:, 0].mean()) * lidar.probe_centre / U
    t_e = t_all[::stride]
    off = (np.arange(nsub) + 0.5) / nsub - 0.5
    t_el = t_e[:, None] + off[None, :] * lidar.dwell_time
    _, n_lc, known_lc, _ = lidar.look_geometry(t_el.ravel())
    ne = t_e.size
    known_elc = known_lc.reshape(ne, nsub, 3)
    keep = np.ones(ne, dtype=bool)
    if exclude_blocked:
        t_blk = (t_e[:, None] + off_s[None, :] * lidar.dwell_time)
        keep = ~(lidar.blocked(t_blk).mean(axis=1) > lidar.blockage_fraction)
    cols = [0, 2, 3, 4] + ([] if w_zero else [5])  # u0, dudz, v0, dvdz (, w0): the fit without du/dy
    A = disc_design(known_elc[keep], lidar.probe_centre)[:, cols]
    c_e = np.linalg.pinv(A)[0]  # the u0 row
    pts = np.asarray(lidar.position, dtype=float)[None, :] + lidar.focus_distance * n_lc
    t_l = (t_el - 0.5 * T - preview).ravel()
    sel = np.repeat(keep, nsub)
    prb = _probe(lidar, lidar.instrument_at()) if probe else None
    looks = lt.Looks(pts[sel], n_lc[sel], t_l[sel], prb)
    est = lt.lidar_functional(looks, np.repeat(c_e, nsub) / nsub, ["lidar"])
    y, z, w = rotor_disc_nodes(rotor_radius, rotor_exponent) if rotor_nodes is None else rotor_nodes
    g = math.radians(lidar.yaw_misalignment_deg)
    hub = np.asarray(lidar.position, dtype=float)
    rl = lt.Looks(np.stack([hub[0] + 0.0 * y, hub[1] + y, hub[2] + z], axis=1), np.tile([1.0, 0.0, 0.0], (y.size, 1)))
    rotor = lt.LinearFunctional(rl, np.asarray(w)[None, :, None] * np.array([math.cos(g), math.sin(g), 0.0]),
                                ["rotor"])
    return rotor, est


def spinner_theory(lidar, params, mean_speed: float, k1, rotor_radius: float, *, resolution: float = 30.0,
                   **kw) -> dict:
    """The coherence of the SpinnerLidar's REWS estimate with the rotor's, and both spectra (module notes).

    Parameters
    ----------
    lidar, mean_speed, rotor_radius, kw
        As :func:`spinner_functionals`.
    params : MannParameters
    k1 : array_like
        Wavenumbers [rad/m], > 0.
    resolution : float
        The polar quadrature's resolution.

    Returns
    -------
    dict
        ``k1`` [rad/m], ``coherence_k`` [-], ``spectra`` (outputs ``0.rotor``, ``1.lidar``).
    """
    fs = spinner_functionals(lidar, mean_speed, rotor_radius, **kw)
    s = lt.functional_spectra(k1, params, fs, mean_speed, resolution=resolution)
    return {"k1": s.k1_k, "coherence_k": s.coherence(0, 1), "spectra": s}


# --------------------------------------------------------------------------
# the periods' result variables
# --------------------------------------------------------------------------
def windscanner_variables(scene, index: int, k_k) -> dict:
    """The WindScanner period's theory variables, ``name -> (dims, values, attrs)`` on ``period`` (module notes).

    ``transfer_ratio_theory`` and ``transfer_cross_theory`` (component, k)
    at the bins' centres ``k_k`` [rad/m], ``w_variance_ratio_theory``; NaN
    for a moving focus (the period's transfer functions are a held point's).
    """
    p = scene.periods[index]
    ws = scene.sensor()
    k = np.asarray(k_k, dtype=float)
    ratio, cross, wr = np.full((3, k.size), np.nan), np.full((3, k.size), np.nan), np.nan
    if scene.scanner.pattern == "point":
        params, U, T = scene.period_params(p), p.mean_speed, scene.period_duration(p)
        th = cached(("windscanner", repr(ws), repr(params), U, T, k.tobytes()),
                     lambda: windscanner_theory(ws, params, U, k, period=T, resolution=_RESULTS_RESOLUTION))
        ratio, cross, wr = np.array(th["ratio_ck"]), np.array(th["cross_ck"]), th["w_variance_ratio"]
    how = (f"linear theory, frozen Mann continuum, the beams' '{ws.weighting}' weighting at each unit's range, "
           f"the reconstruction N^-1 (cross-contamination included), a point sonic; NaN for a moving focus")
    P = ("period",)
    return {
        "transfer_ratio_theory": (P + ("component", "k"), ratio[None], {
            "units": "1", "long_name": "A2012 method 1 of the reconstructed component, linear theory",
            "theory": how}),
        "transfer_cross_theory": (P + ("component", "k"), cross[None], {
            "units": "1", "long_name": "A2012 method 2 of the reconstructed component, linear theory",
            "theory": how}),
        "w_variance_ratio_theory": (P, np.array([wr]), {
            "units": "1", "long_name": "variance of the reconstructed w within the period over the sonic's, linear "
                                       "theory (samples at the estimate rate, mean removed)", "theory": how}),
    }


#: The std ratios' continuum: the adaptive quadrature's k1 range [rad/m] and polar resolution (the study's).
_STD_K1_RANGE, _STD_RESOLUTION = (1e-4, 2.0), 20.0


def _std_ratio_theory(ws, params, U, grid):
    """Continuum and lattice within-period variances (u, v, w) of the reconstruction and the sonic, range cells."""
    shape, spacing, origin, n = grid
    dt = 1.0 / ws.instrument.estimate_rate
    lat = windscanner_lattice_variances(ws, params, U, shape, spacing, origin, n, probe="cells")
    stats = [lt.PeriodStatistic(f"{j}.{c}", n * dt, dt) for j in range(2) for c in "uvw"]
    a = lt.adaptive_spectra(params, list(windscanner_functionals(ws, probe="cells")), U, stats,
                            k1_range=_STD_K1_RANGE, resolution=_STD_RESOLUTION)
    cont = np.array(a.within)
    return {"continuum": np.sqrt(cont[:3] / cont[3:]), "lattice": np.sqrt(lat["lidar"] / lat["sonic"])}


def windscanner_std_ratio_variables(scene, index: int, grid) -> dict:
    """The WindScanner period's std-ratio theory, ``name -> (dims, values, attrs)`` on ``period`` (module notes).

    ``std_ratio_theory`` (component): the reconstructed component's std
    within the period over the sonic's on the frozen Mann continuum;
    ``std_ratio_theory_lattice`` (component): the same over the period's
    generated box as the simulation reads it
    (:func:`windscanner_lattice_variances`: the box's own modes, laterally
    doubled, the range cells trilinearly, the sonic between its nodes).
    Both take the simulation's range cells as the beams' weighting and the
    period's samples (every ``1 / estimate_rate``, mean removed); NaN for a
    moving focus (held points only).  Computed once per geometry, tensor,
    U, samples and box in a process (about 10 s for a 30-s period, 30 s for
    600 s on two loaded cores).

    Parameters
    ----------
    scene : WindScannerScene
    index : int
        The period.
    grid : (shape, spacing, origin, n_samples)
        The generated box's shape (before the lateral crop) [-], spacing [m],
        a node (its first) [m], and the period's steps [-].
    """
    p = scene.periods[index]
    ws = scene.sensor()
    shape, spacing, origin, n = (tuple(int(a) for a in grid[0]), tuple(float(a) for a in grid[1]),
                                 tuple(float(a) for a in grid[2]), int(grid[3]))
    cont, lat = np.full(3, np.nan), np.full(3, np.nan)
    box = (f"box {'x'.join(str(a) for a in shape)} generated (laterally doubled: the y extent twice the "
           f"simulated one, as the box generator draws it) at {'/'.join(f'{a:g}' for a in spacing)} m")
    if scene.scanner.pattern == "point":
        params, U = scene.period_params(p), p.mean_speed
        th = cached(("windscanner_std", repr(ws), repr(params), U, shape, spacing, origin, n),
                    lambda: _std_ratio_theory(ws, params, U, (shape, spacing, origin, n)))
        cont, lat = np.array(th["continuum"]), np.array(th["lattice"])
        reason = ""
    else:
        reason = f"; NaN: pattern={scene.scanner.pattern!r} (a moving focus; the theory is a held point's)"
    common = (f"linear theory, frozen Mann turbulence, weighting: the simulation's range cells at each unit's range "
              f"(tier los), the reconstruction N^-1 (cross-contamination included), within-period std over "
              f"{n} samples every 1/estimate_rate, mean removed")
    C = ("period", "component")
    return {
        "std_ratio_theory": (C, cont[None], {
            "units": "1", "long_name": "std of the reconstructed component over the sonic's, linear theory",
            "theory": common + "; a point sonic" + reason, "box": "continuum",
            "numerics": f"adaptive k1 quadrature over {_STD_K1_RANGE} rad/m, polar resolution {_STD_RESOLUTION:g}"}),
        "std_ratio_theory_lattice": (C, lat[None], {
            "units": "1", "long_name": "std of the reconstructed component over the sonic's, linear theory on the "
                                      "period's box",
            "theory": common + "; the sonic bilinear between its (y, z) nodes and between the nodes along x" + reason,
            "box": box, "numerics": "the sum over the box's wavenumbers (its Nyquist modes and cell correction), "
                                    "the range cells read trilinearly (sinc^2 gains per axis), no aliases"}),
    }


def spinner_k_edges(scene, period) -> np.ndarray:
    """The spinner period's coherence bins [rad/m]: 8 log bins from a quarter period's harmonic to the rosettes' Nyquist."""
    lid = scene.sensor(period)
    U, T = period.mean_speed, lid.rosette_time
    seg = _spinner_segment(scene, period)
    return np.geomspace(2.0 * math.pi / (U * seg), math.pi / (U * T), _SPINNER_BINS + 1)


def _spinner_segment(scene, period) -> float:
    """Segment of the rosette series' spectra [s]: a quarter of the period, whole rosettes, at least 4 of them."""
    T = scene.sensor(period).rosette_time
    return T * max(4, int(scene.period_duration(period) / T) // 4)


def spinner_variables(scene, index: int, rews_er, rotor_r) -> dict:
    """The spinner period's coherence variables, ``name -> (dims, values, attrs)`` on ``period`` (module notes).

    ``rews_coherence`` (estimate, k): the simulated coherence of each
    estimate kind's REWS per rosette (``rews_er``, NaN gaps filled as
    :func:`cwlidar_sim.analysis.spectra.segment_spectra` does) with the
    rotor's (``rotor_r``), segments of a quarter period, Hann-windowed
    (the REWS spectra fall ~k^-4.5 above 0.03 rad/m: without a taper the
    low wavenumbers' leakage fills the upper bins, which then read the
    low wavenumbers' near-unit coherence), bin-averaged before the ratio; ``rews_coherence_theory`` (k): the linear theory's at
    the bins' centres (frozen continuum, the lidar's weighting, the blocked
    estimates left out, one look per dwell, every 4th estimate, the rotor's
    disc on 12 x 32 nodes: within 0.01 of every estimate's and 24 x 64
    nodes, module notes; NaN for evolving turbulence and for a period
    shorter than one segment), computed once per scene and period geometry
    in a process.
    """
    p = scene.periods[index]
    lid = scene.sensor(p)
    edges = spinner_k_edges(scene, p)
    kc = np.sqrt(edges[1:] * edges[:-1])
    U, T = p.mean_speed, lid.rosette_time
    to_k = U / (2.0 * math.pi)
    coh = np.full((rews_er.shape[0], kc.size), np.nan)
    for j, x in enumerate(rews_er):
        try:
            seg = segment_spectra(x, rotor_r, fs=1.0 / T, segment_duration=_spinner_segment(scene, p), window="hann")
        except ValueError:
            continue
        m, _ = bin_average(seg.f_f / to_k, np.stack([seg.psd_xf, seg.psd_yf, seg.csd_f]), edges)
        with np.errstate(invalid="ignore", divide="ignore"):
            coh[j] = np.abs(m[2]) ** 2 / (m[0].real * m[1].real)
    theory = np.full(kc.size, np.nan)
    if p.lifetime is None and scene.period_duration(p) >= _spinner_segment(scene, p):
        sc, params = scene.scan, scene.period_params(p)
        stride = min(_SPINNER_STRIDE, lid.estimates_per_rosette // 8)
        nodes = rotor_disc_nodes(sc.rotor_radius, sc.rotor_exponent, n_radial=_SPINNER_ROTOR[0],
                                 n_azimuth=_SPINNER_ROTOR[1])
        key = ("spinner", repr(lid), repr(params), U, sc.rotor_radius, sc.rotor_exponent, sc.w_zero, kc.tobytes())
        theory = np.array(cached(key, lambda: spinner_theory(
            lid, params, U, kc, sc.rotor_radius, rotor_exponent=sc.rotor_exponent, w_zero=sc.w_zero, sub_dwells=1,
            stride=stride, rotor_nodes=nodes, resolution=_RESULTS_RESOLUTION)["coherence_k"]))
    P = ("period",)
    how = (f"linear theory, frozen Mann continuum, the beam's '{lid.weighting}' weighting, the disc fit's u0 row "
           f"(no du/dy) over every {_SPINNER_STRIDE}th of one rosette's unblocked estimates (one look per dwell), "
           f"preview-shifted, against the rotor's disc average; NaN for evolving turbulence or a period shorter "
           f"than one segment")
    return {
        "rews_coherence": (P + ("estimate", "k"), coh[None], {
            "units": "1", "long_name": "coherence of the lidar's REWS per rosette with the rotor's"}),
        "rews_coherence_theory": (P + ("k",), theory[None], {
            "units": "1", "long_name": "coherence of the lidar's REWS with the rotor's, linear theory", "theory": how}),
        "k_coherence": (P + ("k",), kc[None], {"units": "rad m-1", "long_name": "coherence bin centre (geometric)"}),
    }
