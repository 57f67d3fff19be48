"""Benchmark of conditioned (constrained) Mann boxes: cwlidar_sim against hipersim and mannrs 2.0.

Usage::

    python benchmarks/bench_conditioning.py [--quick] [--json PATH] [--twins K] [--rounds R]
                                            [--methods ours,ours_dense,hipersim,mannrs] [--no-accuracy]

Constraint sets: line records -- a sonic's u, v, w at every node of a row along x (a
record under Taylor's hypothesis at fs = U / dx) -- at one height and at three heights of
a mast (4 nodes apart), read without noise from a truth box of ours.  Tensor αε^(2/3) =
0.1 m^(4/3) s^-2, L = 20 m, Γ = 3.9; periodic boxes of (512, 32, 32) nodes at 2 m
(``--quick``: (128, 16, 16)).  Targets: rows 0, 1, 2, 4 and 8 nodes above the (middle)
sensor and one 4 nodes beside it.

Methods (each as its own API takes it):

* ``ours``: ``conditioned_box`` (per-k1 Hoffman-Ribak, exact for our discrete field),
  ``conditional_mean`` and ``conditional_variance`` (theory);
* ``ours_dense``: the same records as scattered ``PointValues`` (our dense method), one
  height only: a cross-check of our two methods;
* ``hipersim`` 0.1.22: ``MannTurbulenceField.constrain`` (dense correlations of the tensor
  on the doubled grid, points snapped to nodes) on a periodic box; its update multiplies
  correlation coefficients, so fields and values are divided by each component's standard
  deviation (our discrete box's) before and multiplied after -- the normalised form its
  code expects; its conditional mean is ``constrain`` applied to a zero field;
* ``mannrs`` 2.0: ``Stencil.constrain`` (u only, "compressed spectral superposition",
  default compression 0.8 and threshold 1e-4), periodic; the constraint values are
  honoured in units of αε^(2/3) = 1 (at 0.1 a value of 5 m/s came out as 2.6), so it runs
  at αε^(2/3) = 1 with values divided by sqrt(0.1) and the output multiplied by it (exact
  for a linear method); its conditional mean is the mean of its twins.

Measured in one run: the conditional mean at the targets against ours (rms difference over
sigma_u of the prior, and the largest departure from the record at the sensors), the
ensemble variance of K twins about their method's mean against our theory (ratio and its
standard error from the twins' scatter), and, in separate children under the shared
protocol (``benchmarks/_protocol.py``), the time of set-up plus one constrained box
(minimum over rounds), its ratio to our unconditioned box of the same grid (``box``, set-up
included, measured in the same run) and the peak memory (VmHWM).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import child_main, log, machine, summarize, time_repeats, write_json  # noqa: E402

ALPHA_EPS, LENGTH, GAMMA = 0.1, 20.0, 3.9
U = 8.0
DX = 2.0
FULL = (512, 32, 32)
QUICK = (128, 16, 16)
TRUTH_SEED = 12345
DZ_TARGETS = (0, 1, 2, 4, 8)
DY_TARGET = 4
METHODS = ("ours", "ours_dense", "hipersim", "mannrs")
#: (label, heights, x step between constrained nodes, methods).  mannrs honours only sparse points
#: (its twins' mean misses whole-line records by more than sigma_u/3), hence the third set.
SETS = (("line records, 1 height", 1, 1, METHODS),
        ("line records, 3 heights", 3, 1, ("ours", "hipersim", "mannrs")),
        ("every 8th node of the lines, 3 heights", 3, 8, ("ours_dense", "hipersim", "mannrs")))


def _setup(shape, heights, step=1):
    """Parameters, sensor rows, target rows, the truth's rows at the sensors and the constrained x nodes."""
    from cwlidar_sim.turbulence import MannParameters, generate_box

    p = MannParameters(ALPHA_EPS, LENGTH, GAMMA)
    nx, ny, nz = shape
    iy = ny // 2
    mid = nz // 2 - 4
    zs = [mid] if heights == 1 else [mid - 4, mid, mid + 4]
    truth = generate_box(p, shape, (DX,) * 3, TRUTH_SEED, dtype=np.float64)
    data = {iz: np.stack([np.asarray(truth[c].values[:, iy, iz], dtype=np.float64) for c in "uvw"]) for iz in zs}
    for iz in zs:
        data[iz] -= data[iz].mean(axis=1, keepdims=True)  # a record's mean is the mean wind
    targets = [(iy, mid + d) for d in DZ_TARGETS] + [(iy + DY_TARGET, mid)]
    return p, iy, zs, data, targets, np.arange(0, nx, step)


def _line_records(iy, zs, data, nx):
    from cwlidar_sim.turbulence.conditioning import LineRecord

    # Sample i of a sensor at x = 0 sees node -i (x - U t, fs = U / dx).
    rev = (-np.arange(nx)) % nx
    return [LineRecord((0.0, iy * DX, iz * DX), U / DX, {c: data[iz][k][rev] for k, c in enumerate("uvw")},
                       name=f"z{iz}") for iz in zs]


def _rows(field_uvw, targets):
    return np.array([[field_uvw[c][:, iy, iz] for c in range(3)] for iy, iz in targets])


# ---------------------------------------------------------------------------
# the methods: one constrained box of seed s, and the conditional mean
# ---------------------------------------------------------------------------
class Ours:
    def __init__(self, shape, heights, step=1, dense=False):
        self.shape = shape
        self.p, self.iy, self.zs, self.data, self.targets, self.xs = _setup(shape, heights, step)
        from cwlidar_sim.turbulence.conditioning import PointValues

        if dense:
            pts = np.array([(i * DX, self.iy * DX, iz * DX) for iz in self.zs for i in self.xs])
            vals = {c: np.concatenate([self.data[iz][k][self.xs] for iz in self.zs]) for k, c in enumerate("uvw")}
            self.records = PointValues(pts, vals)
        else:
            if step != 1:
                raise ValueError("the per-k1 method needs whole lines (step 1)")
            self.records = _line_records(self.iy, self.zs, self.data, shape[0])

    def twin(self, seed):
        from cwlidar_sim.turbulence.conditioning import conditioned_box

        b = conditioned_box(self.p, self.shape, (DX,) * 3, seed, self.records, U=U)
        return [np.asarray(b[c].values) for c in "uvw"]

    def mean(self):
        from cwlidar_sim.turbulence import generate_box
        from cwlidar_sim.turbulence.conditioning import conditional_mean

        tmpl = generate_box(self.p, self.shape, (DX,) * 3, 0)
        m = conditional_mean(tmpl, self.records, U=U)
        return [np.asarray(m[c].values) for c in "uvw"]


def _sigmas(p, shape):
    from cwlidar_sim.turbulence import expected_box_covariance

    c = expected_box_covariance(p, shape, (DX,) * 3).covariances
    return np.sqrt([c.uu, c.vv, c.ww])


class Hipersim:
    def __init__(self, shape, heights, step=1):
        self.shape = shape
        self.p, self.iy, self.zs, self.data, self.targets, self.xs = _setup(shape, heights, step)
        self.sig = _sigmas(self.p, shape)
        self.min_eig = None
        rows = []
        for iz in self.zs:
            for i in self.xs:
                rows.append([i * DX, self.iy * DX, iz * DX, *(self.data[iz][:, i] / self.sig)])
        self.cons = np.array(rows)

    def _constrain(self, mtf):
        mtf.uvw = np.asarray(mtf.uvw, dtype=np.float64) / self.sig[:, None, None, None]
        with contextlib.redirect_stdout(io.StringIO()):  # constrain() prints its progress
            mtf.constrain(self.cons.copy())
        return [np.asarray(mtf.uvw[k]) * self.sig[k] for k in range(3)]

    def _field(self, seed):
        from hipersim import MannTurbulenceField

        with contextlib.redirect_stdout(io.StringIO()):
            return MannTurbulenceField.generate(alphaepsilon=ALPHA_EPS, L=LENGTH, Gamma=GAMMA, Nxyz=self.shape,
                                                dxyz=(DX,) * 3, seed=seed, HighFreqComp=0,
                                                double_xyz=(False, False, False), n_cpu=1)

    def twin(self, seed):
        return self._constrain(self._field(seed))

    def mean(self):
        import hipersim.mann_turbulence as hm

        mtf = self._field(1)
        mtf.uvw = np.zeros_like(np.asarray(mtf.uvw))
        solve = hm.np.linalg.solve

        def spy(A, b):  # the smallest eigenvalue of the correlation matrix it solves with
            self.min_eig = [float(x) for x in np.linalg.eigvalsh(0.5 * (A + A.T))[[0, -1]]]
            return solve(A, b)

        hm.np.linalg.solve = spy
        try:
            return self._constrain(mtf)
        finally:
            hm.np.linalg.solve = solve


class Mannrs:
    def __init__(self, shape, heights, step=1):
        from mannrs import Constraint, Stencil

        self.shape = shape
        self.p, self.iy, self.zs, self.data, self.targets, self.xs = _setup(shape, heights, step)
        nx, ny, nz = shape
        self.spec = Stencil(L=LENGTH, gamma=GAMMA, Lx=nx * DX, Ly=ny * DX, Lz=nz * DX, Nx=nx, Ny=ny, Nz=nz,
                            aperiodic_x=False, aperiodic_y=False, aperiodic_z=False)
        self._cons_args = (Constraint, nx)
        self.stencil = None

    def _build(self):
        Constraint, nx = self._cons_args
        base = self.spec.build()
        x, y, z = base.get_axes()  # linspace(0, L, N): place the values on the nodes by index
        s = math.sqrt(ALPHA_EPS)
        cons = [Constraint(x=float(x[i]), y=float(y[self.iy]), z=float(z[iz]), u=float(self.data[iz][0, i] / s))
                for iz in self.zs for i in self.xs]
        self.stencil = self.spec.constrain(cons).build()

    def twin(self, seed):
        if self.stencil is None:
            self._build()
        wf = self.stencil.turbulence(1.0, int(seed))
        s = math.sqrt(ALPHA_EPS)
        return [np.asarray(a, dtype=np.float64) * s for a in (wf.U, wf.V, wf.W)]

    def mean(self):
        return None  # no zero-field path: the mean of the twins stands in


class Box:
    """The baseline: our unconditioned box of the same grid (generate_box), set-up included."""

    def __init__(self, shape, heights, step=1):
        from cwlidar_sim.turbulence import MannParameters

        self.shape, self.p = shape, MannParameters(ALPHA_EPS, LENGTH, GAMMA)

    def twin(self, seed):
        from cwlidar_sim.turbulence import box as box_mod
        from cwlidar_sim.turbulence import generate_box

        box_mod._setup.cache_clear()  # the set-up counts, as for the others
        b = generate_box(self.p, self.shape, (DX,) * 3, seed)
        return [np.asarray(b[c].values) for c in "uvw"]


def _method(name, shape, heights, step=1):
    if name == "box":
        return Box(shape, heights, step)
    if name == "ours":
        return Ours(shape, heights, step)
    if name == "ours_dense":
        return Ours(shape, heights, step, dense=True)
    if name == "hipersim":
        return Hipersim(shape, heights, step)
    if name == "mannrs":
        return Mannrs(shape, heights, step)
    raise ValueError(name)


# ---------------------------------------------------------------------------
# children
# ---------------------------------------------------------------------------
def child_accuracy(task):
    shape, heights, K, step = tuple(task["shape"]), task["heights"], task["twins"], task["step"]
    m = _method(task["method"], shape, heights, step)
    twins = [_rows(m.twin(100 + k), m.targets) for k in range(K)]  # (K, T, 3, nx)
    mean = m.mean()
    mean_t = np.mean(twins, axis=0) if mean is None else _rows(mean, m.targets)
    dev2 = np.array([np.mean((t - mean_t) ** 2, axis=-1) for t in twins])  # (K, T, 3)
    if mean is None:
        dev2 *= K / (K - 1.0)  # about the twins' own mean
    res = {"mean_tcx": mean_t.tolist(), "var_tc": dev2.mean(axis=0).tolist(),
           "var_se_tc": (dev2.std(axis=0, ddof=1) / math.sqrt(K)).tolist()}
    # The twins' spread at the constrained nodes themselves (zero for an exact method without noise).
    on = [m.targets.index((m.iy, iz)) for iz in m.zs if (m.iy, iz) in m.targets]
    comps = [0] if task["method"] == "mannrs" else [0, 1, 2]
    sq = [(t[it][comps][:, m.xs] - mean_t[it][comps][:, m.xs]) ** 2 for t in twins for it in on]
    res["spread_at_constraints_rms"] = float(math.sqrt(np.mean(sq) * (K / (K - 1.0) if mean is None else 1.0)))
    if task["method"] == ("ours" if step == 1 else "ours_dense"):
        from cwlidar_sim.turbulence import generate_box
        from cwlidar_sim.turbulence.conditioning import conditional_variance

        tmpl = generate_box(m.p, shape, (DX,) * 3, 0)
        xs = [0.0] if step == 1 else list(np.arange(shape[0]) * DX)  # line records: stationary in x
        pts = [(x, iy * DX, iz * DX) for iy, iz in m.targets for x in xs]
        th = conditional_variance(tmpl, m.records, pts, U=U)
        T = len(m.targets)
        res.update(prior_tc=th.prior.reshape(T, len(xs), 3).mean(axis=1).tolist(),
                   posterior_tc=th.posterior.reshape(T, len(xs), 3).mean(axis=1).tolist())
    if getattr(m, "min_eig", None) is not None:
        res["hipersim_matrix_eig_min_max"] = m.min_eig
    res["record_rows"] = {str(iz): m.data[iz].tolist() for iz in m.zs}
    res["constrained_x"] = m.xs.tolist()
    res["sensor_targets"] = [m.targets.index((m.iy, iz)) if (m.iy, iz) in m.targets else -1 for iz in m.zs]
    return res


def child_time(task):
    """Set-up plus one constrained box (the truth and the records are made before the clock starts)."""
    shape, heights, step = tuple(task["shape"]), task["heights"], task["step"]

    def warm():
        w = _method(task["method"], (32, 8, 8), 1)
        w.twin(1)

    warm()
    m = _method(task["method"], shape, heights, step)

    def run():
        if isinstance(m, Mannrs):
            m.stencil = None  # its constrained stencil is the set-up
        if isinstance(m, Ours):
            from cwlidar_sim.turbulence import box as box_mod

            box_mod._setup.cache_clear()
        m.twin(7)

    return time_repeats(run, 1, warmup=lambda: None)


# ---------------------------------------------------------------------------
# driver
# ---------------------------------------------------------------------------
def _compare(acc, ref):
    """Per method: mean rms difference to ours / sigma(prior), departure from the record, variance against theory.

    The variance is compared as a ratio where our posterior exceeds 1e-3 of the prior, and reported as
    an rms spread [m/s] on the records themselves (zero for an exact method without noise).
    """
    ours = acc.get(ref)
    out = {}
    if ours is None or "error" in ours:
        return out
    prior = np.array(ours["prior_tc"])
    post = np.array(ours["posterior_tc"])
    m0 = np.array(ours["mean_tcx"])
    free = post > 1e-3 * prior
    for name, r in acc.items():
        if "error" in r:
            out[name] = {"error": r["error"][-400:]}
            continue
        m = np.array(r["mean_tcx"])
        comps = [0] if name == "mannrs" else [0, 1, 2]
        d = np.sqrt(np.mean((m - m0) ** 2, axis=-1)) / np.sqrt(prior)
        dep = []
        xs = np.array(r["constrained_x"])
        for iz, it in zip(r["record_rows"], r["sensor_targets"]):
            if it >= 0:
                rec = np.array(r["record_rows"][iz])
                dep.append(float(np.max(np.abs(m[it][comps][:, xs] - rec[comps][:, xs]))))
        var = np.array(r["var_tc"])
        se = np.array(r["var_se_tc"])
        ratio = np.where(free, var / np.where(free, post, 1.0), np.nan)
        ratio_se = np.where(free, se / np.where(free, post, 1.0), np.nan)
        out[name] = {"mean_rms_diff_over_sigma_tc": d[:, comps].tolist(),
                     "max_departure_from_record": max(dep) if dep else None,
                     "spread_at_constraints_rms": r["spread_at_constraints_rms"],
                     "var_over_theory_tc": ratio[:, comps].tolist(),
                     "var_over_theory_se_tc": ratio_se[:, comps].tolist(),
                     "posterior_over_prior_tc": (post / prior)[:, comps].tolist(),
                     "hipersim_matrix_eig_min_max": r.get("hipersim_matrix_eig_min_max")}
    return out


#: The peers and the module each needs (benchmark extras, never runtime dependencies).
PEERS = {"hipersim": "hipersim", "mannrs": "mannrs"}


def _missing_peers(methods):
    """{peer: reason} for the requested peers that cannot be imported here (reported, not failed on)."""
    import importlib.util

    out = {}
    for name in methods:
        mod = PEERS.get(name)
        if mod is not None and importlib.util.find_spec(mod) is None:
            out[name] = f"not installed (pip install {mod}); compared only where installed"
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="(128, 16, 16) boxes, 6 twins, 1 round")
    ap.add_argument("--json", default=None, help="write the report here")
    ap.add_argument("--twins", type=int, default=None, help="twins per method for the variance (default 8, quick 6)")
    ap.add_argument("--rounds", type=int, default=None, help="timing rounds (default 3, quick 1)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--no-accuracy", action="store_true", help="timings only (with the unconditioned box)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child_main({"accuracy": child_accuracy, "time": child_time}, args.child)
        return 0
    shape = QUICK if args.quick else FULL
    K = args.twins or (6 if args.quick else 8)
    rounds = args.rounds or (1 if args.quick else 3)
    methods = [m for m in args.methods.split(",") if m]
    missing = _missing_peers(methods)
    for name, why in missing.items():
        log(f"{name}: {why}; its rows are left out")
    methods = [m for m in methods if m not in missing]
    report = {"machine": machine(), "shape": shape, "spacing_m": DX, "twins": K, "rounds": rounds,
              "params": {"alpha_eps": ALPHA_EPS, "length_scale": LENGTH, "gamma": GAMMA}, "sets": {},
              "not_installed": missing}
    for label, heights, step, names in SETS:
        names = [m for m in names if m in methods]
        ref = "ours" if step == 1 else "ours_dense"
        acc = {}
        for name in ([] if args.no_accuracy else names):
            log(f"[{label}] accuracy: {name}")
            acc[name] = _protocol.spawn(__file__, {"kind": "accuracy", "method": name, "shape": shape,
                                                   "heights": heights, "twins": K, "step": step}, timeout=3600)
        tasks = {name: {"kind": "time", "method": name, "shape": shape, "heights": heights, "step": step}
                 for name in ["box"] + names}
        timing = _protocol.spawn_rounds(__file__, tasks, rounds, timeout=3600)
        t_out = {}
        for name, rs in timing.items():
            ok = [r for r in rs if "error" not in r]
            if not ok:
                t_out[name] = {"error": rs[0].get("error", "")[-400:]}
                continue
            t_out[name] = dict(summarize([run for r in ok for run in r["runs"]]),
                               peak_mb=max(r["peak_bytes"] for r in ok) / 2**20,
                               baseline_mb=min(r["baseline_bytes"] for r in ok) / 2**20)
        if "wall_s_min" in t_out.get("box", {}):
            for name, t in t_out.items():
                if "wall_s_min" in t:
                    t["over_box"] = t["wall_s_min"] / t_out["box"]["wall_s_min"]
        report["sets"][label] = {"heights": heights, "step_nodes": step, "reference": ref,
                                 "compare": _compare(acc, ref), "timing": t_out}
        _print(label, report["sets"][label])
    if args.json:
        write_json(args.json, report)
    return 0


def _print(label, rep):
    if not rep["compare"] and not rep["timing"]:
        return
    log(f"\n== {label}; targets dz = {DZ_TARGETS} nodes above the (middle) sensor, dy = {DY_TARGET} ==")
    for name, c in rep["compare"].items():
        if "error" in c:
            log(f"{name:10s} error: {c['error']}")
            continue
        d = np.array(c["mean_rms_diff_over_sigma_tc"])
        v = np.array(c["var_over_theory_tc"])
        s = np.array(c["var_over_theory_se_tc"])
        sp = c["spread_at_constraints_rms"]
        eig = c["hipersim_matrix_eig_min_max"]
        log(f"{name:10s} max |mean - record| = {c['max_departure_from_record']:.3g} m/s, twins' rms spread at the "
            f"constrained nodes {sp:.3g} m/s" + (f", its matrix's eigenvalues {eig}" if eig else ""))
        log(f"{'':10s} rms(mean - ours)/sigma (u): " + " ".join(f"{x:.3f}" for x in d[:, 0]))
        log(f"{'':10s} var/theory (u):             " + " ".join(f"{x:.2f}+-{e:.2f}" for x, e in zip(v[:, 0], s[:, 0])))
    for name, t in rep["timing"].items():
        if "error" in t:
            log(f"{name:10s} time: error {t['error']}")
        else:
            log(f"{name:10s} set-up + one box: {t['wall_s_min']:.2f} s (median {t['wall_s_median']:.2f}, "
                f"{t.get('over_box', math.nan):.1f} x the unconditioned box), peak {t['peak_mb']:.0f} MB")


if __name__ == "__main__":
    sys.exit(main())
