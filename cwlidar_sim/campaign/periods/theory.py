"""The linear functionals of the scenes' instruments: the sensors' own geometry as :mod:`~cwlidar_sim.analysis.linear_theory` looks.

The sensors (:mod:`cwlidar_sim.sensors`) and the theory
(:mod:`cwlidar_sim.analysis`) sit side by side and do not import each other;
this module, above both, reads a sensor's geometry -- its position, beam
directions, focus, probe weighting and optics, its scan schedule -- and
writes the :class:`~cwlidar_sim.analysis.linear_theory.LinearFunctional` of
what a period compares:

* :func:`staring_functionals`: a staring lidar's probe-volume weighted
  line-of-sight speed and a sonic's wind along the same beam (A2012);
* :func:`conical_functionals`: a conical lidar's VAD fit of one block of
  revolutions at one height (every sub-dwell look at its own azimuth and
  time, the estimates' mid-azimuths in the fit, as
  :meth:`cwlidar_sim.sensors.ConicalLidar.plan_record` samples them) and a
  cup at that height (first-order response of its distance constant);
* :func:`nacelle_functionals`: a nacelle lidar's REWS estimate over one
  revolution (delays and preview) and a rotor of weighted nodes.

The field's frame: the mean wind U along +x.  A look's probe is its beam's
continuous weighting (:func:`cwlidar_sim.analysis.rews_theory.beam_transfer`
of the lidar's ``weighting`` with the instrument's optics), not the
simulation's discrete range cells.
"""

from __future__ import annotations

import numpy as np

from ...analysis import linear_theory as lt
from ...analysis.rews_theory import beam_transfer, scan_beams
from ..._validation import check_int, check_real


def _probe(lidar, instrument):
    """``phi_hat`` of the lidar's weighting at the instrument's focus, with its optics."""
    return beam_transfer(instrument.focus, lidar.weighting, wavelength=instrument.wavelength,
                         radius=instrument.telescope_radius)


def staring_functionals(lidar, sonic_position):
    """A staring lidar's line-of-sight speed and a sonic's wind along the same beam, as linear functionals.

    Parameters
    ----------
    lidar : StaringLidar
        The lidar (:class:`cwlidar_sim.sensors.StaringLidar`), in the field's frame.
    sonic_position : (x, y, z)
        The sonic's position [m].

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
    beam = lt.lidar_functional(lt.Looks([focus], [n], None, _probe(lidar, inst)), [1.0], ["lidar"])
    sonic = lt.LinearFunctional(lt.Looks(np.asarray(sonic_position, dtype=float).reshape(1, 3), [n]),
                                n.reshape(1, 1, 3), ["sonic"])
    return beam, sonic


def conical_functionals(lidar, height: float, mean_speed: float, *, revolutions: int = 1, cup=None):
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
    looks = lt.Looks(focus_lc, n_lc, t_l - 0.5 * (t_e[0] + t_e[-1]), _probe(lidar, inst))
    coef_oe = np.linalg.pinv(np.asarray(lidar.direction(az_e), dtype=float).reshape(-1, 3))  # the fit of estimates
    vad = lt.lidar_functional(looks, np.repeat(coef_oe, nsub, axis=1) / nsub, ["u", "v", "w"])
    if cup is None:
        return vad
    return vad, lt.point_functional(cup.position, ("u",), response=lt.first_order_response(cup.distance_constant / U))


def nacelle_functionals(lidar, focus: float, mean_speed: float, rotor_nodes, *, n_beams: int = 8,
                        preview_shift: float | None = None):
    """A nacelle lidar's REWS estimate over one revolution and a rotor of weighted nodes, as linear functionals.

    The scan as :func:`cwlidar_sim.analysis.rews_theory.scan_beams` discretises
    the lidar's cone (its geometry, revolution time and first azimuth, in the
    nacelle frame, the hub at the origin): ``n_beams`` beams evenly over the
    revolution, beam b's sample ``tau_b = (N - 1 - b) T / N`` old when the
    estimate is formed (the phase after the last beam); each beam's
    line-of-sight speed enters as ``v_b / n_bx`` with weight 1/N.  The
    estimate is shifted by the preview ``preview_shift`` [s] (default
    ``r cos a / U``, the focus's upwind distance).

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
    n_beams : int
        N >= 1.
    preview_shift : float, optional
        The shift of the estimate [s].

    Returns
    -------
    (LinearFunctional, LinearFunctional)
        Outputs ``"rotor"`` (the nodes' weighted u) and ``"lidar"``.
    """
    r = check_real("focus", focus)
    if r not in tuple(lidar.focus_distances):
        raise ValueError(f"focus={focus!r} m is not one of the lidar's focus_distances {tuple(lidar.focus_distances)}")
    U = check_real("mean_speed", mean_speed, lo=0.0, lo_open=True)
    n = check_int("n_beams", n_beams, lo=1, hi=10_000)
    y_n, z_n, w_n = (np.asarray(a, dtype=float).ravel() for a in rotor_nodes)
    if not (y_n.size == z_n.size == w_n.size) or abs(w_n.sum() - 1.0) > 1e-9:
        raise ValueError("rotor_nodes must be (y_n, z_n, w_n) of one length with weights summing to 1")
    beams = scan_beams(lidar.geometry, n, r, all_phases=False, origin=lidar.position)
    shift = lidar.preview_distance(r) / U if preview_shift is None else check_real("preview_shift", preview_shift)
    inst = lidar.instrument_at(r)
    # the look sees u_0(p - U (t + t_l) e1): a sample tau_b old and shifted by T is taken at t_l = -(T + tau_b)
    looks = lt.Looks(beams.focus_points_bc, beams.direction_bc, -(shift + beams.delay_pb[0]), _probe(lidar, inst))
    est = lt.lidar_functional(looks, beams.weight_b / beams.direction_bc[:, 0], ["lidar"])
    rotor_looks = lt.Looks(np.stack([0.0 * y_n, y_n, z_n], axis=1), np.tile([1.0, 0.0, 0.0], (y_n.size, 1)))
    rotor = lt.LinearFunctional(rotor_looks, w_n[None, :, None] * np.array([1.0, 0.0, 0.0]), ["rotor"])
    return rotor, est
