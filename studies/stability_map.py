"""Stability map: where each Doppler estimator and each transfer-function method fails.

    python studies/stability_map.py [--quick] [--out DIR]

Not a benchmark (no timing): a sweep run by hand that writes
``stability_map.json``, ``stability_table.md`` and ``stability_map.png`` to DIR
(default ``results/stability``); ``docs/stability.md`` holds the table and the
criteria, ``docs/stability_map.png`` the map.

Sweeps (tier 2 ``spectral`` through :func:`cwlidar_sim.signal.simulate_uniform`,
the engine of ``cwlidar-sim doppler``; both presets; ``--n`` estimates per point)
-------------------------------------------------------------------------------
* CNR from +10 dB down to -40 dB (nothing left) x estimator, at 8 m/s;
* threshold kind (sigma / snr / peak_fraction) x level x CNR, median estimator;
* line-of-sight speed 0 .. 1.3 x Nyquist (through the near-zero region) x estimator, CNR -10 dB;
* cloud strength (integrated backscatter relative to the aerosol's per metre)
  at 1600 m moving at 3 m/s, target 8 m/s, CNR -10 dB;
* picket fence: speed ``(100 + delta)`` bins, delta in [0, 1), window rect / hann,
  line width set by the transverse speed (0: frozen speckle, the narrowest line,
  to 20 m/s), median and centroid, CNR +10 dB.

Sweeps of the staring scene (A2012 period C, tier ``spectral``, ``--duration``
s, 30-s segments): CNR, misalignment, sonic offset across the beam, turbulence
intensity (alpha_eps scaled by s^2 for sigma_u x s), each one at a time
around the base, with the estimators as processing variants.

Failure criteria (stated here and in docs/stability.md)
--------------------------------------------------------
Estimators, per point:
* ``unavailable``: availability (usable: finite, not NEAR_ZERO / NEAR_NYQUIST) < 0.5;
* ``biased``: |mean - |V|| > 0.25 bin over the finite estimates;
* ``noisy``: standard deviation > 2 bins;
* ``aliased``: |V| > Nyquist (the spectrum cannot tell; the doppler report warns).
Transfer functions, per run (k over the log bins, from the lowest up):
* method 1 (T1 = F_vr / F_vs) stops at the first bin where T1 exceeds twice
  the theory of the simulated probe volume (the estimator's noise floor is
  as large as the filtered signal);
* method 2 (T2 = Re(chi)^2 / F_vs^2) stops at the first bin where T2 is NaN,
  <= 0 or below twice its own sampling uncertainty (coherence lost).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
from _protocol import log, machine, write_json  # noqa: E402

ESTIMATORS = ("median", "centroid", "peak", "peak_parabolic", "peak_gaussian", "ml")
BIAS_BINS, STD_BINS, AVAIL_MIN = 0.25, 2.0, 0.5


def _point(inst, speed, cnr, n, seed, **kw):
    from cwlidar_sim.signal import simulate_uniform

    est, info = simulate_uniform(speed, cnr, instrument=inst, n=n, seed=seed, **kw)
    ok = est.speed_e[np.isfinite(est.speed_e)]
    truth = abs(speed)
    fl = est.flag_counts()
    r = {"availability": est.availability, "valid_fraction": est.valid_fraction,
         "bias": float(ok.mean() - truth) if ok.size else float("nan"),
         "std": float(ok.std()) if ok.size > 1 else float("nan"),
         "flags": {k: v / est.n for k, v in fl.items() if v}}
    b = inst.bin_speed
    fail = []
    if r["availability"] < AVAIL_MIN:
        fail.append("unavailable")
    if math.isfinite(r["bias"]) and abs(r["bias"]) > BIAS_BINS * b:
        fail.append("biased")
    if math.isfinite(r["std"]) and r["std"] > STD_BINS * b:
        fail.append("noisy")
    if truth > inst.nyquist_speed:
        fail.append("aliased")
    r["fail"] = fail
    return r


def doppler_sweeps(quick, n):
    from cwlidar_sim.signal.instrument import preset

    out = []
    cnrs = np.arange(10.0, -40.1, -5.0 if quick else -2.5)
    for pname in ("prototype", "cs"):
        inst = preset(pname)
        ests = ESTIMATORS[:3] if quick else ESTIMATORS
        for e in ests:
            for c in cnrs:
                out.append(dict(sweep="cnr", preset=pname, estimator=e, cnr_db=float(c), speed=8.0,
                                **_point(inst, 8.0, float(c), n, 1, estimator=e)))
        for kind, levels in (("sigma", (3.0, 4.0, 6.0)), ("snr", (0.05, 0.1, 0.3)), ("peak_fraction", (0.3, 0.5))):
            for lv in levels:
                ik = inst.replace(threshold_kind=kind, threshold_value=lv)
                for c in (-40.0, -25.0, -20.0, -15.0, -10.0, 0.0):
                    out.append(dict(sweep="threshold", preset=pname, estimator="median", threshold_kind=kind,
                                    threshold_value=lv, cnr_db=c, speed=8.0, **_point(ik, 8.0, c, n, 2)))
        nyq = inst.nyquist_speed
        speeds = [0.0, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 5.0, 10.0, nyq - 1.0, nyq - 0.3, nyq,
                  nyq + 0.5, 1.1 * nyq, 1.3 * nyq]
        for e in ests:
            for v in speeds:
                out.append(dict(sweep="speed", preset=pname, estimator=e, cnr_db=-10.0, speed=float(v),
                                **_point(inst, float(v), -10.0, n, 3, estimator=e)))
        for cw in (0.0, 1e2, 1e3, 1e4, 1e5, 1e6):
            for e in ("median", "centroid", "peak"):
                r = _point(inst, 8.0, -10.0, n, 4, estimator=e, cloud_range=1600.0, cloud_weight=cw, cloud_speed=3.0)
                out.append(dict(sweep="cloud", preset=pname, estimator=e, cnr_db=-10.0, speed=8.0, cloud_weight=cw,
                                **r))
        deltas = np.arange(0.0, 1.0, 0.1 if quick else 0.05)
        for window in ("rect", "hann"):
            iw = inst.replace(window=window)
            for vt in ((0.0, 5.0) if quick else (0.0, 1.0, 5.0, 20.0)):
                for e in ("median", "centroid"):
                    for d in deltas:
                        v = (100.0 + d) * inst.bin_speed
                        r = _point(iw, v, 10.0, max(200, n // 5), 5, estimator=e, transverse_speed=vt)
                        out.append(dict(sweep="picket", preset=pname, estimator=e, window=window,
                                        transverse_speed=vt, delta_bins=float(d), cnr_db=10.0, speed=v,
                                        bias_bins=r["bias"] / inst.bin_speed, **r))
    return out


def _usable_k(k, T, sigma, theory, method, n_k):
    """Upper wavenumber of the contiguous usable band from the lowest bin (module criteria).

    Bins holding no periodogram value (``n_k == 0``: below the segments' lowest
    wavenumber, or log bins narrower than its spacing) are skipped.
    """
    last = float("nan")
    for i in np.flatnonzero(n_k > 0):
        if method == 1:
            good = np.isfinite(T[i]) and T[i] <= 2.0 * theory[i]
        else:
            good = np.isfinite(T[i]) and T[i] > 0 and (not np.isfinite(sigma[i]) or T[i] > 2.0 * sigma[i])
        if not good:
            break
        last = float(k[i])
    return last


def tf_sweeps(quick, duration):
    from cwlidar_sim.campaign import bundled_scene, run_scene

    sc = bundled_scene("a2012")
    (pc,) = [p for p in sc.periods if p.name == "C"]
    base = sc.replace(name="stability", duration=duration, periods=(dataclasses.replace(pc, duration=None),),
                      lidar=dataclasses.replace(sc.lidar, variants=({"name": "centroid", "estimator": "centroid"},
                                                                     {"name": "peak", "estimator": "peak"})),
                      analysis=dataclasses.replace(sc.analysis, fit=False, segment_duration=30.0))
    t = base.turbulence
    runs = [("base", {})]
    runs += [(f"cnr {c:g} dB", {"cnr": c}) for c in ((-25.0, -20.0, -15.0, -5.0) if not quick else (-22.0, -15.0))]
    runs += [(f"misalignment {m:g} deg", {"theta": m}) for m in ((0.0, 6.0) if quick else (0.0, 3.5, 6.0))]
    runs += [(f"sonic offset y {o:g} m", {"offset": o}) for o in ((2.0,) if quick else (1.0, 3.0))]
    runs += [(f"sigma_u x {s:g}", {"turb": s}) for s in ((0.5, 2.0))]
    out = []
    for label, ch in runs:
        s = base
        if "cnr" in ch:
            s = s.replace(lidar=dataclasses.replace(s.lidar, cnr_db=ch["cnr"]))
        if "theta" in ch:
            s = s.replace(periods=(dataclasses.replace(s.periods[0], misalignment_deg=ch["theta"]),))
        if "offset" in ch:
            s = s.replace(sonic=dataclasses.replace(s.sonic, offset=(0.0, ch["offset"], 0.0)),
                          field=dataclasses.replace(s.field, kind="auto"))
        if "turb" in ch:
            s = s.replace(turbulence=dataclasses.replace(t, alpha_eps=t.alpha_eps * ch["turb"] ** 2))
        t0 = time.perf_counter()
        ds = run_scene(s, progress=False)
        k = ds["k"].values
        th = ds["transfer_theory_cells"].values
        nk = ds["n_k"].values[0]
        row = {"label": label, "field_kind": str(ds["field_kind"].values[0]), "wall_s": time.perf_counter() - t0,
               "availability": float(ds["availability"].values[0])}
        series = {"median": (ds["transfer_ratio"].values[0], ds["transfer_cross"].values[0],
                             ds["transfer_cross_sigma"].values[0])}
        for i, vname in enumerate(ds["variant"].values):
            series[str(vname)] = (ds["transfer_ratio_variant"].values[i, 0], ds["transfer_cross_variant"].values[i, 0],
                                  ds["transfer_cross_sigma"].values[0])  # the main processing's sigma (same segments)
        for est, (T1, T2, sT2) in series.items():
            row[f"k1_{est}"] = _usable_k(k, T1, None, th, 1, nk)
            row[f"k2_{est}"] = _usable_k(k, T2, sT2, th, 2, nk)
        row["nan_fraction_T2"] = float(np.mean(~np.isfinite(ds["transfer_cross"].values[0][nk > 0])))
        out.append(row)
        log(f"  tf {label}: method 1 to {row['k1_median']:.3g}, method 2 to {row['k2_median']:.3g} rad/m "
            f"({row['wall_s']:.0f} s)")
    return out


def table(dop, tf):
    lines = ["| preset | sweep | setting | estimator | fails where (criteria above) |", "|---|---|---|---|---|"]

    def span(rows, key):
        bad = [r[key] for r in rows if r["fail"]]
        if not bad:
            return "nowhere in the sweep"
        kinds = sorted({f for r in rows for f in r["fail"]})
        return f"{key} in [{min(bad):.3g}, {max(bad):.3g}] ({', '.join(kinds)})"

    for p in ("prototype", "cs"):
        for e in ESTIMATORS:
            rows = [r for r in dop if r["sweep"] == "cnr" and r["preset"] == p and r["estimator"] == e]
            if rows:
                bad = [r["cnr_db"] for r in rows if r["fail"]]
                lines.append(f"| {p} | CNR | 8 m/s | {e} | "
                             f"{'CNR <= %.3g dB' % max(bad) if bad else 'nowhere'} "
                             f"({', '.join(sorted({f for r in rows for f in r['fail']}))}) |")
        for e in ESTIMATORS:
            rows = [r for r in dop if r["sweep"] == "speed" and r["preset"] == p and r["estimator"] == e]
            if rows:
                lo = [r["speed"] for r in rows if r["fail"] and r["speed"] < 5]
                hi = [r["speed"] for r in rows if r["fail"] and r["speed"] >= 5]
                lines.append(f"| {p} | speed | CNR -10 dB | {e} | "
                             f"{'|V| <= %.3g m/s' % max(lo) if lo else '-'}; {'|V| >= %.3g m/s' % min(hi) if hi else '-'} |")
        for kind in ("sigma", "snr", "peak_fraction"):
            rows = [r for r in dop if r["sweep"] == "threshold" and r["preset"] == p and r["threshold_kind"] == kind]
            for lv in sorted({r["threshold_value"] for r in rows}):
                rr = [r for r in rows if r["threshold_value"] == lv]
                fa = [r for r in rr if r["cnr_db"] == -40.0][0]
                bad = [r["cnr_db"] for r in rr if r["fail"] and r["cnr_db"] > -40]
                lines.append(f"| {p} | threshold {kind} {lv:g} | median | median | "
                             f"{'CNR <= %.3g dB' % max(bad) if bad else 'nowhere above -40 dB'}; "
                             f"false alarms at -40 dB {fa['valid_fraction']:.3f} |")
        for e in ("median", "centroid", "peak"):
            rows = [r for r in dop if r["sweep"] == "cloud" and r["preset"] == p and r["estimator"] == e]
            bad = [r["cloud_weight"] for r in rows if r["fail"]]
            sp = max(r["flags"].get("SECOND_PEAK", 0.0) for r in rows)
            lines.append(f"| {p} | cloud at 1600 m | target 8, cloud 3 m/s | {e} | "
                         f"{'weight >= %.3g m' % min(bad) if bad else 'nowhere'}; SECOND_PEAK up to {sp:.2f} |")
        for w in ("rect", "hann"):
            for e in ("median", "centroid"):
                rows = [r for r in dop if r["sweep"] == "picket" and r["preset"] == p and r["window"] == w
                        and r["estimator"] == e]
                for vt in sorted({r["transverse_speed"] for r in rows}):
                    b = [r["bias_bins"] for r in rows if r["transverse_speed"] == vt]
                    lines.append(f"| {p} | picket fence, {w}, v_perp {vt:g} m/s | CNR +10 dB | {e} | "
                                 f"bias {min(b):+.3f} .. {max(b):+.3f} bin over the sub-bin position |")
    lines += ["", "| staring run | field | availability | method 1 usable to k [rad/m] (median / centroid / peak) "
              "| method 2 usable to k [rad/m] (median / centroid / peak) |", "|---|---|---|---|---|"]
    for r in tf:
        k1 = " / ".join(f"{r[f'k1_{e}']:.3g}" for e in ("median", "centroid", "peak"))
        k2 = " / ".join(f"{r[f'k2_{e}']:.3g}" for e in ("median", "centroid", "peak"))
        lines.append(f"| {r['label']} | {r['field_kind']} | {r['availability']:.3f} | {k1} | {k2} |")
    return "\n".join(lines) + "\n"


def figure(dop, tf, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 3, figsize=(17, 9.5))
    mk = {"prototype": "-", "cs": "--"}
    # 1: availability vs CNR per estimator
    a = ax[0, 0]
    for p in ("prototype", "cs"):
        for i, e in enumerate(ESTIMATORS):
            rows = [r for r in dop if r["sweep"] == "cnr" and r["preset"] == p and r["estimator"] == e]
            if rows:
                a.plot([r["cnr_db"] for r in rows], [r["availability"] for r in rows], mk[p], color=f"C{i}",
                       label=f"{e}" if p == "prototype" else None)
    a.axhline(AVAIL_MIN, color="k", lw=0.8, ls=":")
    a.set(xlabel="CNR [dB]", ylabel="availability (usable)", title="CNR at 8 m/s (solid prototype, dashed CS)")
    a.legend(fontsize=7)
    # 2: bias vs speed
    a = ax[0, 1]
    for p in ("prototype", "cs"):
        for i, e in enumerate(ESTIMATORS):
            rows = [r for r in dop if r["sweep"] == "speed" and r["preset"] == p and r["estimator"] == e]
            if rows:
                nyq = rows[-1]["speed"] / 1.3
                a.plot([r["speed"] / nyq for r in rows], [r["bias"] for r in rows], mk[p], color=f"C{i}", marker=".")
                bad = [r for r in rows if r["fail"]]
                a.scatter([r["speed"] / nyq for r in bad], [r["bias"] if math.isfinite(r["bias"]) else 0 for r in bad],
                          marker="x", color="r", s=18, zorder=3)
    a.axvline(1.0, color="k", lw=0.8, ls=":")
    a.set(xlabel="|V| / Nyquist", ylabel="bias [m/s]", title="speed, CNR -10 dB (x: failing)")
    a.set_xscale("symlog", linthresh=0.01)
    a.set_yscale("symlog", linthresh=0.01)
    # 3: threshold
    a = ax[0, 2]
    j = 0
    for kind in ("sigma", "snr", "peak_fraction"):
        rows = [r for r in dop if r["sweep"] == "threshold" and r["preset"] == "prototype" and r["threshold_kind"] == kind]
        for lv in sorted({r["threshold_value"] for r in rows}):
            rr = [r for r in rows if r["threshold_value"] == lv]
            a.plot([r["cnr_db"] for r in rr], [r["availability"] for r in rr], marker="o", color=f"C{j}",
                   label=f"{kind} {lv:g}")
            a.plot([r["cnr_db"] for r in rr], [r["valid_fraction"] - r["availability"] + 1e-4 for r in rr], ":",
                   color=f"C{j}")
            j += 1
    a.set(xlabel="CNR [dB]", ylabel="availability (solid); finite but suspect (dotted)",
          title="threshold kind and level, prototype, median")
    a.legend(fontsize=7)
    # 4: picket fence
    a = ax[1, 0]
    j = 0
    for p in ("prototype", "cs"):
        for w in ("rect", "hann"):
            for e in ("median", "centroid"):
                rows = [r for r in dop if r["sweep"] == "picket" and r["preset"] == p and r["window"] == w
                        and r["estimator"] == e and r["transverse_speed"] == 0.0]
                a.plot([r["delta_bins"] for r in rows], [r["bias_bins"] for r in rows], mk[p], color=f"C{j}",
                       label=f"{p} {w} {e}")
                j += 1
    a.axhspan(-BIAS_BINS, BIAS_BINS, color="g", alpha=0.08)
    a.set(xlabel="sub-bin position of the line [bin]", ylabel="bias [bin]",
          title="picket fence, frozen speckle (narrowest line), CNR +10 dB")
    a.legend(fontsize=6)
    # 5: cloud
    a = ax[1, 1]
    for p in ("prototype", "cs"):
        for i, e in enumerate(("median", "centroid", "peak")):
            rows = [r for r in dop if r["sweep"] == "cloud" and r["preset"] == p and r["estimator"] == e]
            x = [max(r["cloud_weight"], 10.0) for r in rows]
            a.plot(x, [r["bias"] for r in rows], mk[p], color=f"C{i}", marker="o", label=e if p == "prototype" else None)
            a.plot(x, [r["flags"].get("SECOND_PEAK", 0.0) for r in rows], mk[p], color=f"C{i}", alpha=0.4)
    a.set(xscale="log", xlabel="cloud weight at 1600 m [m] (10: none)", ylabel="bias [m/s]; faint: SECOND_PEAK fraction",
          title="cloud at 3 m/s, target 8 m/s, CNR -10 dB")
    a.legend(fontsize=7)
    # 6: transfer functions
    a = ax[1, 2]
    y = np.arange(len(tf))
    def z(x):
        return x if math.isfinite(x) else 0.0

    a.barh(y - 0.2, [z(r["k2_median"]) for r in tf], height=0.4, label="method 2 (coherence)", color="C1")
    a.barh(y + 0.2, [z(r["k1_median"]) for r in tf], height=0.4, label="method 1 (noise floor)", color="C0")
    a.set_yticks(y, [r["label"] for r in tf], fontsize=7)
    a.set(xlabel="usable up to k [rad/m] (median estimator)", title="transfer functions, period C")
    a.legend(fontsize=7)
    for aa in ax.flat:
        aa.grid(True, alpha=0.3)
    fig.suptitle("cwlidar_sim stability map (criteria: availability < 0.5, |bias| > 0.25 bin, std > 2 bins, "
                 "|V| > Nyquist; T1 > 2 x theory; T2 < 2 sigma)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser sweeps (about a minute)")
    ap.add_argument("--out", default=os.path.join("results", "stability"), metavar="DIR")
    ap.add_argument("--n", type=int, default=None, help="estimates per Doppler point (1000; quick 300)")
    ap.add_argument("--duration", type=float, default=None, help="staring period [s] (180; quick 90)")
    ap.add_argument("--replot", action="store_true", help="redo the table and figure from DIR/stability_map.json")
    a = ap.parse_args(argv)
    if a.replot:
        with open(os.path.join(a.out, "stability_map.json")) as f:
            d = json.load(f)
        with open(os.path.join(a.out, "stability_table.md"), "w") as f:
            f.write(table(d["doppler"], d["tf"]))
        figure(d["doppler"], d["tf"], os.path.join(a.out, "stability_map.png"))
        return 0
    n = a.n or (300 if a.quick else 1000)
    t0 = time.perf_counter()
    log("doppler sweeps")
    dop = doppler_sweeps(a.quick, n)
    log(f"  {len(dop)} points ({time.perf_counter() - t0:.0f} s); transfer-function sweeps")
    tf = tf_sweeps(a.quick, a.duration or (90.0 if a.quick else 180.0))
    os.makedirs(a.out, exist_ok=True)
    write_json(os.path.join(a.out, "stability_map.json"), {"machine": machine(), "n": n, "doppler": dop, "tf": tf,
                                                            "criteria": {"availability_min": AVAIL_MIN,
                                                                         "bias_bins": BIAS_BINS, "std_bins": STD_BINS}})
    with open(os.path.join(a.out, "stability_table.md"), "w") as f:
        f.write(table(dop, tf))
    figure(dop, tf, os.path.join(a.out, "stability_map.png"))
    log(f"written {a.out} in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
