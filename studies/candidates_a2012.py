"""What A2012's instrument had that the simulation lacks: each candidate's effect on the median's method 2.

    python studies/candidates_a2012.py [--lines 4] [--json PATH]

Each candidate is evaluated with the estimator-aware theory (the tier-2 physics of a campaign
on its own seeded lines, validated against long runs by validate_estimator_theory.py), A2012's
scene (focus 67.5 m, Mann parameters of the bundled scene, U = 8.1 m/s, CNR -10 dB), the median,
and compared with exp(-2 k 5.61 m) at 0.28 and 0.56 rad/m.  Two candidates are factors on the
estimator's theory: the wind-direction wander, from A2012 Eqs. 12-14 averaged over a Gaussian
spread of directions (the tier-1 response; an approximation for the median), and the sonic below
the focus, Re(rho)^2 (:mod:`cwlidar_sim.analysis.offset`, exact for any estimator of an aligned beam).  Method 1 is not part of this table (see docs/estimator_theory.md).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

K_EDGES = None


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--lines", type=int, default=4)
    ap.add_argument("--json")
    ap.add_argument("--only", nargs="*", help="run the candidates whose name contains one of these")
    a = ap.parse_args(argv)
    from cwlidar_sim.analysis import estimator_transfer, log_bins, misaligned_spectra
    from cwlidar_sim.signal import PROTOTYPE_2003
    from cwlidar_sim.signal.aerosol import lognormal_modulation
    from cwlidar_sim.turbulence import MannParameters, subcell_variance

    p = MannParameters(0.06224407174474577, 18.76, 3.9)
    base = PROTOTYPE_2003.replace(focus=67.5)
    zR = base.rayleigh_length
    edges = log_bins(0.2, 0.8, 10)
    k = np.sqrt(edges[:-1] * edges[1:])
    i28, i56 = int(np.argmin(abs(k - 0.28))), int(np.argmin(abs(k - 0.56)))
    spread0 = math.sqrt(subcell_variance(p, 0.5))
    lam2 = 0.5 * base.wavelength

    def broad(hz):
        return math.sqrt(spread0**2 + (lam2 * hz) ** 2)

    cands = [
        ("baseline (median, a0 20 mm, 4 sigma threshold)", {}, {}),
        ("a0 = 15 mm (zR 9.97 m)", {"telescope_radius": 0.015}, {}),
        ("a0 = 25 mm (zR 3.59 m)", {"telescope_radius": 0.025}, {}),
        ("line broadening 0.3 MHz (Gaussian sd)", {}, {"subcell_spread": broad(3e5)}),
        ("line broadening 1 MHz", {}, {"subcell_spread": broad(1e6)}),
        ("line broadening 2 MHz", {}, {"subcell_spread": broad(2e6)}),
        ("transit time: no transverse speed", {}, {"transverse_speed": 0.0}),
        ("transit time: 5 m/s across the beam", {}, {"transverse_speed": 5.0}),
        ("threshold 2 sigma", {"threshold_value": 2.0}, {}),
        ("threshold 8 sigma", {"threshold_value": 8.0}, {}),
        ("threshold raised 20 % (excess reading)", {"threshold_raise_percent": 20.0,
                                                    "threshold_raise_reading": "excess"}, {}),
        ("threshold raised 20 % (level reading)", {"threshold_raise_percent": 20.0}, {}),
        ("threshold 10 % of the peak", {"threshold_kind": "peak_fraction", "threshold_value": 0.1}, {}),
        ("background gain +5 % (mismatch)", {}, {"gain": 1.05}),
        ("background gain -5 % (mismatch)", {}, {"gain": 0.95}),
        ("aerosol modulation sd(log) 0.5, 5 m", {}, {"modulation": lognormal_modulation(0.5, 5.0)}),
        ("a0 15 mm + 1 MHz broadening", {"telescope_radius": 0.015}, {"subcell_spread": broad(1e6)}),
        ("a0 = 17 mm (zR 7.77 m)", {"telescope_radius": 0.017}, {}),
        ("sonic 1 m below the focus", {}, {"@offset": -1.0}),
        ("direction wander sd 5 deg", {}, {"@wander": 5.0}),
        ("direction wander sd 10 deg", {}, {"@wander": 10.0}),
        ("together, plausible: 0.3 MHz, aerosol 0.5/5 m, sonic -1 m, wander 5 deg", {},
         {"subcell_spread": broad(3e5), "modulation": lognormal_modulation(0.5, 5.0), "@offset": -1.0,
          "@wander": 5.0}),
        ("together: 1 MHz, sonic -1 m, wander 5 deg", {}, {"subcell_spread": broad(1e6), "@offset": -1.0,
                                                            "@wander": 5.0}),
        ("together: a0 17 mm, sonic -1 m, wander 5 deg", {"telescope_radius": 0.017}, {"@offset": -1.0,
                                                                                      "@wander": 5.0}),
    ]
    if a.only:
        cands = [c for c in cands if any(o in c[0] for o in a.only)]
    from cwlidar_sim.analysis.offset import offset_coherence

    kk = k[[i28, i56]]
    F0, _, c0 = misaligned_spectra(kk, p, 0.0, zR)
    xh, wh = np.polynomial.hermite_e.hermegauss(7)
    wh = wh / wh.sum()

    def wander(sd):
        F, C = np.zeros(2), np.zeros(2)
        for xi, wi in zip(xh, wh):
            f, _, c = misaligned_spectra(kk, p, float(sd * xi), zR)
            F += wi * f
            C += wi * np.real(c)
        return (C / F) ** 2 / (np.real(c0) / F0) ** 2

    rows = []
    for name, inst_over, kw in cands:
        kw = dict(kw)
        fac = np.ones(2)
        if "@offset" in kw:
            fac *= np.real(offset_coherence(kk, p, kw.pop("@offset"))) ** 2
        if "@wander" in kw:
            fac *= wander(kw.pop("@wander"))
        inst = base.replace(**inst_over)
        lines = max(1, a.lines // 2) if "modulation" in kw else a.lines
        t = estimator_transfer(inst, p, 8.1, estimators=("median",), k_edges=edges, n_lines=lines, **kw)
        r = {"candidate": name, "T2_0.28": float(t.transfer_cross_ek[0, i28] * fac[0]),
             "T2_0.56": float(t.transfer_cross_ek[0, i56] * fac[1]),
             "sigma_0.28": float(t.transfer_cross_sigma_ek[0, i28] * fac[0]), "sigma_0.56": float(t.transfer_cross_sigma_ek[0, i56] * fac[1]),
             "factor_0.28": float(fac[0]), "factor_0.56": float(fac[1]), "zR_instrument": inst.rayleigh_length,
             "zR_eff": float(t.zR_eff_e[0])}
        r["ratio_0.28"] = r["T2_0.28"] / math.exp(-2 * k[i28] * zR)
        r["ratio_0.56"] = r["T2_0.56"] / math.exp(-2 * k[i56] * zR)
        rows.append(r)
        print(f"{name:72s} T2(0.28)/exp = {r['ratio_0.28']:5.2f}  T2(0.56)/exp = {r['ratio_0.56']:5.2f}", flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
