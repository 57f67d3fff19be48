"""CS's residual attributed: the lidar/cup std ratio walked from CS's 1-D filter model to the simulation (issue 33).

    python studies/cs_attribution.py --json docs/cs_attribution.json --figure docs/cs_attribution.png
    python studies/cs_attribution.py --from-json docs/cs_attribution.json --figure docs/cs_attribution.png
    python studies/cs_attribution.py --merge A.json B.json --json docs/cs_attribution.json   # heights run apart
    python studies/cs_attribution.py --per-decade 16 --k-max-factor 2   # the grid check (about three times the cost)
    python studies/cs_attribution.py --cut-check 40 100   # step 6 split: the Lorentzian cut at the telescope, then the shape

The bundled ``cs`` scene's lidar (30 deg cone, 1 s revolutions, 50 estimates a revolution, CS's
z_R = 0.0013 r^2 optics) at each height, its VAD fit's u (1 s and 3 s scans) against the cup, by
:mod:`cwlidar_sim.analysis.linear_theory` (the scene's functionals,
:func:`cwlidar_sim.campaign.periods.theory.conical_functionals`), one step at a time:

0. ``cs_kaimal``: CS's filter model, Kaimal spectra, Lorentzian exp(-2 k1 z_R) (``std_ratio_model``);
1. ``cs_mann``: the same with the tensor's one-point spectra (``std_ratio_model_mann``);
2. ``x_only``: the scan's own looks (every sub-dwell at its azimuth and time, the fit on the estimates'
   mid-azimuths) over a field varying along x only, u alone, the whole-line Lorentzian, against the
   point u, infinite periods: CS's model without its rectified-sine layout;
3. ``period``: the statistic the simulation publishes: 10-min periods with their mean removed, the
   fits sampled every 1 s or 3 s (aliasing included), the cup's first-order response sampled at 10 Hz;
4. ``uv_3d``: the full 3-D field, u and v (``quadrature="plane"``): u and v decorrelate across the
   46-115 m circle and along the slanted beams;
5. ``w``: + w's contamination of the fit's u (its tilt across the circle);
6. ``exact``: the beam's own weighting (``weighting = "exact"``, the published numbers') instead of
   the whole-line Lorentzian;
7. ``box``: the sum over the box's own modes (:func:`~cwlidar_sim.analysis.linear_theory.lattice_spectra`,
   the unit's box: spacing z / 20, laterally doubled, the generator's cell correction) instead of the
   continuum, for the fit and for the cup.

Steps 0-3 are evaluated per period template (the scene's six: 6-12 m/s, toward 0, 30, -40 deg) and
averaged as the run's plan does (whole passes: equal weights).  Steps 4-7 cost a plane quadrature
each and are evaluated once per height at the templates' mean speed (9 m/s, toward 0) with one look
per estimate (the fit's mid-azimuths); each step's *change* is added to step 3's template average.
What that costs in accuracy is measured at 40 m by ``--checks`` (U = 6 and 12 m/s, eight sub-dwell
looks) and stored in the JSON.  The 3-s fit is the mean of three 1-s fits of the same azimuths, one
revolution apart: under Taylor's hypothesis its spectrum is the 1-s fit's times
``|sum_j exp(-i j k1 U T_rev)|^2 / 9`` (tested), so only the 1-s functional is integrated.

Not in the theory (module notes of linear_theory): the speed's nonlinearity (|u_h| taken as U + u),
the box's trilinear interpolation between nodes for the lidar's looks, speckle, noise and the
estimator; and the simulated value is the mean of per-period ratios, the theory the ratio of expected
variances.  The simulated ratios are the published run's (docs/cs_reproduce.json), not re-run here.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import machine, write_json  # noqa: E402

from cwlidar_sim.analysis import cs_model  # noqa: E402
from cwlidar_sim.analysis import linear_theory as lt  # noqa: E402
from cwlidar_sim.analysis.linear_theory import period_variance  # noqa: E402
from cwlidar_sim.analysis.rews_theory import beam_transfer  # noqa: E402
from cwlidar_sim.campaign.execution.reproduce import bundled_scene  # noqa: E402
from cwlidar_sim.campaign.periods import theory as th  # noqa: E402
from cwlidar_sim.campaign.scenes.conical import default_spacing  # noqa: E402
from cwlidar_sim.sensors import ConicalLidar, Cup  # noqa: E402
from cwlidar_sim.turbulence import spectra as _spectra  # noqa: E402
from cwlidar_sim.turbulence.cover import plan_box  # noqa: E402

# The x-only quadrature and the cup call one_point_spectra on the same fine grid for the same tensor many
# times (about 20 s a call on 2801 k1): computed once per tensor and grid in this process.
_one_point = _spectra.one_point_spectra
_CACHE = {}


def _cached_one_point(k1, params, **kw):
    key = (params, np.asarray(k1).tobytes(), tuple(sorted(kw.items())))
    if key not in _CACHE:
        _CACHE[key] = tuple(np.array(a, copy=True) for a in _one_point(k1, params, **kw))
    return tuple(a.copy() for a in _CACHE[key])


_spectra.one_point_spectra = _cached_one_point

STEPS = ("cs_kaimal", "cs_mann", "x_only", "period", "uv_3d", "w", "exact", "box")
LABELS = {"cs_kaimal": "CS's model (Kaimal)", "cs_mann": "CS's model (Mann spectra)",
          "x_only": "scan's own looks, x-only field", "period": "10-min periods, sampling, cup",
          "uv_3d": "3-D field: u, v", "w": "+ w", "exact": "exact weighting", "box": "the box's modes"}
SCANS = (1, 3)
U_REF = 9.0
CUP_RATE = 10.0
#: x-only and cup quadrature: log grid over [1e-5, 1e2] rad/m (the x-only field costs one node per k1)
K_FINE = np.geomspace(1e-5, 1e2, 2801)
COMPONENTS = {"uv": (1.0, 1.0, 0.0), "w": (0.0, 0.0, 1.0), "u": (1.0, 0.0, 0.0), "all": (1.0, 1.0, 1.0)}


# --------------------------------------------------------------------------
# the scene's instruments
# --------------------------------------------------------------------------
def scene_lidar(scene, z, toward_deg=0.0, sub_dwells=None):
    """The lidar of a unit at height z as the period builds it (scan turned by ``-toward_deg``), in the field's frame."""
    kw = scene.lidar_fields(scene.scan.spacing or default_spacing(z))
    kw.pop("tier")
    if sub_dwells is not None:
        kw["sub_dwells"] = sub_dwells
    kw["azimuth0_deg"] = float(kw.get("azimuth0_deg", 0.0)) - toward_deg
    return ConicalLidar(heights=(z,), **kw)


def fit_u(lidar, z, U, probe="lorentzian"):
    """The 1-s VAD fit's u as one functional with outputs ``uv`` and ``w`` (its response to u + v and to w).

    ``probe``: ``"lorentzian"`` the whole-line exp(-z_R |q|) of CS's model, ``"exact"`` the lidar's
    own weighting (the simulation's).
    """
    vad = th.conical_functionals(lidar, z, U, revolutions=1)
    looks = vad.looks
    if probe == "lorentzian":
        looks = lt.Looks(looks.point_lc, looks.direction_lc, looks.time_l,
                         lt.lorentzian_probe(lidar.instrument_at(z).rayleigh_length))
    w_lc = vad.weight_olc[0]
    weight_olc = np.stack([w_lc * np.array(COMPONENTS[c]) for c in ("uv", "w")])
    return lt.LinearFunctional(looks, weight_olc, ["uv", "w"])


def only(functional, component):
    """A ``fit_u`` functional's ``uv`` output restricted to ``component`` (``"u"``: its response to u alone)."""
    w = functional.weight_olc[:1] * np.array(COMPONENTS[component])
    return lt.LinearFunctional(functional.looks, w, [component])


def cup_functional(z, U):
    cup = Cup(position=(0.0, 0.0, z))
    return lt.point_functional(cup.position, ("u",), response=lt.first_order_response(cup.distance_constant / U))


def block_gain(k1, U, n_rev, revolution_time=1.0):
    """``|sum_j exp(-i j k1 U T_rev)|^2 / n^2``: a fit of ``n_rev`` revolutions as the mean of its 1-s fits."""
    x = np.asarray(k1, dtype=float) * U * revolution_time
    s = np.sin(0.5 * x)
    small = np.abs(s) < 1e-12
    return np.where(small, 1.0, (np.sin(0.5 * n_rev * x) / (n_rev * np.where(small, 1.0, s))) ** 2)


# --------------------------------------------------------------------------
# ratios from spectra
# --------------------------------------------------------------------------
def _integral(k1, F):
    return float(np.trapezoid(F * k1, np.log(k1)))


def on_fine(k1, F, ref_k, ref_fine):
    """A spectrum on the fine grid: its transfer ``F / ref`` log-log between the nodes (flat below them) times
    ``ref`` (a smooth spectrum known on both grids); nothing above the last node."""
    lk = np.log(K_FINE)
    out = np.exp(np.interp(lk, np.log(k1), np.log(np.maximum(F / ref_k, 1e-300)))) * ref_fine
    out[K_FINE > k1[-1] * (1 + 1e-12)] = 0.0
    return out


def infinite_ratios(F_fit, F_ref, U):
    """sqrt(var fit / var reference) over infinite periods, per scan length (the 3-s fit by block_gain); on K_FINE."""
    ref = _integral(K_FINE, F_ref)
    return {n: math.sqrt(_integral(K_FINE, F_fit * block_gain(K_FINE, U, n)) / ref) for n in SCANS}


def _within(k1, F, U, duration, dt, lines=False):
    if not lines:  # nothing beyond the grid (period_variance would extend its last power law)
        k1 = np.concatenate([k1, k1[-1] * np.array([1.0001, 1.0002])])
        F = np.concatenate([F, [0.0, 0.0]])
    return period_variance(k1, F, U, duration, sample_interval=dt, lines=lines)["within"]


def period_ratios(k1, F_fit, U, cup_within, *, duration=600.0, lines=False):
    """sqrt(within-period var of the fits sampled every n s / the cup's), per scan length.

    ``k1``, ``F_fit``: K_FINE and a spectrum on it, or with ``lines`` a box's lines.
    """
    return {n: math.sqrt(_within(k1, F_fit * block_gain(k1, U, n), U, duration, float(n), lines) / cup_within)
            for n in SCANS}


def cup_within(params, z, U, duration=600.0):
    F = lt.functional_spectra(K_FINE, params, cup_functional(z, U), U, quadrature="x_only").spectrum(0)
    return period_variance(K_FINE, F, U, duration, sample_interval=1.0 / CUP_RATE)["within"]  # its k^-11/3 tail


# --------------------------------------------------------------------------
# steps
# --------------------------------------------------------------------------
def height_params(scene, z, U):
    """The unit's tensor; its alpha_eps (set by U through u*) scales every spectrum alike, so the ratios
    take the tensor at U_REF (one tensor per height: the cached one-point spectra serve every speed)."""
    p, ref = scene.turbulence.params(z, U), scene.turbulence.params(z, U_REF)
    if (p.length_scale, p.gamma) != (ref.length_scale, ref.gamma):
        return p
    return ref


def cheap_steps(scene, z, U, toward_deg=0.0, sub_dwells=None):
    """Steps 0-3 for one period template: {step: {n_rev: ratio}}."""
    params = height_params(scene, z, U)
    lidar = scene_lidar(scene, z, toward_deg, sub_dwells)
    zr = lidar.instrument_at(z).rayleigh_length
    out = {}
    for step, kw in (("cs_kaimal", {"spectrum": "kaimal"}), ("cs_mann", {"spectrum": "mann", "params": params})):
        out[step] = {n: cs_model.model_ratios(z, U, n, half_angle_deg=lidar.half_angle_deg,
                                              revolution_time=lidar.revolution_time, rayleigh_length=zr, n_k=3000,
                                              **kw)["std_ratio"] for n in SCANS}
    u = only(fit_u(lidar, z, U), "u")
    s = lt.functional_spectra(K_FINE, params, [u, lt.point_functional((0.0, 0.0, z), ("u",))], U,
                              quadrature="x_only")
    out["x_only"] = infinite_ratios(s.spectrum(0), s.spectrum(1), U)
    out["period"] = period_ratios(K_FINE, s.spectrum(0), U, cup_within(params, z, U))
    return out


def k_grid(z, per_decade=8, k_max_factor=1.0):
    """The plane quadrature's k1 [rad/m]: ``per_decade`` a decade from 1e-4 to min(1, 30 / z) k_max_factor."""
    k_max = min(1.0, 30.0 / z) * k_max_factor
    n = int(round(per_decade * math.log10(k_max / 1e-4))) + 1
    return np.geomspace(1e-4, k_max, n)


def plane_steps(scene, z, U=U_REF, *, per_decade=8, k_max_factor=1.0, resolution=30.0, sub_dwells=1,
                lattice=True):
    """Steps 3-7 at one speed (toward 0): {step: {n_rev: ratio}}, each from the same lidar and cup."""
    params = height_params(scene, z, U)
    lidar = scene_lidar(scene, z, 0.0, sub_dwells)
    f_lor, f_exact = fit_u(lidar, z, U, "lorentzian"), fit_u(lidar, z, U, "exact")
    t0 = time.perf_counter()
    x = lt.functional_spectra(K_FINE, params, only(f_lor, "u"), U, quadrature="x_only").spectrum(0)
    cup = cup_within(params, z, U)
    out = {"period": period_ratios(K_FINE, x, U, cup)}
    k1 = k_grid(z, per_decade, k_max_factor)
    s = lt.functional_spectra(k1, params, [f_lor, f_exact], U, resolution=resolution)
    t_plane = time.perf_counter() - t0
    point = lt.point_functional((0.0, 0.0, z), ("u",))
    F11_k, F11_fine = (lt.functional_spectra(k, params, point, U, quadrature="x_only").spectrum(0)
                       for k in (k1, K_FINE))

    def fine(F):
        return on_fine(k1, F, F11_k, F11_fine)

    def total(i):  # the fit's u: uv + w (outputs 2 i, 2 i + 1)
        m = s.matrix_kab
        return (m[:, 2 * i, 2 * i] + m[:, 2 * i + 1, 2 * i + 1] + 2.0 * m[:, 2 * i, 2 * i + 1]).real

    out["uv_3d"] = period_ratios(K_FINE, fine(s.matrix_kab[:, 0, 0].real), U, cup)
    out["w"] = period_ratios(K_FINE, fine(total(0)), U, cup)
    out["exact"] = period_ratios(K_FINE, fine(total(1)), U, cup)
    cost = {"plane_s": t_plane, "k1": k1.size}
    if lattice:
        t0 = time.perf_counter()
        spacing = scene.scan.spacing or default_spacing(z)
        bp = plan_box(lidar.box_region(spacing), U, scene.duration, spacing, params=params)
        (nx, ny, nz), d3 = bp.shape, bp.spacing
        shape = (nx, 2 * ny if scene.scan.lateral_doubling else ny, nz)
        rows_all = np.arange(1, nx // 2 + 1)
        dk1 = 2.0 * math.pi / (nx * d3[0])
        rows = rows_all[rows_all * dk1 <= k1[-1] * (1 + 1e-9)]
        fit = lt.LinearFunctional(f_exact.looks, f_exact.weight_olc.sum(axis=0, keepdims=True), ["all"])  # uv + w
        lf = lt.lattice_spectra(params, fit, U, shape, d3, rows=rows)
        lc = lt.lattice_spectra(params, cup_functional(z, U), U, shape, d3)
        cup_box = period_variance(lc.k1_k, lc.spectrum(0), U, scene.duration, sample_interval=1.0 / CUP_RATE,
                                  lines=True)["within"]
        out["box"] = period_ratios(lf.k1_k, lf.spectrum(0), U, cup_box, lines=True)
        out["box_cup_sigma_ratio"] = math.sqrt(cup_box / cup)
        cost.update(lattice_s=time.perf_counter() - t0, box_shape=list(shape), box_spacing=list(d3), rows=int(rows.size))
    return out, cost


def cut_check(scene, z, U=U_REF, *, per_decade=8, k_max_factor=1.0, resolution=30.0):
    """Step 6 split in two at one speed: {probe: {n_rev: ratio}} for the whole-line Lorentzian, the Lorentzian
    cut at the telescope (``weighting = "lorentzian"``) and the exact weighting (fit's u: uv + w)."""
    params = height_params(scene, z, U)
    lidar = scene_lidar(scene, z, 0.0, 1)
    f_lor, f_exact = fit_u(lidar, z, U, "lorentzian"), fit_u(lidar, z, U, "exact")
    inst = lidar.instrument_at(z)
    cut = beam_transfer(inst.focus, "lorentzian", wavelength=inst.wavelength, radius=inst.telescope_radius)
    looks = f_exact.looks
    f_cut = lt.LinearFunctional(lt.Looks(looks.point_lc, looks.direction_lc, looks.time_l, cut), f_exact.weight_olc,
                                ["uv", "w"])
    k1 = k_grid(z, per_decade, k_max_factor)
    s = lt.functional_spectra(k1, params, [f_lor, f_cut, f_exact], U, resolution=resolution)
    point = lt.point_functional((0.0, 0.0, z), ("u",))
    F11_k, F11_fine = (lt.functional_spectra(k, params, point, U, quadrature="x_only").spectrum(0) for k in (k1, K_FINE))
    cup, m, out = cup_within(params, z, U), s.matrix_kab, {}
    for i, name in enumerate(("whole_line_lorentzian", "lorentzian_cut", "exact")):
        tot = (m[:, 2 * i, 2 * i] + m[:, 2 * i + 1, 2 * i + 1] + 2.0 * m[:, 2 * i, 2 * i + 1]).real
        out[name] = period_ratios(K_FINE, on_fine(k1, tot, F11_k, F11_fine), U, cup)
    out["behind_telescope_weight"] = inst.rayleigh_length / (math.pi * inst.focus)
    return out


def templates(scene):
    """The scene's period templates: (name, mean speed, toward [deg])."""
    return [(p.name, p.mean_speed, p.toward_deg) for p in scene.periods]


def run(heights, *, per_decade=8, k_max_factor=1.0, resolution=30.0, checks=True, check_sub_dwells=False, log=print):
    scene = bundled_scene("cs")
    out = {"heights": {}, "settings": {"per_decade": per_decade, "k_max_factor": k_max_factor,
                                       "resolution": resolution, "u_ref": U_REF, "templates": templates(scene)}}
    for z in heights:
        t0 = time.perf_counter()
        per = {name: cheap_steps(scene, z, U, toward) for name, U, toward in templates(scene)}
        avg = {s: {n: float(np.mean([per[p][s][n] for p in per])) for n in SCANS} for s in STEPS[:4]}
        t_cheap = time.perf_counter() - t0
        ref, cost = plane_steps(scene, z, per_decade=per_decade, k_max_factor=k_max_factor, resolution=resolution)
        steps = dict(avg)
        for a, b in zip(STEPS[3:], STEPS[4:]):
            steps[b] = {n: steps[a][n] + ref[b][n] - ref[a][n] for n in SCANS}
        out["heights"][f"{z:g}"] = {"steps": steps, "templates": per, "at_u_ref": ref,
                                    "cost": dict(cost, cheap_s=t_cheap)}
        log(f"z = {z:g} m: " + ", ".join(f"{s} {steps[s][1]:.4f}/{steps[s][3]:.4f}" for s in STEPS)
            + f"  ({json.dumps(cost)})")
    if checks:
        out["checks"] = accuracy_checks(scene, per_decade, k_max_factor, resolution, log, sub_dwells=check_sub_dwells)
    return out


def accuracy_checks(scene, per_decade, k_max_factor, resolution, log=print, z=40.0, sub_dwells=False):
    """What the shortcuts cost, at 40 m: one speed for steps 4-6, one look per estimate."""
    def deltas(ref):
        return {b: {n: ref[b][n] - ref[a][n] for n in SCANS} for a, b in zip(STEPS[3:6], STEPS[4:7])}

    base, _ = plane_steps(scene, z, per_decade=per_decade, k_max_factor=k_max_factor, resolution=resolution,
                          lattice=False)
    checks = {"height": z, "base": deltas(base)}
    speeds = sorted({U for _, U, _ in templates(scene)})
    by_speed = {}
    for U in (speeds[0], speeds[-1]):
        r, _ = plane_steps(scene, z, U, per_decade=per_decade, k_max_factor=k_max_factor, resolution=resolution,
                           lattice=False)
        by_speed[f"{U:g}"] = deltas(r)
    checks["by_speed"] = by_speed
    if sub_dwells:  # eight times the looks
        r8, _ = plane_steps(scene, z, per_decade=per_decade, k_max_factor=k_max_factor, resolution=resolution,
                            lattice=False, sub_dwells=scene.scan.sub_dwells)
        checks[f"sub_dwells_{scene.scan.sub_dwells}"] = deltas(r8)
    log("checks at 40 m: " + json.dumps(checks))
    return checks


# --------------------------------------------------------------------------
# the simulation and the figure
# --------------------------------------------------------------------------
def simulated(path):
    """The published run's ratios ± standard errors per height and scan (docs/cs_reproduce.json)."""
    with open(path, encoding="utf-8") as f:
        h = json.load(f)["heights"]
    return {z: {n: (h[z][f"std_ratio_{n}s"], h[z][f"std_ratio_{n}s_se"]) for n in SCANS} for z in h}


def figure(out, sim, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    zs = sorted(out["heights"], key=float)
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.0), sharey=True)
    x = np.arange(len(STEPS) + 1)
    split = STEPS.index("uv_3d") - 0.5
    for ax, n in zip(axes, SCANS):
        for j, z in enumerate(zs):
            v = [out["heights"][z]["steps"][s][str(n)] for s in STEPS]
            ax.plot(x[:-1], v, "o-", color=f"C{j}", lw=1.3, ms=4.5, label=f"{z} m")
            if z in sim:
                m, se = sim[z][n]
                ax.errorbar(x[-1], m, yerr=se, fmt="s", color=f"C{j}", ms=6, capsize=4, lw=1.5)
                ax.plot([x[-2], x[-1]], [v[-1], m], ":", color=f"C{j}", lw=1.0)
        ax.axvline(split, color="0.5", ls="--", lw=0.8)
        ax.text(split - 0.1, 1.0, "1-D field, per template ", transform=ax.get_xaxis_transform(), ha="right",
                va="top", fontsize=7.5, color="0.35")
        ax.text(split + 0.1, 1.0, " 3-D field, at 9 m/s", transform=ax.get_xaxis_transform(), ha="left",
                va="top", fontsize=7.5, color="0.35")
        ax.set_xticks(x)
        ax.set_xticklabels([LABELS[s] for s in STEPS] + ["simulated ± s.e."], rotation=40, ha="right", fontsize=8)
        ax.set_title(f"{n} s scans")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("lidar / cup standard-deviation ratio")
    axes[0].tick_params(labelleft=True)
    axes[1].tick_params(labelleft=True)
    axes[0].legend(title="height", fontsize=8, title_fontsize=8, loc="lower left")
    fig.suptitle("From CS's filter model to the simulation, one step at a time (linear theory; "
                 "squares: the simulation ± standard error)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def table(out, sim) -> str:
    """Markdown: per height and scan, each step's ratio and change, then the simulation."""
    lines = ["| step | " + " | ".join(f"{z} m, {n} s" for z in sorted(out['heights'], key=float) for n in SCANS) + " |",
             "|---|" + "---|" * (2 * len(out["heights"]))]
    zs = sorted(out["heights"], key=float)
    for i, s in enumerate(STEPS):
        cells = []
        for z in zs:
            st = out["heights"][z]["steps"]
            for n in SCANS:
                v = st[s][str(n)]
                if i == 0:
                    cells.append(f"{v:.3f}")
                else:
                    p = st[STEPS[i - 1]][str(n)]
                    cells.append(f"{v:.3f} ({v - p:+.3f})")
        lines.append(f"| {LABELS[s]} | " + " | ".join(cells) + " |")
    cells = []
    for z in zs:
        for n in SCANS:
            m, se = sim[z][n]
            v = out["heights"][z]["steps"]["box"][str(n)]
            cells.append(f"**{m:.3f} ± {se:.3f}** ({m - v:+.3f})")
    lines.append("| simulated ± s.e. (simulated − theory) | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--heights", type=float, nargs="+", default=[40.0, 100.0])
    ap.add_argument("--per-decade", type=int, default=8, help="k1 of the plane quadrature a decade")
    ap.add_argument("--k-max-factor", type=float, default=1.0, help="times the highest k1, min(1, 30 / z) rad/m")
    ap.add_argument("--resolution", type=float, default=30.0, help="functional_spectra's resolution")
    ap.add_argument("--no-checks", action="store_true", help="skip the 40-m accuracy checks")
    ap.add_argument("--check-sub-dwells", action="store_true", help="also check the sub-dwell looks (8 x the cost)")
    ap.add_argument("--simulated", default=os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                                       "docs", "cs_reproduce.json"))
    ap.add_argument("--json", default=None)
    ap.add_argument("--figure", default=None)
    ap.add_argument("--markdown", default=None)
    ap.add_argument("--from-json", default=None, help="redraw the figure and the table from a stored run")
    ap.add_argument("--merge", nargs="+", default=None, help="stored runs of other heights, joined (the first's "
                    "settings and checks; each run's own machine and wall time under 'runs')")
    ap.add_argument("--cut-check", type=float, nargs="+", default=None, metavar="Z",
                    help="only split step 6 (the cut at the telescope, then the shape) at these heights")
    a = ap.parse_args(argv)
    if a.cut_check:
        scene = bundled_scene("cs")
        for z in a.cut_check:
            print(f"z = {z:g} m:", json.dumps(cut_check(scene, z, per_decade=a.per_decade, k_max_factor=a.k_max_factor,
                                                       resolution=a.resolution)), flush=True)
        return 0
    sim = simulated(a.simulated)
    if a.from_json:
        with open(a.from_json, encoding="utf-8") as f:
            out = json.load(f)
    elif a.merge:
        parts = []
        for path in a.merge:
            with open(path, encoding="utf-8") as f:
                parts.append(json.load(f))
        if any(p["settings"] != parts[0]["settings"] for p in parts):
            raise ValueError("--merge: the runs' settings differ")
        out = {k: v for k, v in parts[0].items() if k not in ("heights", "run", "machine", "time")}
        out["heights"] = {z: h for p in parts for z, h in p["heights"].items()}
        out["checks"] = next((p["checks"] for p in parts if "checks" in p), None)
        out["runs"] = [{"heights": list(p["heights"]), "run": p["run"], "machine": p["machine"], "time": p["time"]}
                       for p in parts]
        if a.json:
            write_json(a.json, out)
    else:
        t, c = time.perf_counter(), time.process_time()
        load0 = os.getloadavg()
        out = run(a.heights, per_decade=a.per_decade, k_max_factor=a.k_max_factor, resolution=a.resolution,
                  checks=not a.no_checks, check_sub_dwells=a.check_sub_dwells)
        out["run"] = {"wall_s": time.perf_counter() - t, "cpu_s": time.process_time() - c,
                      "loadavg_start": list(load0), "loadavg_end": list(os.getloadavg())}
        out = json.loads(json.dumps(out))  # the keys as the stored file has them
        if a.json:
            write_json(a.json, {"machine": machine(), "time": time.strftime("%Y-%m-%dT%H:%M:%S"), **out})
    md = table(out, sim)
    print(md)
    if a.markdown:
        with open(a.markdown, "w", encoding="utf-8") as f:
            f.write(md)
    if a.figure:
        figure(out, sim, a.figure)
    return 0


if __name__ == "__main__":
    sys.exit(main())
