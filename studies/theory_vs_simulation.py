"""The linear theory against the simulation at tier ``los``, paired seeds: issue 33's acceptance.

For each scene the simulation runs N seeded periods (the box, the lidar, the point sensor or the rotor from one
seed: paired), and the pooled statistic is compared with the lattice theory of the box the simulation built (its
generated shape and spacing: :func:`cwlidar_sim.analysis.linear_theory.lattice_spectra`) seen as the period sees it
(:func:`~cwlidar_sim.analysis.linear_theory.period_variance`: the samples, the period, its mean removed), with the
functionals of :mod:`cwlidar_sim.campaign.periods.theory` (``probe="cells"``: the simulation's range cells):

* conical (the CS scene's lidar, one height a period, 1-s VAD scans): the lidar/cup std ratio,
  ``sqrt(sum var_lidar / sum var_cup)`` over the periods (within-period variances, 1/N), and the cup/sonic ratio
  (the cup's response); the cup and the sonic as the simulation reads them, between the box's nodes along x
  (:func:`~cwlidar_sim.campaign.periods.theory.node_interpolated_variance`: at 40 m it lowers the point's variance
  by 1.3 % and moves the lidar/cup ratio by +0.002);
* nacelle (the bundled scene's frozen period, one focus): the lidar's revolution mean against the rotor's REWS at
  the preview delay, the std ratio and the correlation coefficient;
* windscanner (``--kind windscanner``; the bundled scene's published layout, 8 m/s, the 4-m box, tier 1 of tier
  los): each reconstructed component (u, v, w) over the sonic's at the common focus, the std ratio pooled as above,
  against :func:`cwlidar_sim.campaign.periods.scanner_theory.windscanner_lattice_variances` (the three units'
  range cells read trilinearly, N^-1 at the focus; the sonic as the sampler reads it: bilinear between the four
  (y, z) nodes around the target, between the nodes along x on its samples), the continuum beside it.

The standard error of a pooled statistic is the jackknife's over the periods; ``z = (sim - theory) / SE``.  It
needs many periods: with 4 the jackknife of a ratio is itself uncertain by a factor of ~2 (the first run's 40-m
"z = +7.9", 0.908 +/- 0.016 on 4 periods of 60 s, was that: one 60-s period's ratio scatters by 0.10, and 400
periods give 0.7833 +/- 0.0058 against the theory's 0.7861, z = -0.5).  What the theory still leaves out (and so
the residual holds): the lidars' own trilinear interpolation between the nodes -- a mode reaches a look lowered by
about ``sinc^2(k_i d / 2)`` on each axis (tests/campaign/periods/test_theory_adapters.py), which the functionals
do not hold; it leaves the simulated lidar low where the spacing is coarse against what the lidar resolves: 40 m
(d = 2 m) z = -0.5 on 400 x 60 s, 100 m (d = 5 m) lidar/cup 0.6606 +/- 0.0101 against 0.6819 (z -2.1, 300 x 60 s),
nacelle 100 m (d = 4 m) lidar/rotor std ratio 1.121 +/- 0.013 against 1.162 (z -3.2, 300 x 60 s: the rotor's
variance agrees within 1 %, the lidar's is 6 % low; with dy = dz = 2 m the gap shrinks to 0.033, about the
d^(2/3) the Mann spectrum's tail gives) while the lidar-rotor correlation agrees (z +0.7); and, second order in
the turbulence intensity, the horizontal speed's nonlinearity, the VAD's rectified fit and its exclusion of the
zero crossings (at tier los dropping the exclusion moves the 40-m ratio by 0.0004).

The lidars' interpolation, computed (``--interpolation linear``, the default here:
``lattice_spectra(interpolation="linear")``, the rotor's REWS linear along x only): it explains little of those
residuals.  Conical 100 m lidar/cup 0.6819 -> 0.6788 (z -2.1 -> -1.8 against the 300 x 60 s above); nacelle
lidar/rotor 1.1615 -> 1.1584 (z -3.2 -> -2.9; the lidar's within-period variance -0.6 %, the rotor's -0.04 %); the
correlation is the plain lattice's (one interpolation per call).  The aliases (``--aliases 1`` against 0) move
the lidars' variance by 2e-5 (conical) and 1.2e-4 (nacelle): the gains ``sinc^2(k d / 2)`` are the effect, and
they act where the lidars' spectra are already small.

The nacelle's "6 % lidar variance deficit", settled: no term is missing.  (1) The trailing revolution mean at full
rate is cyclostationary; the functional of one scan phase read the std ratio 0.004 high: over 10 phases the
lattice theory's lidar variance swings by +/- 0.75 % with one cycle per revolution, and two opposite phases
(``phases``, default 2) give its average within 2e-4 (std ratio 1.1615 at phase 0, 1.1574 averaged; with the
interpolation 1.1543).  (2) A one-mode field (tests/campaign/periods/test_theory_adapters.py) and a still field
check the simulation's looks, times, cells and weights term by term.  (3) The rest was the first 300 seeds: at
2400 periods of 60 s (seeds 2000..4399, SE 0.0047 <= 0.005) the simulated ratio is 1.1498 +/- 0.0047 against 1.1543
(z -1.0; seeds 2300..4399 alone 1.1539 +/- 0.0051, z -0.1; seeds 2000..2299 1.1206 +/- 0.0128, z -2.6); the
lidar's mean within-period variance 0.3446 against 0.3449 (lattice), the rotor's 0.2607 against 0.2575, the
correlation 0.9076 against 0.9050; paired in the same boxes, the lidar over the lidar with v = w = 0 in the box
1.00687 +/- 0.00034 against 1.00726 (the beams' v, w cross-contamination, z -1.1).  The continuum (the box left
out) gives 1.176: the box's lattice lowers the nacelle std ratio by 0.02.

Conical 100 m again (issue 33, part: lattice; seeds 1000-2139, tier los, 60-s periods, sub-dwells 2): lidar/cup
0.6730 +/- 0.0057 on 1140 periods against the lattice theory 0.6791 (``campaign.periods.lattice_theory`` with the
cells; 0.6788 this study's unmerged looks on every row; 0.6792 the continuous weighting): z -1.1, within 1.5
standard errors (the 300 periods above were z -1.8; the first 620 of these z -1.8, the first 900 z -1.6); the
continuum 0.6706 (z +0.4).  Cup/sonic 0.99182 +/- 0.00030 against 0.99178.  Checked, each moving the lattice by
<= 3e-4: the lateral aliases (their power, which bounds any cross term of a look's sub-cell offset, 2e-5 of the
lidar's variance), the weighting (cells against continuous), the sub-dwell merge and the sparse rows, the Nyquist
convention.
**At SE <= 0.005** (the issue's size; this study's default theory, the lidar's interpolation included):
100 m, 1600 periods (seeds 1000-2599, 2971 s of simulation on the loaded cores): lidar/cup 0.6807 +/- 0.0049
against the lattice's 0.6788, z +0.38 (the continuum's 0.6706: z +2.1); cup/sonic 0.9917 +/- 0.0003 against
0.9918 (z -0.25).  40 m, 700 periods (seeds 1000-1699): lidar/cup 0.7829 +/- 0.0044 against 0.7830, z -0.01;
cup/sonic 0.9789 +/- 0.0005 against 0.9790 (z -0.17).  The 100-m mean moved from 0.6730 (first 1140) to 0.6807:
the last 460 periods' ratio 0.70, inside one period's scatter of 0.20 over sqrt(460).

WindScanner (issue 33's "one new instrument"; seeds 5000-5239, 240 x 160 s, SE <= 0.005, 403 s of simulation and
19-74 s of theory on the loaded 2 cores; a rerun gives the same bits): u 0.7292 +/- 0.0047 against the lattice's
0.7323 (z -0.66), v 0.6597 +/- 0.0040 against 0.6613 (z -0.41), w 0.6202 +/- 0.0030 against 0.6193 (z +0.31); the
continuum 0.6979 / 0.6146 / 0.5338 is 7 / 11 / 29 standard errors away: the 4-m box lowers the sonic's variance (to
0.861 / 0.797 / 0.704 of the continuum's: its modes and the bilinear reading, as campaign.periods.in_situ's analytic
sub-grid variance gives, 0.706 for w) far more than the reconstruction's (0.948 / 0.922 / 0.947), whose 4-m cells
and ~19-m Rayleigh length average those scales away anyway. Needs ~210 / 150 / 90 periods of 160 s for SE 0.005.

The w finding (docs/windscanner.md said the reconstructed w was ~20 % below the continuum in both boxes): not a
defect.  ``--w-box 4 2 --duration 160`` gives the reconstruction's w variance over the box against the continuum
(range cells): the box's modes alone 0.984 (4 m) / 0.987 (2 m), read trilinearly 0.947 / 0.974 (the continuous
weighting of the results' theory is another 2.4 % above the cells: 0.0878 against 0.0857 m^2/s^2); the 240 periods
above simulate 0.0816 +/- 0.0017 against the lattice's 0.0812.  The "20 %" was one draw: the eight periods of
tests/campaign/periods/test_scanner_theory.py (seeds 100-107) read 0.0694 +/- 0.0046 (4 m) and 0.0715 +/- 0.0045
(2 m), 2.5-2.8 standard errors below their lattices (their std ratios, paired with the sonic, are within 1.2), and
the sonic's sub-grid share there quoted 37 % (4 m) is 29.4 % (lattice 29.6 %, the analytic in_situ 29.4 %).
A 2-m box (``--spacing 2 --seed0 6000``, 60 x 160 s, 336 s of simulation, 94 s of theory): u 0.7091 +/- 0.0124
against 0.7130 (z -0.31), v 0.6314 +/- 0.0077 against 0.6360 (z -0.60), w 0.5838 +/- 0.0065 against 0.5821
(z +0.26); the reconstructed w's variance 0.0833 +/- 0.0031 against the lattice's 0.0835 (continuum 0.0857).
The eight seeds give nearly the same per-period w variance in both boxes (0.0877 / 0.0886 ... 0.0477 / 0.0504:
a seed draws the same large scales at either spacing), so "both boxes low" was one draw seen twice.

Run (reduced size, a few minutes; the 60-s periods cost ~0.4 s each, one height's theory ~25 s)::

    PYTHONPATH=. python studies/theory_vs_simulation.py --periods 100 --duration 60

Full size (SE <= 0.005 for the std ratios: ~540 periods of 60 s at 40 m, about 4 minutes of simulation; the
nacelle needs ~2400 periods of 60 s, about 7 minutes; at 100 m see the printed estimate of the periods it needs)::

    PYTHONPATH=. python studies/theory_vs_simulation.py --periods 540 --duration 60 --heights 40 100

WindScanner, full size (~7 minutes of simulation on 2 loaded cores) and its box against the continuum::

    PYTHONPATH=. python studies/theory_vs_simulation.py --kind windscanner --periods 240 --duration 160
    PYTHONPATH=. python studies/theory_vs_simulation.py --w-box 4 2 --duration 160
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from cwlidar_sim.analysis import linear_theory as lt
from cwlidar_sim.analysis.rews import RotorDisc, rews_from_box
from cwlidar_sim.campaign.execution.reproduce import bundled_scene
from cwlidar_sim.campaign.periods import scanner_theory as st
from cwlidar_sim.campaign.periods import theory as th
from cwlidar_sim.campaign.periods.conical_simulation import simulate_conical_period
from cwlidar_sim.campaign.periods.nacelle_lattice import box_rotor_nodes, lattice_statistics
from cwlidar_sim.campaign.scenes.conical import default_spacing
from cwlidar_sim.sensors import ConicalLidar, Cup
from cwlidar_sim.sensors.nacelle import measure_nacelle
from cwlidar_sim.turbulence.cover import cover_box


def jackknife(num_i, den_i, cross_i=None):
    """``(stat, se)`` of ``sqrt(sum num / sum den)`` (or ``sum cross / sqrt(sum num sum den)``) over periods i."""
    num_i, den_i = np.asarray(num_i, float), np.asarray(den_i, float)

    def stat(m):
        if cross_i is None:
            return math.sqrt(num_i[m].sum() / den_i[m].sum())
        return np.asarray(cross_i, float)[m].sum() / math.sqrt(num_i[m].sum() * den_i[m].sum())

    n = num_i.size
    full = stat(np.ones(n, bool))
    loo = np.array([stat(np.arange(n) != i) for i in range(n)])
    return full, math.sqrt((n - 1) / n * np.sum((loo - loo.mean()) ** 2))


def _within(spec, name, U, T, dt, other=None):
    """The lattice lines' expected within-period (co)variance of a series sampled every ``dt`` over ``T``."""
    F = spec.spectrum(name) if other is None else spec.cross(name, other).real
    return lt.period_variance(spec.k1_k, F, U, T, sample_interval=dt, lines=True)["within"]


# --------------------------------------------------------------------------
# conical: the CS scene's lidar against its cup
# --------------------------------------------------------------------------
def conical_case(height, n_periods, duration, *, speed=8.0, seed0=1000, sub_dwells=2, span=None, break_=None,
                 interpolation="none", aliases=1):
    """Simulated and theoretical lidar/cup and cup/sonic std ratios at one height (module notes): two rows.

    ``break_`` (for the acceptance tests' negative checks): ``"vad_w"`` drops the VAD's coefficient of w in the
    theory, ``"no_cup_response"`` the cup's response, ``"probe_x2"`` doubles the theory's Rayleigh length.
    """
    cs = bundled_scene("cs")
    d = default_spacing(height)
    lf = cs.lidar_fields(d)
    lf.pop("tier"), lf.pop("sub_dwells")
    if span is not None:
        lf["span"] = span
    params, _, _ = cs.turbulence.resolve(height, speed)
    t0 = time.perf_counter()
    rows = [simulate_conical_period(height, seed0 + i, speed=speed, duration=duration, scan_revs=(1,), tier="los",
                                    sub_dwells=sub_dwells, spacing=d, params=params, model=False,
                                    lidar_overrides=lf) for i in range(n_periods)]
    t_sim = time.perf_counter() - t0
    n_scan = np.array([r["scans"][1]["n_scans"] for r in rows], float)
    n_cup = duration * 10.0
    var_l = np.array([r["scans"][1]["lidar_std"] ** 2 for r in rows]) * (n_scan - 1) / n_scan
    var_c = np.array([r["cup_std"] ** 2 for r in rows]) * (n_cup - 1) / n_cup
    sim, se = jackknife(var_l, var_c)
    r0 = rows[0]
    shape = (r0["box_shape"][0], 2 * r0["box_shape"][1], r0["box_shape"][2])
    t0 = time.perf_counter()
    lidar = ConicalLidar(**dict(lf, heights=(height,), tier="los", cell_length=d, sub_dwells=sub_dwells))
    if break_ == "probe_x2":
        lidar = lidar.replace(instrument=lidar.instrument.replace(
            telescope_radius=lidar.instrument.telescope_radius / math.sqrt(2.0)))
    vad = th.conical_functionals(lidar, height, speed, revolutions=1, probe="cells")
    if break_ == "vad_w":
        vad = lt.LinearFunctional(vad.looks, vad.weight_olc * np.array([1.0, 1.0, 0.0]), vad.names)
    point = lt.point_functional(r0["in_situ_position"], ("u",))
    spec = lt.lattice_spectra(params, [vad, point], speed, shape, r0["box_spacing"])
    T = float(np.mean(n_scan)) * lidar.revolution_time
    if interpolation == "none":
        v_lidar = _within(spec, "0.u", speed, T, lidar.revolution_time)
    else:  # the lidar's looks read the box trilinearly (the point sensors: node_interpolated_variance below)
        spec_l = lt.lattice_spectra(params, vad, speed, shape, r0["box_spacing"], interpolation=interpolation,
                                    aliases=aliases)
        v_lidar = _within(spec_l, "u", speed, T, lidar.revolution_time)
    # the cup and the sonic read the box between its nodes along x (the cup's step on its 10-Hz samples)
    cup = Cup(position=r0["in_situ_position"])
    lines = spec.spectrum("1.u") * (2.0 * math.pi / (shape[0] * r0["box_spacing"][0]))
    v_cup = th.node_interpolated_variance(spec.k1_k, lines, speed, cup.times(duration), r0["box_spacing"][0],
                                          distance_constant=None if break_ == "no_cup_response"
                                          else cup.distance_constant)
    t_sonic = lidar.schedule(duration).time_e
    v_sonic = th.node_interpolated_variance(spec.k1_k, lines, speed, t_sonic, r0["box_spacing"][0])
    var_s = np.array([r["sonic_std"] ** 2 for r in rows]) * (t_sonic.size - 1) / t_sonic.size
    sim_cs, se_cs = jackknife(var_c, var_s)
    theory, th_cs = math.sqrt(v_lidar / v_cup), math.sqrt(v_cup / v_sonic)
    base = {"scene": f"conical {height:g} m", "n": n_periods, "duration": duration, "box": shape, "t_sim": t_sim,
            "t_theory": time.perf_counter() - t0}
    return [dict(base, stat="std ratio lidar/cup", sim=sim, se=se, theory=theory, z=(sim - theory) / se,
                 sd_one=se * math.sqrt(n_periods)),
            dict(base, stat="std ratio cup/sonic", sim=sim_cs, se=se_cs, theory=th_cs, z=(sim_cs - th_cs) / se_cs,
                 sd_one=se_cs * math.sqrt(n_periods))]


# --------------------------------------------------------------------------
# nacelle: the bundled scene's lidar against the rotor
# --------------------------------------------------------------------------
def nacelle_case(n_periods, duration, *, focus=100.0, seed0=2000, break_=None, spacing=None, interpolation="none",
                 aliases=1, phases=2):
    """Simulated and theoretical lidar/rotor std ratio and correlation at the preview delay (module notes).

    ``break_``: ``"no_cells"`` the continuous probe over the whole beam (no span, no mean-wind tail),
    ``"yaw"`` the theory's lidar yawed by 10 deg, ``"no_delay"`` the looks' times dropped.  ``spacing``: the box's
    (dx, dy, dz) [m] instead of the scene's.  ``phases``: scan phases averaged (evenly over the revolution).
    """
    scene = bundled_scene("nacelle")
    p = scene.periods[0]
    s = scene.scan
    U, params = p.mean_speed, scene.period_params(p)
    lid = scene.sensor(p, (focus,)).replace(tier="los")
    rotor_disc = RotorDisc(s.rotor_radius, s.rotor_exponent)
    dt, epr = lid.dwell_time, lid.estimates_per_rev
    m = int(round((lid.preview_distance(focus) / U - 0.5 * (lid.revolution_time - dt)) / dt))
    var_l, var_r, cov = [], [], []
    t0 = time.perf_counter()
    for i in range(n_periods):
        sp = s.spacing if spacing is None else spacing
        box = cover_box(lid.box_region(min(np.atleast_1d(sp)), s.rotor_radius), U, duration, params, seed0 + i,
                        spacing=sp, lateral_doubling=s.lateral_doubling)
        rec = measure_nacelle(box, lid, duration, U)
        u_e = rec.vlos_e / rec.direction_ec[:, 0]
        c = np.concatenate([[0.0], np.cumsum(u_e)])
        est = (c[epr:] - c[:-epr]) / epr  # estimate i + epr - 1: the revolution ending there
        pos = lid.position
        rews = rews_from_box(box, rotor_disc, pos[1], pos[2], x=pos[0], times=rec.time_e, U=U)
        a = est[: est.size - m]
        b = rews[epr - 1 + m:]
        a, b = a - a.mean(), b - b.mean()
        var_l.append(np.mean(a * a)), var_r.append(np.mean(b * b)), cov.append(np.mean(a * b))
        n_s = a.size
        if i == 0:
            shape, spacing = box.attrs["generated_shape"], tuple(float(box[c][1] - box[c][0]) for c in "xyz")
            nodes = box_rotor_nodes(s.rotor_radius, s.rotor_exponent, box["y"].values, box["z"].values, pos[1], pos[2])
        del box
    t_sim = time.perf_counter() - t0
    ratio, se_ratio = jackknife(var_l, var_r)
    corr, se_corr = jackknife(var_l, var_r, cov)
    t0 = time.perf_counter()
    lid_th = lid.replace(position=(0.0, 0.0, 0.0))
    if break_ == "yaw":
        lid_th = lid_th.replace(yaw_misalignment_deg=10.0)
    ests = []
    for j in range(phases):  # the trailing mean is cyclostationary: its statistics average the scan's phases
        rotor, est_f = th.nacelle_functionals(lid_th, focus, U, nodes, n_beams=None, preview_shift=m * dt,
                                              probe="continuous" if break_ == "no_cells" else "cells",
                                              phase=(j * epr) // phases)
        if break_ == "no_delay":
            looks = est_f.looks
            est_f = lt.LinearFunctional(lt.Looks(looks.point_lc, looks.direction_lc, None, looks.probe_l),
                                        est_f.weight_olc, est_f.names)
        ests.append(est_f)
    T = n_s * dt
    # the package's lattice (campaign.periods.nacelle_lattice, every row here): the correlation the plain lattice's,
    # the variances read as the sampler reads the box (the lidar trilinearly, the rotor's REWS linearly along x)
    r = lattice_statistics(params, rotor, ests, U, T, dt, shape, spacing, interpolation=interpolation,
                           aliases=aliases, all_rows=True)
    vl, vr, th_corr = r["lidar_var"], r["rotor_var"], r["correlation"]
    t_th = time.perf_counter() - t0
    base = {"n": n_periods, "duration": duration, "box": tuple(shape), "t_sim": t_sim, "t_theory": t_th,
            "variances": {"sim lidar": float(np.mean(var_l)), "sim rotor": float(np.mean(var_r)), "theory lidar": vl,
                          "theory rotor": vr}}
    th_ratio = math.sqrt(vl / vr)
    return [dict(base, scene=f"nacelle {focus:g} m", stat="std ratio lidar/rotor", sim=ratio, se=se_ratio,
                 theory=th_ratio, z=(ratio - th_ratio) / se_ratio, sd_one=se_ratio * math.sqrt(n_periods)),
            dict(base, scene=f"nacelle {focus:g} m", stat="correlation lidar-rotor", sim=corr, se=se_corr,
                 theory=th_corr, z=(corr - th_corr) / se_corr, sd_one=se_corr * math.sqrt(n_periods))]


# --------------------------------------------------------------------------
# WindScanner: the three beams' reconstructed (u, v, w) against the sonic at the common focus
# --------------------------------------------------------------------------
def windscanner_scene(duration, *, spacing=None):
    """The bundled WindScanner scene (published layout, 4-m box, tier los), its first period (8 m/s) lasting
    ``duration``."""
    sc = bundled_scene("windscanner")
    values = {"duration": float(duration), "scanner.segment_duration": float(duration) / 3.0, "lidar.tier": "los"}
    if spacing is not None:
        values["scanner.spacing"] = float(spacing)
    return sc.replace(periods=(sc.periods[0],)).with_values(values)


def windscanner_simulate(n_periods, duration, *, seed0=5000, spacing=None):
    """``n_periods`` paired periods (box, the three units and the sonic from seed ``seed0 + i``): within-period
    variances (1/N) of the reconstructed and the sonic's (u, v, w), and the box's grid."""
    from cwlidar_sim.analysis.reconstruction import reconstruct_uvw
    from cwlidar_sim.campaign.periods.windscanner import period_record
    from cwlidar_sim.sensors.windscanner import record_steps

    sc = windscanner_scene(duration, spacing=spacing)
    var_l, var_s = [], []
    t0 = time.perf_counter()
    for i in range(n_periods):
        box, rec, sonic_kc, time_k, _ = period_record(sc.replace(seed=seed0 + i), 0)
        steps = record_steps(rec)
        uvw = reconstruct_uvw(steps["direction_kic"], steps["vlos_ki"]).uvw_kc  # tier 1: the signed ideal speeds
        var_l.append(uvw.var(axis=0)), var_s.append(sonic_kc.var(axis=0))
        if i == 0:
            grid = {"shape": tuple(int(n) for n in box.attrs["generated_shape"]),
                    "spacing": tuple(float(box[c][1] - box[c][0]) for c in "xyz"),
                    "origin": tuple(float(box[c][0]) for c in "xyz"), "n_t": int(time_k.size)}
        del box
    return {"scene": sc, "var_l": np.array(var_l), "var_s": np.array(var_s), "t_sim": time.perf_counter() - t0,
            "n": n_periods, "duration": duration, **grid}


def windscanner_theory(sim, *, probe="cells", sonic="nodes", aliases=0):
    """The lattice theory of ``windscanner_simulate``'s box (``scanner_theory.windscanner_lattice_variances``: the
    range cells read trilinearly, the sonic between the box's nodes) and the continuum's beside it: within-period
    variances of the reconstructed and the sonic's (u, v, w)."""
    sc = sim["scene"]
    ws, p = sc.sensor(), sc.periods[0]
    params, U = sc.period_params(p), p.mean_speed
    dt = 1.0 / ws.instrument.estimate_rate
    t0 = time.perf_counter()
    lat = st.windscanner_lattice_variances(ws, params, U, sim["shape"], sim["spacing"], sim["origin"], sim["n_t"],
                                           probe=probe, sonic=sonic, aliases=aliases)
    t_lat = time.perf_counter() - t0
    t0 = time.perf_counter()
    stats = [lt.PeriodStatistic(f"{j}.{c}", sim["n_t"] * dt, dt) for j in range(2) for c in "uvw"]
    a = lt.adaptive_spectra(params, list(st.windscanner_functionals(ws, probe=probe)), U, stats, k1_range=(1e-4, 2.0),
                            resolution=20.0)
    cont = np.array(a.within)
    return {**lat, "continuum_lidar": cont[:3], "continuum_sonic": cont[3:], "t_lattice": t_lat,
            "t_continuum": time.perf_counter() - t0}


def windscanner_case(n_periods, duration, *, seed0=5000, spacing=None, aliases=0):
    """Simulated and theoretical std ratios reconstructed/sonic of u, v, w (pooled, jackknife SE): three rows."""
    sim = windscanner_simulate(n_periods, duration, seed0=seed0, spacing=spacing)
    t = windscanner_theory(sim, aliases=aliases)
    out = []
    for c, name in enumerate("uvw"):
        r, se = jackknife(sim["var_l"][:, c], sim["var_s"][:, c])
        theory = math.sqrt(t["lidar"][c] / t["sonic"][c])
        out.append({"scene": f"windscanner {sim['spacing'][0]:g} m", "stat": f"std ratio {name} recon/sonic",
                    "sim": r, "se": se, "theory": theory, "z": (r - theory) / se, "sd_one": se * math.sqrt(n_periods),
                    "continuum": math.sqrt(t["continuum_lidar"][c] / t["continuum_sonic"][c]), "n": n_periods,
                    "duration": duration, "box": sim["shape"], "t_sim": sim["t_sim"],
                    "t_theory": t["t_lattice"] + t["t_continuum"],
                    "variances": {"sim lidar": float(sim["var_l"][:, c].mean()),
                                  "sim lidar se": float(sim["var_l"][:, c].std(ddof=1) / math.sqrt(n_periods)),
                                  "sim sonic": float(sim["var_s"][:, c].mean()),
                                  "sim sonic se": float(sim["var_s"][:, c].std(ddof=1) / math.sqrt(n_periods)),
                                  "lattice lidar": t["lidar"][c],
                                  "lattice sonic": t["sonic"][c], "continuum lidar": t["continuum_lidar"][c],
                                  "continuum sonic": t["continuum_sonic"][c]}})
    return out


def windscanner_w_box(duration, spacings=(4.0, 2.0)):
    """The WindScanner's variances over each box against the continuum (module notes, "the w finding"): printed rows
    of lattice / continuum for the reconstruction (the box's modes alone, then read trilinearly) and the sonic."""
    from cwlidar_sim.turbulence.cover import plan_box

    for sp in spacings:
        sc = windscanner_scene(duration, spacing=sp)
        ws, p = sc.sensor(), sc.periods[0]
        params, U = sc.period_params(p), p.mean_speed
        dt = 1.0 / ws.instrument.estimate_rate
        n_t = int(round(duration / dt))
        plan = plan_box(ws.box_region(sp), U, duration, sp, min_extent=2.0 * params.length_scale)
        shape, d = (plan.shape[0], 2 * plan.shape[1], plan.shape[2]), (sp,) * 3  # generated: laterally doubled
        stats = [lt.PeriodStatistic(f"{j}.{c}", n_t * dt, dt) for j in range(2) for c in "uvw"]
        cont = {pr: np.array(lt.adaptive_spectra(params, list(st.windscanner_functionals(ws, probe=pr)), U, stats,
                                                 k1_range=(1e-4, 2.0), resolution=20.0).within)
                for pr in ("continuous", "cells")}
        recon, _ = st.windscanner_functionals(ws, probe="cells")
        nodes = lt.lattice_spectra(params, recon, U, shape, d)
        v_nodes = np.array([_within(nodes, c, U, n_t * dt, dt) for c in "uvw"])
        lat = st.windscanner_lattice_variances(ws, params, U, shape, d, tuple(plan.origin), n_t)
        c = cont["cells"]
        print(f"box {sp:g} m {shape}, {duration:g}-s periods, (u, v, w):\n"
              f"  continuum: reconstruction, continuous weighting {np.round(cont['continuous'][:3], 5)}, range cells "
              f"{np.round(c[:3], 5)}; sonic {np.round(c[3:], 5)}\n"
              f"  lattice / continuum (cells): reconstruction, the box's modes {np.round(v_nodes / c[:3], 4)}, read "
              f"trilinearly {np.round(lat['lidar'] / c[:3], 4)}; sonic between the nodes "
              f"{np.round(lat['sonic'] / c[3:], 4)}"
              f"\n  variance ratio reconstruction / sonic: continuum {np.round(c[:3] / c[3:], 4)}, lattice "
              f"{np.round(lat['lidar'] / lat['sonic'], 4)}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--periods", type=int, default=6)
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--heights", type=float, nargs="*", default=[40.0, 100.0])
    ap.add_argument("--sub-dwells", type=int, default=2)
    ap.add_argument("--interpolation", choices=("none", "linear"), default="linear")
    ap.add_argument("--aliases", type=int, default=0)
    ap.add_argument("--no-nacelle", action="store_true")
    ap.add_argument("--kind", choices=("conical", "nacelle", "windscanner"), nargs="*", default=["conical", "nacelle"],
                    help="the scenes compared (default conical and nacelle)")
    ap.add_argument("--spacing", type=float, default=None,
                    help="the WindScanner's box spacing [m] (default the scene's)")
    ap.add_argument("--seed0", type=int, default=5000, help="the WindScanner's first seed")
    ap.add_argument("--w-box", type=float, nargs="*", default=None, metavar="SPACING",
                    help="print the WindScanner's lattice / continuum variances for these box spacings [m] and stop")
    args = ap.parse_args(argv)
    if args.w_box is not None:
        return windscanner_w_box(args.duration, tuple(args.w_box) or (4.0, 2.0))
    kw = {"interpolation": args.interpolation, "aliases": args.aliases}
    out = []
    if "conical" in args.kind:
        out += [r for z in args.heights for r in conical_case(z, args.periods, args.duration,
                                                              sub_dwells=args.sub_dwells, **kw)]
    if "nacelle" in args.kind and not args.no_nacelle:
        out += nacelle_case(args.periods, args.duration, **kw)
    if "windscanner" in args.kind:
        out += windscanner_case(args.periods, args.duration, seed0=args.seed0, spacing=args.spacing,
                                aliases=args.aliases)
    for r in out:
        need = math.ceil((r["sd_one"] / 0.005) ** 2)
        extra = f" continuum {r['continuum']:.4f}" if "continuum" in r else ""
        print(f"{r['scene']:16s} {r['stat']:26s} sim {r['sim']:.4f} +/- {r['se']:.4f}  theory {r['theory']:.4f}  "
              f"z {r['z']:+.2f}{extra}  (N={r['n']}, T={r['duration']:g} s, box {r['box']}, sim {r['t_sim']:.0f} s, "
              f"theory {r['t_theory']:.0f} s; SE 0.005 needs N ~ {need} of these)")
        if "variances" in r:
            v = r["variances"]
            print("    variances [m^2 s^-2]: " + ", ".join(
                f"{k} {x:.5f}" + (f" +/- {v[k + ' se']:.5f}" if k + " se" in v else "")
                for k, x in v.items() if not k.endswith(" se")))


if __name__ == "__main__":
    main()
