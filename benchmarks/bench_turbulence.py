"""Benchmark of Mann-box generation: cwlidar_sim against mannrs and hipersim.

Usage::

    python benchmarks/bench_turbulence.py [--quick] [--json PATH] [--shapes SPEC ...]
                                          [--repeats N] [--no-accuracy] [--peer-modes MODES]

A shape SPEC is ``NXxNYxNZ@D`` (one spacing for all axes) or ``NXxNYxNZ@DX/DY/DZ`` [m],
e.g. ``16384x32x32@0.5/4/4``.

αε^(2/3) = 1 m^(4/3) s^-2, L = 33.6 m, Γ = 3.9.  Every measurement runs in a fresh
interpreter under the shared protocol of ``benchmarks/_protocol.py`` (warm-up box
64x8x8 first, minimum over children run in rounds -- ours, the FFT floor, each peer --
peak memory as VmHWM).  Measured per shape: ours (set-up + first box, then a second
box with the cached set-up, then the FFT floor in the same child), the floor (three
FFTW threaded inverse real 3-D FFTs, planning excluded), and the peers ``mannrs`` and
``hipersim`` in their periodic (like-for-like) and default (y, z doubled) settings.
Accuracy (``--no-accuracy`` skips it): seed-averaged variances, u-w covariance and
x-periodogram band sums against the tensor over the grid, over all of R^3 and
``expected_box_covariance``, with standard errors from each box's own Fourier modes
(periodic boxes) or the scatter between seeds (the peers' doubled boxes, marked ``*``).
``ours+hf`` is ours with ``hf_compensation=True`` (accuracy only).  The settings, the
references and the results are described in ``benchmarks/README.md``.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import _protocol  # noqa: E402  (the shared child-process protocol)
from _protocol import TreeRssSampler, child_main, log, machine, ru_maxrss, write_json  # noqa: E402
from _protocol import vmhwm as peak_rss  # noqa: E402
from _protocol import vmrss as current_rss  # noqa: E402

ALPHA_EPS = 1.0
LENGTH_SCALE = 33.6
GAMMA = 3.9

FULL_SHAPES = ["4096x32x32@2", "8192x64x64@2", "16384x32x32@0.5/4/4"]
QUICK_SHAPES = ["1024x32x32@2", "2048x16x16@2"]
WARMUP_SHAPE = (64, 8, 8)
WARMUP_SPACING = (2.0, 2.0, 2.0)
MID_BAND = (0.05, 0.3)  # rad/m
HF_BAND_FRAC = (0.60, 0.68)  # x pi/dx
COMPONENTS = ("u", "v", "w")


# ---------------------------------------------------------------------------
# small utilities
# ---------------------------------------------------------------------------
def parse_shape(spec: str):
    """'NXxNYxNZ@D' or 'NXxNYxNZ@DX/DY/DZ' -> ((nx, ny, nz), (dx, dy, dz))."""
    try:
        dims, sp = spec.split("@")
        shape = tuple(int(n) for n in dims.lower().split("x"))
        d = tuple(float(s) for s in sp.split("/"))
        if len(d) == 1:
            d = d * 3
        if len(shape) != 3 or len(d) != 3 or min(shape) < 2 or min(d) <= 0:
            raise ValueError
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"bad shape spec {spec!r}; expected NXxNYxNZ@D or NXxNYxNZ@DX/DY/DZ with N >= 2, D > 0"
        ) from None
    return shape, d


def shape_label(shape, spacing) -> str:
    sp = "/".join(f"{s:g}" for s in spacing)
    if len(set(spacing)) == 1:
        sp = f"{spacing[0]:g}"
    return "x".join(str(n) for n in shape) + f"@{sp}"


def output_bytes(shape) -> int:
    """Size of three float32 output arrays, 3 Nx Ny Nz 4 bytes."""
    return 3 * shape[0] * shape[1] * shape[2] * 4



# ---------------------------------------------------------------------------
# generators, as used inside a child
# ---------------------------------------------------------------------------
PEER_SETTINGS = {
    # name: (peer, mode, options)
    "mannrs/periodic": ("mannrs", "periodic", dict(aperiodic=(False, False, False), parallel=True)),
    "hipersim/periodic-n1": ("hipersim", "periodic", dict(double_xyz=(False, False, False), n_cpu=1)),
    "hipersim/periodic-nall": ("hipersim", "periodic", dict(double_xyz=(False, False, False), n_cpu=None)),
    "mannrs/default": ("mannrs", "default", dict(aperiodic=(False, True, True), parallel=True)),
    "hipersim/default": ("hipersim", "default", dict(double_xyz=(False, True, True), n_cpu=1)),
}


def _params():
    from cwlidar_sim.turbulence import MannParameters

    return MannParameters(alpha_eps=ALPHA_EPS, length_scale=LENGTH_SCALE, gamma=GAMMA)


class OursGen:
    def __init__(self, hf_compensation=False):
        from cwlidar_sim._config import set_num_threads
        from cwlidar_sim.turbulence import generate_box

        set_num_threads(os.cpu_count() or 1)
        self._gen = generate_box
        self.params = _params()
        self.hf = hf_compensation

    def box(self, shape, spacing, seed):
        ds = self._gen(self.params, shape, spacing, seed, hf_compensation=self.hf, dtype=np.float32)
        return ds, (ds["u"].data, ds["v"].data, ds["w"].data)


class MannrsGen:
    """mannrs 2.0: Stencil(...).build(parallel) then .turbulence(ae, seed, parallel)."""

    def __init__(self, aperiodic, parallel):
        import mannrs

        self._m = mannrs
        self.aperiodic = aperiodic
        self.parallel = parallel

    def stencil(self, shape, spacing):
        nx, ny, nz = shape
        dx, dy, dz = spacing
        # mannrs takes the box lengths; its grid is periodic with spacing L_i / N_i
        # (get_axes() prints linspace(0, L_i, N_i), but U[0] and U[-1] are neighbours,
        # not the same plane, so the spacing of the data is L_i / N_i).
        st = self._m.Stencil(L=LENGTH_SCALE, gamma=GAMMA, Lx=nx * dx, Ly=ny * dy, Lz=nz * dz, Nx=nx, Ny=ny,
                             Nz=nz, aperiodic_x=self.aperiodic[0], aperiodic_y=self.aperiodic[1],
                             aperiodic_z=self.aperiodic[2])
        return st.build(parallel=self.parallel)

    @staticmethod
    def synth(stencil, seed, parallel):
        wf = stencil.turbulence(ALPHA_EPS, seed, parallel=parallel)
        return wf, (wf.U, wf.V, wf.W)  # each indexed [x, y, z]

    def box(self, shape, spacing, seed):
        return self.synth(self.stencil(shape, spacing), seed, self.parallel)


class HipersimGen:
    """hipersim 0.1.22: MannTurbulenceField.generate(...) (uvw indexed [c, x, y, z])."""

    def __init__(self, double_xyz, n_cpu):
        from hipersim import MannTurbulenceField

        self._mtf = MannTurbulenceField
        self.double_xyz = double_xyz
        self.n_cpu = n_cpu if n_cpu is not None else (os.cpu_count() or 1)

    def box(self, shape, spacing, seed):
        f = self._mtf.generate(alphaepsilon=ALPHA_EPS, L=LENGTH_SCALE, Gamma=GAMMA, Nxyz=tuple(shape),
                               dxyz=tuple(spacing), seed=seed, HighFreqComp=0, double_xyz=self.double_xyz,
                               n_cpu=self.n_cpu)
        return f, (f.uvw[0], f.uvw[1], f.uvw[2])

    def tensor(self, shape, spacing):
        from hipersim.turbgen.spectral_tensor import MannSpectralTensor

        # MannSpectralTensor (unlike generate's one-time tensor) keeps the tensor
        # for several seeds.
        return MannSpectralTensor(alphaepsilon=ALPHA_EPS, L=LENGTH_SCALE, Gamma=GAMMA, Nxyz=tuple(shape),
                                  dxyz=tuple(spacing), HighFreqComp=0, double_xyz=self.double_xyz,
                                  n_cpu=self.n_cpu)


def make_peer(setting):
    peer, _mode, opt = PEER_SETTINGS[setting]
    if peer == "mannrs":
        return MannrsGen(opt["aperiodic"], opt["parallel"])
    return HipersimGen(opt["double_xyz"], opt["n_cpu"])


# ---------------------------------------------------------------------------
# child tasks
# ---------------------------------------------------------------------------
def child_time(task):
    """One timing measurement in a fresh process."""
    shape, spacing = tuple(task["shape"]), tuple(task["spacing"])
    gen_name = task["generator"]
    res = {"generator": gen_name}
    if gen_name == "ours":
        gen = OursGen()
        # Importing the turbulence package does not import numba; the warm-up does.
        from cwlidar_sim.turbulence import _kernels  # noqa: F401  (numba import, no compile)
    else:
        gen = make_peer(gen_name)
    res["rss_after_imports"] = current_rss()
    sampler = None
    if gen_name.startswith("hipersim") and getattr(gen, "n_cpu", 1) > 1:
        sampler = TreeRssSampler().__enter__()
    _obj, _arr = gen.box(WARMUP_SHAPE, WARMUP_SPACING, 12345)
    del _obj, _arr
    gc.collect()
    res["rss_baseline"] = current_rss()
    res["peak_rss_after_warmup"] = peak_rss()

    t0 = time.perf_counter()
    obj, arrs = gen.box(shape, spacing, 1)
    res["t_first"] = time.perf_counter() - t0
    res["peak_rss_first"] = peak_rss()
    res["out_shape"] = list(arrs[0].shape)
    res["out_dtype"] = str(arrs[0].dtype)
    if gen_name == "ours":
        del obj, arrs
        gc.collect()
        t0 = time.perf_counter()
        obj, arrs = gen.box(shape, spacing, 2)
        res["t_second"] = time.perf_counter() - t0
    res["peak_rss"] = peak_rss()
    res["ru_maxrss"] = ru_maxrss()
    if sampler is not None:
        sampler.__exit__()
        res["peak_tree_rss_sampled"] = sampler.peak
        res["tree_has_children"] = sampler.saw_children
    if task.get("floor_too"):
        # The FFT floor right after the second box, in the same process
        # (after the memory figures are taken), so that their ratio is
        # measured under one machine load.
        del obj, arrs
        gc.collect()
        res["t_floor_same_child"] = _time_floor(shape, 3)["t_floor"]
    return res


def child_floor(task):
    """Three FFTW threaded inverse real 3-D FFTs (u, v, w), planning excluded."""
    from cwlidar_sim._config import set_num_threads

    shape = tuple(task["shape"])
    nthreads = os.cpu_count() or 1
    set_num_threads(nthreads)
    res = {"generator": "floor", "threads": nthreads, "rss_after_imports": current_rss()}
    res.update(_time_floor(shape, task.get("repeats", 3)))
    res["peak_rss"] = peak_rss()
    return res


def _time_floor(shape, repeats):
    """Minimum over ``repeats`` of three FFTW threaded inverse real 3-D FFTs (planning excluded)."""
    from cwlidar_sim._fft import irfft3_floor

    nthreads = os.cpu_count() or 1
    runs = [irfft3_floor(shape, np.float32, threads=nthreads) for _ in range(3)]
    bufs = [r.__self__.input_array.view(np.float32) for r in runs]

    def refill():
        # Finite, non-denormal input (the buffers start uninitialised and c2r
        # destroys its input); the values do not change FFTW's work.
        for b in bufs:
            b.fill(1.0)

    times = []
    for _ in range(repeats):
        refill()
        t0 = time.perf_counter()
        for r in runs:
            r()
        times.append(time.perf_counter() - t0)
    return {"t_all": times, "t_floor": min(times)}


def _box_stats_direct(arrs, spacing, k_mid, k_hf):
    """Sample covariances and band sums of the x-periodogram for one box."""
    from cwlidar_sim._fft import rfft_rows

    u, v, w = arrs
    nx, ny, nz = u.shape
    dx = spacing[0]
    out = {}
    means = [float(np.mean(a, dtype=np.float64)) for a in arrs]
    for c, a, m in zip(COMPONENTS, arrs, means):
        out[f"var_{c}"] = float(np.var(a, dtype=np.float64))
        out[f"mean_{c}"] = m
    uw = 0.0
    for i in range(nx):  # slab by slab in float64: no box-sized temporaries
        uw += float(np.sum((u[i].astype(np.float64) - means[0]) * (w[i].astype(np.float64) - means[2])))
    out["cov_uw"] = uw / u.size
    # Periodogram along x, averaged over y and z, one-sided (like one_point_spectra and
    # expected_box_covariance's F_k4): sum over k1 >= 0 of F dk1 = <a^2> (k1 = 0 and Nyquist counted half).
    norm = dx / (math.pi * nx) / (ny * nz)
    for c, a in zip(COMPONENTS, arrs):
        acc = np.zeros(nx // 2 + 1)
        for j in range(ny):
            rows = np.ascontiguousarray(np.asarray(a[:, j, :], dtype=np.float64).T)  # (z, x)
            X = rfft_rows(rows)
            acc += (X.real**2 + X.imag**2).sum(axis=0)
        F = acc * norm
        out[f"F_mid_sum_{c}"] = float(F[k_mid].sum())
        out[f"F_hf_sum_{c}"] = float(F[k_hf].sum())
    return out


def _mode_variances(arrs, spacing, k_mid, k_hf):
    """Sampling variances of this box's statistics, estimated from its own modes.

    Valid for a periodic box made of independent circular Gaussian Fourier modes
    (ours and the peers' periodic settings; not for the peers' doubled boxes, whose
    output is a quarter of a periodic box).  With a_k = DFT(u)/N, the sample
    variance is sum_{k != 0} |a_k|^2, and |a_k|^2 = |a_-k|^2 is exponential with
    mean s_k, so Var(sample variance) = 2 sum_k s_k^2, estimated without bias by
    sum_{k != 0} |a_k|^4.  For the u-w covariance sum_k Re(a_k b_k*),
    Var = 2 sum_k Var(Re a_k b_k*) = sum_k (S_aa S_bb + Re S_ab^2), estimated by
    sum_k |a_k|^2 |b_k|^2 (exact when S_ab is real; otherwise an upper bound).
    A band sum of the one-sided periodogram, (2/dk1) sum over modes with k1 = +k_n
    in the band of |a_k|^2, holds no conjugate pairs, so its variance is
    (2/dk1)^2 sum s_k^2, estimated by (2/dk1)^2 sum |a_k|^4 / 2.
    """
    import scipy.fft

    nx, ny, nz = arrs[0].shape
    n = nx * ny * nz
    dk1 = 2.0 * math.pi / (nx * spacing[0])
    # Weights of the half z-spectrum: modes n3 and -n3 (except 0 and Nyquist).
    wz = np.full(nz // 2 + 1, 2.0)
    wz[0] = 1.0
    if nz % 2 == 0:
        wz[-1] = 1.0
    p2 = []
    for a in arrs:
        A = scipy.fft.rfftn(np.asarray(a, dtype=np.float32), workers=os.cpu_count())
        P = (A.real.astype(np.float64) ** 2 + A.imag.astype(np.float64) ** 2) / float(n) ** 2
        del A
        P[0, 0, 0] = 0.0  # the box mean is not part of the sample variance
        p2.append(P)
    out = {}
    for c, P in zip(COMPONENTS, p2):
        out[f"var_{c}_var"] = float((P**2 * wz).sum())
        for band, idx in (("mid", k_mid), ("hf", k_hf)):
            # modes with k1 = +k_n: row n with n3 >= 0, and (by conjugation) row
            # nx - n with n3 > 0 (excluding Nyquist), i.e. the (n, -n2, -n3) modes.
            s4 = (P[idx] ** 2).sum() + ((P[(nx - idx) % nx][:, :, 1:] ** 2) * (wz[1:] - 1.0)).sum()
            out[f"F_{band}_sum_{c}_var"] = float(2.0 * s4 / dk1**2)
    out["cov_uw_var"] = float((p2[0] * p2[2] * wz).sum())
    return out


def band_indices(shape, spacing):
    nx, dx = shape[0], spacing[0]
    dk = 2.0 * math.pi / (nx * dx)
    k = dk * np.arange(nx // 2 + 1)
    mid = np.nonzero((k >= MID_BAND[0]) & (k <= MID_BAND[1]))[0]
    nyq = math.pi / dx
    hf = np.nonzero((k >= HF_BAND_FRAC[0] * nyq) & (k <= HF_BAND_FRAC[1] * nyq))[0]
    return k, mid, hf


def child_accuracy(task):
    shape, spacing = tuple(task["shape"]), tuple(task["spacing"])
    name = task["generator"]
    seeds = task["seeds"]
    _k, mid, hf = band_indices(shape, spacing)
    per_seed = []
    periodic = name.startswith("ours") or PEER_SETTINGS[name][1] == "periodic"

    def _box_stats(arrs, spacing, mid, hf):
        st = _box_stats_direct(arrs, spacing, mid, hf)
        if periodic:
            st.update(_mode_variances(arrs, spacing, mid, hf))
        return st

    if name in ("ours", "ours+hf"):
        gen = OursGen(hf_compensation=(name == "ours+hf"))
        for s in seeds:
            ds, arrs = gen.box(shape, spacing, s)
            per_seed.append(_box_stats(arrs, spacing, mid, hf))
            del ds, arrs
            gc.collect()
    else:
        gen = make_peer(name)
        if isinstance(gen, MannrsGen):
            st = gen.stencil(shape, spacing)
            for s in seeds:
                wf, arrs = gen.synth(st, s, gen.parallel)
                per_seed.append(_box_stats(arrs, spacing, mid, hf))
                del wf, arrs
                gc.collect()
        else:
            mst = gen.tensor(shape, spacing)
            for s in seeds:
                f = mst.generate(seed=s, alphaepsilon=ALPHA_EPS)
                per_seed.append(_box_stats(tuple(f.uvw[i] for i in range(3)), spacing, mid, hf))
                del f
                gc.collect()
    return {"generator": name, "seeds": seeds, "per_seed": per_seed}


def run_child_main(task_json):
    # hipersim's process pool is never closed: child_main leaves with os._exit.
    child_main({"time": child_time, "floor": child_floor, "accuracy": child_accuracy}, task_json)


def spawn(task, timeout=900):
    """One task in a fresh interpreter (the shared protocol); its result dict, or an error dict."""
    return _protocol.spawn(__file__, task, timeout=timeout)

# ---------------------------------------------------------------------------
# references for the accuracy section
# ---------------------------------------------------------------------------
def _band_reference(k_bins, lo, hi, params, k2_max, k3_max, n=48):
    """Sum over band bins of the analytic F11, F22, F33 (log-log cubic interpolation
    from n wavenumbers; the spectra are smooth there)."""
    from scipy.interpolate import CubicSpline

    from cwlidar_sim.turbulence import one_point_spectra

    kt = np.geomspace(lo, hi, n)
    F = np.stack(one_point_spectra(kt, params, k2_max=k2_max, k3_max=k3_max)[:3], axis=1)
    spl = CubicSpline(np.log(kt), np.log(F), axis=0)
    Fb = np.exp(spl(np.log(k_bins)))
    return Fb.sum(axis=0)


def references(shape, spacing, hf_too=True):
    from cwlidar_sim.turbulence import covariances, expected_box_covariance

    params = _params()
    k, mid, hf = band_indices(shape, spacing)
    dy, dz = spacing[1], spacing[2]
    cov_grid = covariances(params, spacing)
    cov_full = covariances(params)
    refs = {
        "cov": {
            "grid": dict(uu=cov_grid.uu, vv=cov_grid.vv, ww=cov_grid.ww, uw=cov_grid.uw),
            "full": dict(uu=cov_full.uu, vv=cov_full.vv, ww=cov_full.ww, uw=cov_full.uw),
        },
        "bands": {
            "mid": {"k_lo": float(k[mid[0]]), "k_hi": float(k[mid[-1]]), "n_bins": int(len(mid))},
            "hf": {"k_lo": float(k[hf[0]]), "k_hi": float(k[hf[-1]]), "n_bins": int(len(hf))},
        },
        "F_sum": {},
    }
    for band, idx in (("mid", mid), ("hf", hf)):
        lo, hi = float(k[idx[0]]), float(k[idx[-1]])
        refs["F_sum"][f"{band}/grid"] = _band_reference(k[idx], lo, hi, params, math.pi / dy, math.pi / dz).tolist()
        refs["F_sum"][f"{band}/full"] = _band_reference(k[idx], lo, hi, params, math.inf, math.inf).tolist()
    for tag, hfc in (("ours", False), ("ours+hf", True)):
        if hfc and not hf_too:
            continue
        e = expected_box_covariance(params, shape, spacing, hf_compensation=hfc)
        c = e.covariances
        refs["cov"][f"expected[{tag}]"] = dict(uu=c.uu, vv=c.vv, ww=c.ww, uw=c.uw)
        mc = e.mean_covariances
        refs["cov"][f"box_mean_cell[{tag}]"] = dict(uu=mc.uu, vv=mc.vv, ww=mc.ww, uw=mc.uw)
        for band, idx in (("mid", mid), ("hf", hf)):
            refs["F_sum"][f"{band}/expected[{tag}]"] = e.F_k4[idx, :3].sum(axis=0).tolist()
    return refs


def _se_theory(per_seed, key):
    """Standard error of the seed mean from each box's own mode variances (NaN if absent)."""
    if not all(key in p for p in per_seed):
        return float("nan")
    n = len(per_seed)
    return math.sqrt(sum(p[key] for p in per_seed)) / n


def accuracy_ratios(acc, refs, gen):
    """Seed-averaged statistics divided by each reference, with standard errors."""
    ps = acc["per_seed"]
    n = len(ps)
    exp_key = "expected[ours+hf]" if gen == "ours+hf" else "expected[ours]"
    out = {"n_seeds": n, "cov": {}, "F_mid": {}, "F_hf": {}, "box_mean_sq": {}}
    stat_keys = {"uu": "var_u", "vv": "var_v", "ww": "var_w", "uw": "cov_uw"}
    for key, sk in stat_keys.items():
        vals = np.array([p[sk] for p in ps])
        m = float(vals.mean())
        se = float(vals.std(ddof=1) / math.sqrt(n)) if n > 1 else float("nan")
        se_th = _se_theory(ps, f"{sk}_var")
        d = {"value": m, "se": se, "se_theory": se_th}
        for r in ("grid", "full", exp_key):
            ref = refs["cov"][r][key]
            d[f"ratio_{r.split('[')[0]}"] = m / ref
            d[f"ratio_{r.split('[')[0]}_se"] = se / abs(ref)
            d[f"ratio_{r.split('[')[0]}_se_theory"] = se_th / abs(ref)
        out["cov"][key] = d
    for c in COMPONENTS:
        out["box_mean_sq"][c] = float(np.mean([p[f"mean_{c}"] ** 2 for p in ps]))
    for band in ("mid", "hf"):
        for ic, c in enumerate(COMPONENTS):
            vals = np.array([p[f"F_{band}_sum_{c}"] for p in ps])
            m = float(vals.mean())
            se = float(vals.std(ddof=1) / math.sqrt(n)) if n > 1 else float("nan")
            se_th = _se_theory(ps, f"F_{band}_sum_{c}_var")
            d = {"se_theory": se_th}
            for r in ("grid", "full", exp_key):
                ref = refs["F_sum"][f"{band}/{r}"][ic]
                d[f"ratio_{r.split('[')[0]}"] = m / ref
                d[f"ratio_{r.split('[')[0]}_se"] = se / ref
                d[f"ratio_{r.split('[')[0]}_se_theory"] = se_th / ref
            out[f"F_{band}"][c] = d
    return out


# ---------------------------------------------------------------------------
# driver
# ---------------------------------------------------------------------------
def _gb(b):
    return b / 1e9


def measure_shape(shape, spacing, peer_settings, repeats, do_accuracy, seeds, seeds_ours, acc_modes):
    label = shape_label(shape, spacing)
    res = {"label": label, "shape": list(shape), "spacing": list(spacing), "output_bytes": output_bytes(shape)}

    def best(runs):
        ok = [r for r in runs if "error" not in r]
        if not ok:
            return {"error": runs[-1].get("error"), "runs": runs}
        agg = {"runs": runs, "n_runs": len(ok)}
        for key in ("t_first", "t_second", "t_floor_same_child"):
            if key in ok[0]:
                agg[key] = min(r[key] for r in ok)
        if "t_floor_same_child" in ok[0]:
            # Second box and floor timed back to back in one process: the
            # ratio of each pair sees one machine load.
            agg["second_over_floor_paired"] = sorted(r["t_second"] / r["t_floor_same_child"] for r in ok)
        for key in ("peak_rss", "peak_rss_first", "peak_tree_rss_sampled"):
            if key in ok[0]:
                agg[key] = max(r[key] for r in ok)
        for key in ("rss_after_imports", "rss_baseline"):
            agg[key] = min(r[key] for r in ok)
        # Increment measured within each run (peak minus that run's own baseline).
        agg["peak_increment"] = max(r["peak_rss"] - r["rss_baseline"] for r in ok)
        return agg

    base = {"shape": list(shape), "spacing": list(spacing)}
    # Rounds: each round runs every generator once (and the floor), so that
    # a change of machine load (other jobs) hits all of them alike; each
    # time is the minimum over the rounds.
    names = ["ours", "floor"] + list(peer_settings)
    runs = {n: [] for n in names}
    for rnd in range(repeats):
        for n in names:
            log(f"[{label}] round {rnd + 1}/{repeats}: {n}")
            if n == "floor":
                task = dict(base, kind="floor", generator="floor", repeats=3)
            else:
                task = dict(base, kind="time", generator=n, floor_too=(n == "ours"))
            r = spawn(task)
            if "error" in r:
                log(f"  [{label}] {n} round {rnd + 1}: ERROR {r['error'][:400]}")
            runs[n].append(r)
    res["ours"] = best(runs["ours"])
    fl_ok = [r for r in runs["floor"] if "error" not in r]
    if fl_ok:
        fl = dict(min(fl_ok, key=lambda r: r["t_floor"]), runs=runs["floor"])
    else:
        fl = {"error": runs["floor"][-1].get("error"), "runs": runs["floor"]}
    res["floor"] = fl
    res["peers"] = {s: best(runs[s]) for s in peer_settings}

    # ratios
    o = res["ours"]
    rt = {}
    periodic = {}
    for s, r in res["peers"].items():
        if "t_first" not in r or "t_first" not in o:
            continue
        peer, mode, _ = PEER_SETTINGS[s]
        rt[f"ours/{s}"] = o["t_first"] / r["t_first"]
        if mode == "periodic":
            if peer not in periodic or r["t_first"] < periodic[peer][1]:
                periodic[peer] = (s, r["t_first"])
    best_default = {}
    for s, r in res["peers"].items():
        peer, mode, _ = PEER_SETTINGS[s]
        if mode == "default" and "t_first" in r:
            best_default[peer] = (s, r["t_first"])
    if periodic and "t_first" in o:
        fs, ft = min(periodic.values(), key=lambda x: x[1])
        rt["best_periodic_setting"] = {p: v[0] for p, v in periodic.items()}
        rt["faster_peer_periodic"] = fs
        rt["speedup_vs_faster_peer_periodic"] = ft / o["t_first"]
    if best_default and "t_first" in o:
        fs, ft = min(best_default.values(), key=lambda x: x[1])
        rt["faster_peer_default"] = fs
        rt["speedup_vs_faster_peer_default"] = ft / o["t_first"]
    if "t_floor" in fl and "t_second" in o:
        rt["ours_second/floor"] = o["t_second"] / fl["t_floor"]
        rt["ours_first/floor"] = o["t_first"] / fl["t_floor"]
    if "second_over_floor_paired" in o:
        pr = o["second_over_floor_paired"]
        rt["ours_second/floor_paired_median"] = pr[len(pr) // 2]
        rt["ours_second/floor_paired_min"] = pr[0]
    if "peak_rss" in o:
        rt["ours_peak/output"] = o["peak_rss"] / res["output_bytes"]
        rt["ours_increment/output"] = o["peak_increment"] / res["output_bytes"]
    res["ratios"] = rt

    if do_accuracy:
        log(f"[{label}] accuracy references")
        t0 = time.perf_counter()
        refs = references(shape, spacing)
        res["references"] = refs
        log(f"  ({time.perf_counter() - t0:.1f} s)")
        res["accuracy"] = {}
        # hipersim's n_cpu only changes speed, so one hipersim setting per mode.
        acc_gens = ["ours", "ours+hf"] + [s for s in peer_settings if s != "hipersim/periodic-nall"
                                          and PEER_SETTINGS[s][1] in acc_modes]
        for g in acc_gens:
            sd = seeds_ours if g.startswith("ours") else seeds
            log(f"[{label}] accuracy {g} ({len(sd)} seeds)")
            a = spawn(dict(base, kind="accuracy", generator=g, seeds=sd))
            if "error" in a:
                log(f"  ERROR {a['error'][:400]}")
                res["accuracy"][g] = a
                continue
            res["accuracy"][g] = dict(raw=a, ratios=accuracy_ratios(a, refs, g))
    return res


def _fmt_t(x):
    return f"{x:7.2f}" if isinstance(x, (int, float)) and math.isfinite(x) else "    n/a"


def print_tables(results):
    log("")
    log("=" * 100)
    log("SPEED AND MEMORY  (alpha_eps=1, L=33.6 m, Gamma=3.9; min time over fresh processes;")
    log("  'peak' = absolute peak RSS incl. Python + libraries; 'incr' = peak minus RSS after imports")
    log("  and a tiny warm-up box (JIT cache / lazy imports / process pool excluded from timing))")
    log("=" * 100)
    for r in results:
        ob = r["output_bytes"]
        log(f"\n{r['label']}   output arrays 3*Nx*Ny*Nz*4 = {ob / 1e6:.1f} MB")
        log(f"  {'generator':26s} {'time s':>8s} {'2nd box s':>9s} {'peak GB':>8s} {'base GB':>8s} {'incr GB':>8s}"
            f" {'peak/out':>8s} {'incr/out':>8s} {'ours/this':>9s}")
        rows = [("ours (cwlidar_sim)", r["ours"])] + list(r["peers"].items())
        for name, d in rows:
            if "error" in d:
                log(f"  {name:26s} ERROR")
                continue
            t2 = _fmt_t(d.get("t_second", float("nan")))
            ratio = r["ratios"].get(f"ours/{name}")
            rs = f"{ratio:9.3f}" if ratio is not None else "        -"
            tree = ""
            if d.get("peak_tree_rss_sampled"):
                tree = f"  (process tree incl. pool workers, sampled: {_gb(d['peak_tree_rss_sampled']):.2f} GB)"
            log(f"  {name:26s} {_fmt_t(d['t_first']):>8s} {t2:>9s} {_gb(d['peak_rss']):8.3f} "
                f"{_gb(d['rss_baseline']):8.3f} {_gb(d['peak_increment']):8.3f} {d['peak_rss'] / ob:8.2f} "
                f"{d['peak_increment'] / ob:8.2f} {rs}{tree}")
        fl = r["floor"]
        if "t_floor" in fl:
            log(f"  {'floor: 3 FFTW irfft3 (' + str(fl['threads']) + ' thr)':26s} {_fmt_t(fl['t_floor']):>8s}")
        rt = r["ratios"]
        if "speedup_vs_faster_peer_periodic" in rt:
            log(f"  speed-up vs faster peer, periodic (like-for-like): "
                f"{rt['speedup_vs_faster_peer_periodic']:.2f}x ({rt['faster_peer_periodic']})   target >= 3x")
        if "speedup_vs_faster_peer_default" in rt:
            log(f"  speed-up vs faster peer, peer defaults (y,z doubled): "
                f"{rt['speedup_vs_faster_peer_default']:.2f}x ({rt['faster_peer_default']})")
        if "ours_second/floor" in rt:
            log(f"  ours second box / FFT floor: {rt['ours_second/floor']:.2f}   target <= 2"
                f"   (first box / floor: {rt['ours_first/floor']:.2f})")
        if "ours_second/floor_paired_median" in rt:
            pr = ", ".join(f"{x:.2f}" for x in r["ours"]["second_over_floor_paired"])
            log(f"  ours second box / FFT floor timed in the same process, per run: {pr}"
                f"   (median {rt['ours_second/floor_paired_median']:.2f})")
        if "ours_peak/output" in rt:
            log(f"  ours peak / output: absolute {rt['ours_peak/output']:.2f}, increment "
                f"{rt['ours_increment/output']:.2f}   target < 2")

    if not any("accuracy" in r for r in results):
        return
    log("")
    log("=" * 100)
    log("ACCURACY  seed-averaged sample statistic / reference  (+- standard error of the seed mean,")
    log("  from each box's own Fourier-mode variances for periodic boxes; '*' = from the scatter between")
    log("  seeds, for the peers' doubled boxes, crude with 3 seeds)")
    log("  grid = tensor over |k_i| <= pi/d_i; full = all of R^3; exp = expected_box_covariance (ours; = grid")
    log("  less the central k-cell, i.e. the box mean).  var = sample variance about the box mean.")
    log(f"  mid = F_ii summed over k1 in [{MID_BAND[0]}, {MID_BAND[1]}] rad/m; hf = k1 in "
        f"[{HF_BAND_FRAC[0]}, {HF_BAND_FRAC[1]}] x pi/dx")
    log("=" * 100)
    for r in results:
        if "accuracy" not in r:
            continue
        refs = r["references"]
        log(f"\n{r['label']}   grid: uu={refs['cov']['grid']['uu']:.3f} vv={refs['cov']['grid']['vv']:.3f} "
            f"ww={refs['cov']['grid']['ww']:.3f} uw={refs['cov']['grid']['uw']:.3f}   full: "
            f"uu={refs['cov']['full']['uu']:.3f} vv={refs['cov']['full']['vv']:.3f} "
            f"ww={refs['cov']['full']['ww']:.3f} uw={refs['cov']['full']['uw']:.3f}  [m^2/s^2]")
        b = refs["bands"]
        log(f"  bins: mid {b['mid']['n_bins']} ({b['mid']['k_lo']:.3f}..{b['mid']['k_hi']:.3f} rad/m), "
            f"hf {b['hf']['n_bins']} ({b['hf']['k_lo']:.3f}..{b['hf']['k_hi']:.3f} rad/m)")
        log(f"  {'generator':22s} {'stat':8s} {'/grid':>16s} {'/full':>16s} {'/exp(ours)':>16s}")
        for g, a in r["accuracy"].items():
            if "ratios" not in a:
                log(f"  {g:22s} ERROR")
                continue
            q = a["ratios"]
            lines = []
            for key in ("uu", "vv", "ww", "uw"):
                lines.append((f"var {key}" if key != "uw" else "cov uw", q["cov"][key]))
            for band in ("mid", "hf"):
                for c in COMPONENTS:
                    lines.append((f"F{c}{c} {band}", q[f"F_{band}"][c]))
            for i, (name, d) in enumerate(lines):
                cells = []
                for rr in ("grid", "full", "expected"):
                    th = d.get(f"ratio_{rr}_se_theory", float("nan"))
                    se, mark = (th, " ") if math.isfinite(th) else (d[f"ratio_{rr}_se"], "*")
                    cells.append(f"{d[f'ratio_{rr}']:.3f}+-{se:.3f}{mark}")
                log(f"  {(g if i == 0 else ''):22s} {name:8s} {cells[0]:>16s} {cells[1]:>16s} {cells[2]:>16s}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small shapes, 1 repeat (< 1 min)")
    ap.add_argument("--json", metavar="PATH", help="write all results to this JSON file")
    ap.add_argument("--shapes", nargs="+", type=parse_shape, metavar="SPEC",
                    help="shapes NXxNYxNZ@D or NXxNYxNZ@DX/DY/DZ (override the mode's list)")
    ap.add_argument("--repeats", type=int, help="fresh-process repeats per timing (default 3, quick 1)")
    ap.add_argument("--peer-modes", default=None,
                    help="comma list of peer settings to time, from: " + ",".join(PEER_SETTINGS)
                    + " (default: all; 'periodic' or 'default' select by mode; 'none' for no peers)")
    acc = ap.add_mutually_exclusive_group()
    acc.add_argument("--accuracy", dest="accuracy", action="store_true", default=None,
                     help="run the accuracy section (default: on)")
    acc.add_argument("--no-accuracy", dest="accuracy", action="store_false")
    ap.add_argument("--seeds", type=int, default=None,
                    help="seeds per peer generator for accuracy (default 3, quick 2)")
    ap.add_argument("--seeds-ours", type=int, default=None,
                    help="seeds for our generator in the accuracy section (default 10, quick 3): ours is "
                    "cheap, and more seeds shrink the standard error of the variances")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        run_child_main(args.child)
        return

    shapes = args.shapes or [parse_shape(s) for s in (QUICK_SHAPES if args.quick else FULL_SHAPES)]
    repeats = args.repeats or (1 if args.quick else 3)
    if repeats < 1:
        ap.error("--repeats must be >= 1")
    do_acc = True if args.accuracy is None else args.accuracy
    nseeds = args.seeds or (2 if args.quick else 3)
    if nseeds < 2:
        ap.error("--seeds must be >= 2 (the standard error needs two)")
    seeds = [1001 + i for i in range(nseeds)]
    nseeds_ours = args.seeds_ours or (3 if args.quick else 10)
    if nseeds_ours < 2:
        ap.error("--seeds-ours must be >= 2")
    seeds_ours = [2001 + i for i in range(nseeds_ours)]
    if args.peer_modes in (None, "all"):
        settings = list(PEER_SETTINGS)
    elif args.peer_modes == "none":
        settings = []
    else:
        settings = []
        for tok in args.peer_modes.split(","):
            tok = tok.strip()
            if tok in ("periodic", "default"):
                settings += [s for s, v in PEER_SETTINGS.items() if v[1] == tok]
            elif tok in PEER_SETTINGS:
                settings.append(tok)
            else:
                ap.error(f"--peer-modes: unknown setting {tok!r}; allowed: {', '.join(PEER_SETTINGS)}, "
                         "periodic, default, all, none")
        settings = list(dict.fromkeys(settings))

    t_start = time.perf_counter()
    meta = {
        **machine(),
        "params": dict(alpha_eps=ALPHA_EPS, length_scale=LENGTH_SCALE, gamma=GAMMA),
        "mode": "quick" if args.quick else "full",
        "repeats": repeats,
        "seeds": seeds if do_acc else None,
        "seeds_ours": seeds_ours if do_acc else None,
        "peer_settings": {s: dict(peer=v[0], mode=v[1], options={k: list(o) if isinstance(o, tuple) else o
                                                                  for k, o in v[2].items()})
                          for s, v in PEER_SETTINGS.items() if s in settings},
        "protocol": (
            "each timing in a fresh subprocess, in rounds (ours, floor, each peer; repeated); imports, then a "
            "64x8x8 warm-up box (excludes numba JIT-cache "
            "load, lazy imports, hipersim pool start), then timed tensor set-up + first box (seed 1); ours also "
            "a second box (seed 2) after dropping the first, and then the floor in the same process "
            "(t_floor_same_child). Times: min over repeats; peak RSS "
            "(VmHWM, absolute, includes interpreter + libraries): max over repeats; "
            "peak_increment = peak - RSS after imports and warm-up. Floor: 3 FFTW threaded c2r 3-D FFTs, "
            "planning excluded, min of 3. Output bytes = 3*Nx*Ny*Nz*4."
        ),
        "bands": {"mid_rad_per_m": list(MID_BAND), "hf_fraction_of_nyquist": list(HF_BAND_FRAC)},
    }
    results = []
    for shape, spacing in shapes:
        results.append(measure_shape(shape, spacing, settings, repeats, do_acc, seeds, seeds_ours,
                                     ("periodic",) if args.quick else ("periodic", "default")))
        if args.json:  # keep partial results if a later shape fails
            write_json(args.json, {"meta": dict(meta, total_wall_s=time.perf_counter() - t_start), "shapes": results})
    print_tables(results)
    total = time.perf_counter() - t_start
    log(f"\ntotal benchmark wall time {total:.1f} s")
    if args.json:
        write_json(args.json, {"meta": dict(meta, total_wall_s=total), "shapes": results})
        log(f"JSON written to {args.json}")


if __name__ == "__main__":
    main()
