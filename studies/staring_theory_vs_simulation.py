"""A2012 period C at tier ``los``: the simulated transfer functions (methods 1 and 2) against the linear theory.

Paired seeds: each seeded period is its own plane field flown through by the lidar and the sonic; the bins' raw
means (``spectrum_lidar``, ``spectrum_sonic``, ``cross_spectrum_real``) are pooled over the periods and the ratios
formed from the pooled means, with a jackknife standard error over the periods; the theory is
``transfer_ratio_theory`` / ``transfer_cross_theory`` of the results (the period's geometry, range cells, readings'
filters, window kernel and the field's lines along x), and ``transfer_ratio_theory_lattice`` /
``transfer_cross_theory_lattice`` the same on the generated plane's own modes (k2 up to pi / dy, the sub-points and the
sonic read bilinearly across y).  Prints one row per k bin and the z-scores of broad bands against both.

Run (reduced, ~5 min on 2 loaded cores): ``python studies/staring_theory_vs_simulation.py 24 600``; a finer plane
across the wind (dy = 0.25 m): ``... 24 600 0.25``; full size: ``python studies/staring_theory_vs_simulation.py
200 600``.
"""

import math
import sys

import numpy as np

from cwlidar_sim.campaign.execution.reproduce import bundled_scene
from cwlidar_sim.campaign.periods import staring as st

#: Broad bands of k [rad/m] for the acceptance's z-scores (methods 1 and 2 above ~1e-2 of their low-k value).
BANDS = ((0.005, 0.02), (0.02, 0.05), (0.05, 0.1), (0.1, 0.2), (0.2, 0.4))


def period_c(duration, dy=0.5):
    """The bundled A2012 scene's period C alone at tier ``los``, no variants, no fit, ``duration`` s, the plane's dy."""
    sc = bundled_scene("a2012").with_values({"lidar.tier": "los", "lidar.variants": [], "analysis.fit": False,
                                             "duration": float(duration), "field.dy": float(dy)})
    return sc.replace(periods=(sc.periods[2],))


def run(n, duration, dy=0.5, seed0=33000):
    """``n`` seeded periods: per period the bins' F_r, F_s, Re chi, and the theory (the same for all)."""
    rows = []
    for i in range(n):
        sc = period_c(duration, dy).replace(seed=seed0 + i)
        ds = st.run_unit(sc, 0)
        rows.append((ds.spectrum_lidar.values[0], ds.spectrum_sonic.values[0], ds.cross_spectrum_real.values[0]))
    F = np.array(rows)  # (period, 3, k)
    return {"k": ds.k.values, "k_lower": ds.k_lower.values, "k_upper": ds.k_upper.values, "F": F,
            "theory1": ds.transfer_ratio_theory.values[0], "theory2": ds.transfer_cross_theory.values[0],
            "lattice1": ds.transfer_ratio_theory_lattice.values[0],
            "lattice2": ds.transfer_cross_theory_lattice.values[0],
            "old1": ds.transfer_theory_ratio.values[0], "old2": ds.transfer_theory_cross.values[0]}


def pooled(F, band=None, k_lower=None, k_upper=None):
    """``(t1, se1, t2, se2)`` per bin (or over a band's bins, their raw means summed): jackknife over the periods."""
    def stat(m):
        r, s, c = (F[m, j].sum(axis=0) for j in range(3))
        if band is not None:
            r, s, c = r.sum(), s.sum(), c.sum()
        return np.array([r / s, c ** 2 / s ** 2])

    n = F.shape[0]
    if band is not None:
        sel = (k_lower >= band[0]) & (k_upper <= band[1])
        F = F[:, :, sel]
    full = stat(np.ones(n, bool))
    loo = np.array([stat(np.arange(n) != i) for i in range(n)])
    se = np.sqrt((n - 1) / n * np.sum((loo - loo.mean(axis=0)) ** 2, axis=0))
    return full[0], se[0], full[1], se[1]


def band_theory(res, band, which, kind="theory"):
    """The theory over a band, as the simulation pools it: the theory's ratio weighted by the pooled sonic spectrum.

    ``kind``: ``"theory"`` (the continuum) or ``"lattice"`` (the plane's own modes).
    """
    sel = (res["k_lower"] >= band[0]) & (res["k_upper"] <= band[1])
    s = res["F"][:, 1, sel].sum(axis=0)
    if which == 1:
        return float(np.sum(res[f"{kind}1"][sel] * s) / np.sum(s))
    return float((np.sum(np.sqrt(res[f"{kind}2"][sel]) * s) / np.sum(s)) ** 2)


def main(n=40, duration=600.0, dy=0.5):
    res = run(n, duration, dy)
    t1, s1, t2, s2 = pooled(res["F"])
    print(f"{n} periods of {duration:g} s, A2012 period C, tier los, plane dy = {dy:g} m")
    print("   k      sim1     se1    th1     z1 |  sim2     se2    th2     z2 | lat1    zl1  lat2    zl2")
    for j, kk in enumerate(res["k"]):
        if np.isfinite(t1[j]) and res["theory1"][j] > 1e-3:
            z1 = (t1[j] - res["theory1"][j]) / s1[j]
            z2 = (t2[j] - res["theory2"][j]) / s2[j]
            print(f"{kk:7.4f} {t1[j]:.4f} {s1[j]:.4f} {res['theory1'][j]:.4f} {z1:+5.1f} | {t2[j]:.4f} {s2[j]:.4f} "
                  f"{res['theory2'][j]:.4f} {z2:+5.1f} | {res['lattice1'][j]:.4f} {(t1[j] - res['lattice1'][j]) / s1[j]:+5.1f} "
                  f"{res['lattice2'][j]:.4f} {(t2[j] - res['lattice2'][j]) / s2[j]:+5.1f}")
    for b in BANDS:
        t1, s1, t2, s2 = pooled(res["F"], b, res["k_lower"], res["k_upper"])
        for kind in ("theory", "lattice"):
            th1, th2 = band_theory(res, b, 1, kind), band_theory(res, b, 2, kind)
            print(f"band {b} {'continuum' if kind == 'theory' else 'lattice  '}: method 1 {t1:.4f} +/- {s1:.4f} vs "
                  f"{th1:.4f} (z {(t1 - th1) / s1:+.2f}); method 2 {t2:.4f} +/- {s2:.4f} vs {th2:.4f} "
                  f"(z {(t2 - th2) / s2:+.2f})")
    return res


if __name__ == "__main__":
    args = [float(a) for a in sys.argv[1:]]
    main(int(args[0]) if args else 40, args[1] if len(args) > 1 else 600.0, args[2] if len(args) > 2 else 0.5)
