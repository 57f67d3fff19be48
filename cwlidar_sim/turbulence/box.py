"""Periodic 3-D Mann turbulence boxes (Mann 1998)."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from .._repr import summary_repr
from .. import _config
from .._validation import check_bool, check_choice, check_int, check_memory, check_real, check_seed, check_tuple
from .parameters import MannParameters
from .tensor import _check_params, _prefactor, lifetime_table

CORRECTIONS = ("cell", "none")
#: Modes with every |k_i| <= _REGION * max(dk) get the cell-integrated tensor.
_REGION = 3.0
#: Gauss-Legendre points per axis in each (sub-)cell of the adaptive integral.
_GAUSS_POINTS = 4
#: Target number of modes filled per task (fixes the chunking, hence the
#: random streams, independently of the thread count).
_MODES_PER_CHUNK = 1 << 16
#: Wavenumbers at which the full analytic spectra are computed for the
#: high-frequency compensation (interpolated in log-log between them).
_HF_TABLE = 96


#: Cells per task of the parallel cell integrals (any value gives the same result).
_CELLS_PER_TASK = 16


@dataclasses.dataclass(frozen=True)
class _Setup:
    corr_33: np.ndarray  # (2r1+1, 2r2+1, 2r3+1, 3, 3), amplitude matrices of corrected modes
    r: tuple  # (r1, r2, r3)
    gain_x3: np.ndarray  # (N1, 3) per-row, per-component gain
    ftab: np.ndarray  # eddy lifetime f on the bit-indexed nodes of (|k| L)^2 (see _kernels.box_params)
    fbase: int  # code of its first node


def _check_grid(shape, spacing):
    shape = check_tuple("shape", shape, 3, lambda n, v: check_int(n, v, lo=2))
    spacing = check_tuple("spacing", spacing, 3, lambda n, v: check_real(n, v, lo=0.0, lo_open=True))
    return shape, spacing


def _dk(shape, spacing):
    return tuple(2.0 * math.pi / (n * d) for n, d in zip(shape, spacing))


def _canonical_cells(r):
    """Map every cell (s1, s2, s3), |s_i| <= r_i, to a canonical one.

    Phi(-k) = Phi(k) (a real field), and the reflection y -> -y of the
    sheared flow gives Phi(k1, -k2, k3) = S Phi(k) S with S = diag(1, -1, 1);
    cells are symmetric about their centres, so their averages obey the same
    rules.  Canonical cells have s2 >= 0, s3 >= 0 and, where s3 = 0, s1 >= 0
    (about a quarter of the region).  Returns the canonical (s1, s2, s3) rows,
    and for every cell of the full region (C order) the row of its canonical
    cell and whether S Phi S applies.
    """
    r1, r2, r3 = r
    g1, g2, g3 = (a.ravel() for a in np.meshgrid(np.arange(-r1, r1 + 1), np.arange(-r2, r2 + 1),
                                                 np.arange(-r3, r3 + 1), indexing="ij"))
    neg3 = g3 < 0
    c1, c2, c3 = np.where(neg3, -g1, g1), np.where(neg3, -g2, g2), np.abs(g3)
    flip = c2 < 0
    c2 = np.abs(c2)
    # (s1, s2, 0) with s1 < 0 equals (-s1, -s2, 0), the mirror of (-s1, s2, 0).
    z = (c3 == 0) & (c1 < 0)
    c1 = np.where(z, -c1, c1)
    flip ^= z
    code = (c1 + r1) * (r2 + 1) * (r3 + 1) + c2 * (r3 + 1) + c3
    keys, row = np.unique(code, return_inverse=True)
    s1 = keys // ((r2 + 1) * (r3 + 1)) - r1
    s2 = (keys // (r3 + 1)) % (r2 + 1)
    s3 = keys % (r3 + 1)
    return np.stack([s1, s2, s3], axis=1), row, flip


def _correction_setup(params, shape, spacing, correction):
    from ._kernels import cell_average_kernel

    dk = _dk(shape, spacing)
    if correction == "none":
        return np.zeros((1, 1, 1, 3, 3)), (-1, -1, -1)
    dk_max = max(dk)
    # Stay clear of the Nyquist index, whose sign is a convention.
    r = tuple(int(min((n - 1) // 2, math.floor(_REGION * dk_max / d + 1e-9))) for n, d in zip(shape, dk))
    cells, row, flip = _canonical_cells(r)
    kc = cells * np.asarray(dk)
    gx, gw = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
    phi = np.empty((kc.shape[0], 3, 3))
    half = 0.5 * np.asarray(dk)
    tab = lifetime_table()
    # Cells near the k1 axis cost thousands of times more than the rest
    # (refinement toward the singular origin); small tasks handed to
    # whichever thread is free spread them.  Every cell is computed alone,
    # so the result does not depend on the split.
    tasks = [(lo, min(len(kc), lo + _CELLS_PER_TASK)) for lo in range(0, len(kc), _CELLS_PER_TASK)]

    def work(_w, t):
        cell_average_kernel(kc[t[0]:t[1]], half, gx, gw, params.length_scale, params.gamma, tab, phi[t[0]:t[1]])

    from .._fft import run_dynamic

    run_dynamic(tasks, work)
    lam, vec = np.linalg.eigh(phi)
    m = (vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]) @ np.swapaxes(vec, 1, 2)
    # sqrt(S Phi S) = S sqrt(Phi) S: the 12, 21, 23 and 32 entries change sign.
    m = m[row]
    sgn = np.array([[1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, -1.0, 1.0]])
    m[flip] *= sgn
    return m.reshape(tuple(2 * ri + 1 for ri in r) + (3, 3)), r


def _lifetime_nodes_table(params, shape, spacing):
    """Eddy lifetime f on the bit-indexed nodes covering every mode of the box."""
    from scipy.special import hyp2f1

    from ._kernels import lifetime_bits_nodes

    L = params.length_scale
    dk = _dk(shape, spacing)
    k_max2 = sum((math.pi / d) ** 2 for d in spacing)
    t_nodes, base = lifetime_bits_nodes(L * L * min(dk) ** 2, L * L * k_max2)
    x = np.sqrt(t_nodes)
    f = x ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1.0 / 3.0, 17.0 / 6.0, 4.0 / 3.0, -(x**-2)))
    if not np.all(np.isfinite(f) & (f > 0)):  # pragma: no cover  (hyp2f1 is finite for x > 0)
        raise RuntimeError("eddy lifetime table is not finite")
    return f, base


def _raw_box_spectra(params, shape, spacing, corr_33, r, ftab, fbase):
    """Sum over (n2, n3) of M M^T for rows n1 = 0..N1/2 (no scale factors), as the generator draws them.

    The Nyquist row of an even N1 pairs its modes within itself: the mode
    with k3 < 0 is the conjugate of a stored mode of the same row, so it
    carries that mode's matrix (the tensor at ``-pi/dx`` with the signs of
    k2, k3 flipped, not at ``-pi/dx`` with its own k2, k3; the sheared tensor
    tells the two apart): that row is the sum of the generator's own
    matrices (``box_phi_rows_kernel``, checked against many seeds in
    tests/analysis/test_linear_theory_nyquist.py).  ``box_spectrum_kernel``'s
    row there was 17 % (u), 31 % (v), 13 % (w) low on an 8x6x4 box and had
    the wrong sign of uw.
    """
    from ._conditioning_kernels import box_phi_rows_kernel
    from ._kernels import box_spectrum_kernel

    N1, N2, N3 = shape
    rows = N1 // 2 + 1
    out = np.empty((rows, 6))
    per = max(1, _MODES_PER_CHUNK // (N2 * N3))
    tasks = [(lo, min(rows, lo + per)) for lo in range(0, rows, per)]

    def work(_w, t):
        box_spectrum_kernel(t[0], t[1], N1, N2, N3, *spacing, params.length_scale, params.gamma, ftab, fbase,
                            corr_33, *r, out[t[0]:t[1]])

    _config.run_static(tasks, work)
    if N1 % 2 == 0:
        nyq = np.empty((1, N2, N3, 6))
        box_phi_rows_kernel(np.array([N1 // 2], dtype=np.int64), N3, N1, N2, N3, *spacing, params.length_scale,
                            params.gamma, ftab, fbase, corr_33, *r, False, nyq)
        out[-1] = nyq[0].sum(axis=(0, 1))
    return out


@functools.lru_cache(maxsize=4)
def _setup(params, shape, spacing, correction, hf_compensation) -> _Setup:
    corr_33, r = _correction_setup(params, shape, spacing, correction)
    ftab, fbase = _lifetime_nodes_table(params, shape, spacing)
    N1 = shape[0]
    gain = np.ones((N1, 3))
    if hf_compensation:
        from scipy.interpolate import CubicSpline

        from .spectra import _one_point_two_sided

        dk = _dk(shape, spacing)
        raw = _raw_box_spectra(params, shape, spacing, corr_33, r, ftab, fbase)
        pre2 = _prefactor(params) ** 2
        f_box = raw[:, :3] * pre2 * dk[1] * dk[2]
        k_rows = dk[0] * np.arange(raw.shape[0])
        k_tab = np.geomspace(dk[0], max(k_rows[-1], dk[0] * 1.0001), _HF_TABLE)
        F = np.stack(_one_point_two_sided(np.concatenate([[0.0], k_tab]), params)[:3], axis=1)
        f_full = np.empty_like(f_box)
        f_full[0] = F[0]
        spl = CubicSpline(np.log(k_tab), np.log(F[1:]), axis=0)
        f_full[1:] = np.exp(spl(np.log(k_rows[1:])))
        with np.errstate(divide="ignore", invalid="ignore"):
            g_half = np.where(f_box > 0, np.sqrt(f_full / f_box), 1.0)
        # gain is even in k1: row n1 and row N1 - n1 share it.
        idx = np.minimum(np.arange(N1), N1 - np.arange(N1))
        gain = g_half[idx]
    for a in (corr_33, gain, ftab):
        a.setflags(write=False)
    return _Setup(corr_33=corr_33, r=r, gain_x3=gain, ftab=ftab, fbase=fbase)


#: Field kinds of the noise keys: a box, a line and a plane of one seed draw
#: independent noise.
NOISE_BOX, NOISE_LINE, NOISE_PLANE = 0, 1, 2


def _noise_keys(seed, kind=NOISE_BOX):
    """The two 64-bit keys of a field's counter-based noise (see _kernels.rng).

    Boxes: the first two words of ``SeedSequence(seed)``; lines and planes:
    of ``SeedSequence(seed, spawn_key=(kind,))``.
    """
    ss = np.random.SeedSequence(seed) if kind == NOISE_BOX else np.random.SeedSequence(seed, spawn_key=(kind,))
    key, key_b = ss.generate_state(2, dtype=np.uint64)
    return np.uint64(key), np.uint64(key_b)


def _check_noise_shape(what, shape, max_shape):
    # The noise counters pack the signed wavenumber indices into 61 bits.
    for i, (n, m) in enumerate(zip(shape, max_shape)):
        if n > m:
            raise ValueError(f"shape[{i}] of {what} must be at most {m} (the noise keys' range), got {n}")


def _chunk_rows(shape):
    N1, N2, N3 = shape
    per = max(1, _MODES_PER_CHUNK // (N2 * (N3 // 2 + 1)))
    return [(lo, min(N1, lo + per)) for lo in range(0, N1, per)]


def box_nbytes(shape, dtype=np.float32) -> int:
    """Bytes held by a box of this shape: three padded real arrays."""
    N1, N2, N3 = shape
    return 3 * N1 * N2 * 2 * (N3 // 2 + 1) * np.dtype(dtype).itemsize


class BoxGenerator:
    """Generator of Mann boxes that share parameters, shape and spacing.

    The set-up (corrected low-wavenumber modes, high-frequency gains and,
    with ``cache_stencil``, the amplitude parameters of every mode) is done
    once; each :meth:`generate` then costs the random numbers, one pass of
    arithmetic per mode and three inverse FFTs.

    Parameters
    ----------
    params, shape, spacing, correction, hf_compensation
        As for :func:`generate_box`.
    cache_stencil : bool
        Keep five float32 amplitude parameters per mode of one half of the
        k2 axis, ``20 * Nx * (Ny//2 + 1) * (Nz//2 + 1)`` bytes (about 0.43 x
        the float32 box): later boxes skip the tensor arithmetic, about a
        third of the work of filling the spectra (the whole box about
        1.17 x faster, measured on 2 cores at 4096 x 32 x 32 and
        8192 x 64 x 64).  Default False.
    """

    def __init__(self, params: MannParameters, shape, spacing, *, correction: str = "cell",
                 hf_compensation: bool = False, cache_stencil: bool = False):
        _check_params(params)
        self.params = params
        self.shape, self.spacing = _check_grid(shape, spacing)
        self.correction = check_choice("correction", correction, CORRECTIONS)
        self.hf_compensation = check_bool("hf_compensation", hf_compensation)
        self.cache_stencil = check_bool("cache_stencil", cache_stencil)
        from ._kernels import BOX_MAX_SHAPE

        _check_noise_shape("a box", self.shape, BOX_MAX_SHAPE)
        check_memory(f"a box of shape {self.shape}", box_nbytes(self.shape) + self.stencil_nbytes)
        self._setup = _setup(params, self.shape, self.spacing, self.correction, self.hf_compensation)
        self._stencil = self._build_stencil() if self.cache_stencil else None

    @property
    def stencil_nbytes(self) -> int:
        """Bytes of the cached amplitude stencil (0 without ``cache_stencil``)."""
        if not self.cache_stencil:
            return 0
        N1, N2, N3 = self.shape
        return 20 * N1 * (N2 // 2 + 1) * (N3 // 2 + 1)

    def _build_stencil(self):
        from ._kernels import stencil_kernel

        N1, N2, N3 = self.shape
        st = np.empty((N1, N2 // 2 + 1, N3 // 2 + 1, 5), dtype=np.float32)
        p, su = self.params, self._setup

        def work(_w, t):
            lo, hi = t
            stencil_kernel(lo, hi, N1, N2, N3, *self.spacing, p.length_scale, p.gamma, su.ftab, su.fbase,
                           st[lo:hi])

        _config.apply_numba_threads()
        _config.run_static(_chunk_rows(self.shape), work)
        return st

    def generate(self, seed: int, *, keep_mean: bool = False, sigma_u: float | None = None,
                 dtype=np.float32, progress: bool = False):
        """Generate one box; see :func:`generate_box` for the arguments and result."""
        seed = check_seed("seed", seed)
        keep_mean = check_bool("keep_mean", keep_mean)
        if sigma_u is not None:
            sigma_u = check_real("sigma_u", sigma_u, lo=0.0, lo_open=True)
        dt = np.dtype(dtype)
        if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise TypeError(f"dtype must be float32 or float64, got {dt}")
        check_memory(f"a box of shape {self.shape}", box_nbytes(self.shape, dt))

        from .. import _fft
        from ._kernels import fill_box_kernel

        params, spacing, st = self.params, self.spacing, self._setup
        N1, N2, N3 = self.shape
        dk = _dk(self.shape, spacing)
        scale = _prefactor(params) * math.sqrt(dk[0] * dk[1] * dk[2])
        specs = [_fft.empty_halfspectrum(self.shape, dt) for _ in range(3)]
        chunks = _chunk_rows(self.shape)
        key, key_b = _noise_keys(seed)
        bar = _progress_bar(progress, len(chunks) + 3, "box")
        stencil = self._stencil
        use = stencil is not None
        dummy = np.zeros((1, 1, 1, 5), np.float32)

        def fill(_w, task):
            lo, hi = task
            # The noise is drawn inside the kernel from counters: every mode's
            # numbers depend on the seed and the mode's index only.
            fill_box_kernel(specs[0], specs[1], specs[2], lo, hi, N3, *spacing, params.length_scale,
                            params.gamma, st.ftab, st.fbase, st.corr_33, *st.r, st.gain_x3, scale, keep_mean,
                            stencil[lo:hi] if use else dummy, use, key, key_b)
            if bar is not None:
                bar.update(1)

        # Threads take chunks as they come free: which thread fills a chunk
        # changes nothing in it.  The kernel also makes the planes k3 = 0
        # and Nyquist Hermitian.
        _fft.run_dynamic(chunks, fill)
        out = []
        plans = _fft.new_plan_store()  # u, v and w share their FFT plans
        for spec in specs:
            out.append(_fft.irfftn_inplace_shared(spec, N3, plans))
            if bar is not None:
                bar.update(1)
        del plans
        if bar is not None:
            bar.close()
        if sigma_u is not None:
            f = sigma_u / math.sqrt(_variance(out[0]))
            for a in out:
                _scale_inplace(a, f)
        attrs = dict(
            params.as_dict(),
            seed=seed,
            dx=spacing[0],
            dy=spacing[1],
            dz=spacing[2],
            correction=self.correction,
            hf_compensation=int(self.hf_compensation),
            keep_mean=int(keep_mean),
            generator="cwlidar_sim.turbulence.generate_box",
        )
        if sigma_u is not None:
            attrs["sigma_u_target"] = sigma_u
        return _as_dataset(out, spacing, attrs)


def generate_box(
    params: MannParameters,
    shape,
    spacing,
    seed: int,
    *,
    correction: str = "cell",
    hf_compensation: bool = False,
    keep_mean: bool = False,
    sigma_u: float | None = None,
    dtype=np.float32,
    progress: bool = False,
):
    """Generate a periodic Mann turbulence box.

    Parameters
    ----------
    params : MannParameters
        Tensor parameters.
    shape : (int, int, int)
        Number of points (Nx, Ny, Nz), each >= 2; any size (not only powers
        of two, though those are fastest).
    spacing : (float, float, float)
        Grid spacing (dx, dy, dz) [m], > 0; may differ between axes.
    seed : int
        Seed, 0 <= seed < 2**63.  The same seed gives the same box bit for bit
        whatever the thread count; float32 and float64 boxes of one seed agree
        to float32 precision; boxes of one seed and one physical size
        ``shape * spacing`` on other grids hold the same Fourier coefficients
        at the wavenumbers they share (see Notes).  (Boxes of a given seed
        differ from those of cwlidar_sim versions before the wavenumber-keyed
        noise.)
    correction : {"cell", "none"}
        How the modes near k = 0 are weighted (see Notes).  Default "cell".
    hf_compensation : bool
        Scale each k1 row of each component so that the box's expected
        one-point spectrum F_ii(k1) equals the full analytic one (the grid's
        lateral cut-off otherwise removes up to half of F11 at high k1).
    keep_mean : bool
        Keep the k = 0 mode with the tensor integrated over the central cell,
        so that the box mean fluctuates (scales longer than the box); default
        False, a zero-mean box.  With ``"cell"`` and ``keep_mean`` the
        variance about zero equals the grid-resolved integral.
    sigma_u : float, optional
        Rescale u, v and w by one common factor so that the sample standard
        deviation of u is exactly this [m/s].
    dtype : float32 or float64
        Output precision (default float32).
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    box : xarray.Dataset
        ``u``, ``v``, ``w`` [m/s] on dims ("x", "y", "z") with coordinates
        x = i dx, y = j dy, z = l dz [m]; attributes hold the parameters and
        settings.  u is along x (the mean wind), w vertical.  The arrays are
        views into FFTW's in-place buffers (not C-contiguous: each z-row keeps
        one or two padding values).

    Notes
    -----
    The field is the sum over the box's discrete wave vectors of
    ``sqrt(dk1 dk2 dk3) M(k) n(k)`` with complex Gaussian ``n`` made
    Hermitian, followed by an inverse 3-D FFT.  Its expected covariance is
    therefore a Riemann sum of the tensor over the grid's wave vectors.

    * ``"none"``: plain Riemann sum (the tensor at each mode).  Wrong wherever
      the tensor changes within one wavenumber cell, i.e. at low |k| unless
      the box is many L wide.  With shear the tensor is singular at k = 0
      (Phi33 grows like 1/|k|^2 because the eddy lifetime diverges), so a
      long thin box, whose k1 spacing is much finer than its k2, k3 spacing,
      puts far too much variance in the modes (k1, 0, 0) near the axis: for
      4096 x 32 x 32 at 2 m the expected sigma_w^2 is over ten times the
      tensor's.  Use only to reproduce uncorrected generators.
    * ``"cell"`` (default): modes with every |k_i| <= 3 max(dk) use the
      tensor averaged over their wavenumber cell (adaptive Gauss-Legendre,
      refined toward the singular origin), factorised by a symmetric square
      root.  The expected covariance then equals the tensor
      integrated over the wave vectors the grid holds (|k_i| <= pi/d_i) to
      within a fraction of a percent.  What it loses: the variance of scales
      larger than the box is folded into the box's lowest modes, so the
      lateral and vertical coherence of those modes is that of a periodic
      box; the k = 0 mode (the box mean) is set to zero, which removes the
      tensor integrated over the central cell (reported by
      :func:`expected_box_covariance`).

    Mann (1998) weights the tensor by sinc^2(kappa_i L_i / 2) around each mode
    instead of the cell's box-car.  The box-car is used here because cells
    tile wave-vector space exactly, so the expected covariance is the
    grid-resolved integral by construction, while the sinc^2 window's 1/x^2
    tails must be truncated and renormalised (about 6 % of its weight lies
    beyond +/-3 cells).

    High-k1 content lost by a coarse lateral grid is not restored by any
    correction; ``hf_compensation`` restores the one-point auto-spectra
    (the cross-spectrum F13 becomes g1 g3 F13 of the grid, and the lateral
    coherence at high k1 is that of the few resolved modes).

    The normals are drawn inside the kernel that computes M, from counters:
    normal c (six per mode of the half spectrum) is a 256-layer ziggurat
    (Marsaglia & Tsang 2000) on output c of SplitMix64 keyed by
    ``SeedSequence(seed)``, and a mode's six counters are keyed by its
    signed wavenumber indices (s1, s2, s3), k_i = 2 pi s_i / (N_i d_i), not
    by its position in the arrays: they depend on the seed and the
    wavenumber only, not on how modes are shared among threads nor on the
    grid.  The planes k3 = 0 and (even Nz) k3 = Nyquist are made Hermitian
    in (k1, k2) (mode -k the conjugate of mode k, self-conjugate modes real
    with the full variance); of each pair the mode with s1 > 0, or s1 = 0
    and s2 > 0, is drawn, a rule of the wavenumbers too.

    Grid consistency: two boxes of one physical size (N_i d_i equal), one
    seed, one ``correction`` and no ``hf_compensation`` (whose gains depend
    on the grid by design) have the same coefficient, to round-off, at
    every wavenumber with |s_i| < N_i / 2 on both grids, so the finer box
    low-pass filtered to the coarser one's band is the coarser box (tested,
    float64: 5e-15 of the rms coefficient).  The cell-corrected region
    depends on the wavenumber spacing only (up to grids under 8 points
    across an axis).  Nyquist modes (index N_i / 2 of an even axis) are not
    shared: on the coarse grid the index stands for both +-pi/d_i.  They are
    evaluated and keyed at s_i = -N_i / 2 (numpy's fftfreq sign), so off the
    Hermitian planes they equal the finer grid's mode at -N_i / 2 (unless
    that mode is cell-corrected there); in the planes k3 = 0 and Nyquist
    they are the coarse grid's own (a mode made Hermitian with its mirror,
    or the z-Nyquist's averaged tensor below).  A comparison of two grids
    is therefore paired only in the band both resolve, which is what a
    refinement study wants; :mod:`cwlidar_sim.turbulence.grids` builds
    grids of one physical size.  The Nyquist plane stands for both k3 = +pi/dz and
    -pi/dz, which with shear carry different spectra; since the Hermitian
    constraint gives a mode and its mirror one variance, each gets the
    average of the tensor at the two, as ``expected_box_covariance`` does.

    Speed and memory: a box costs filling the three half spectra -- per
    mode and core about 27 ns for its six normals and their mix and 17 ns
    for the tensor (one evaluation serves the two modes (k1, +-k2, k3)) --
    and three inverse FFTs, done in two cache-friendly passes.  Measured
    on 2 cores (``benchmarks/bench_turbulence.py``, unloaded machine), with
    the set-up cached (a second box of one configuration) a box takes 1.85,
    1.35 and 0.88 times three of FFTW's own threaded inverse 3-D FFTs of its
    shape at 4096 x 32 x 32, 8192 x 64 x 64 (2 m) and 16384 x 32 x 32
    (0.5/4/4 m); set-up plus first box takes 0.21, 1.07 and 0.52 s, 5.9,
    9.3 and 10 times faster than the faster of mannrs and hipersim run
    periodic.  The set-up (cell integrals near k = 0, once per
    configuration, kept for the next four) takes about 0.1 s.  The three
    half spectra are transformed in place and no noise is stored, so the
    peak is the output (``box_nbytes``: 3 Nx Ny (Nz + 2) values for even
    Nz, 1.06 x the three unpadded arrays at Nz = 32) plus a few kB per
    thread and the set-up tables: measured peak increments 1.04-1.17 x the
    three float32 arrays.  For many boxes of one configuration use
    :class:`BoxGenerator` (optionally with its cached stencil).
    """
    gen = BoxGenerator(params, shape, spacing, correction=correction, hf_compensation=hf_compensation)
    return gen.generate(seed, keep_mean=keep_mean, sigma_u=sigma_u, dtype=dtype, progress=progress)


@dataclasses.dataclass(frozen=True)
class BoxExpectation:
    """What a box is built to have, in the ensemble mean.

    Attributes
    ----------
    covariances : Covariances
        Expected *sample* covariances of the box (about its own mean)
        [m^2 s^-2]; what ``box.u.var()`` estimates.
    mean_covariances : Covariances
        The tensor integrated over the central wavenumber cell
        |k_i| < dk_i / 2: the variance of scales larger than the box, which
        would appear as the box mean and is removed (the k = 0 mode is zero).
        ``covariances + mean_covariances`` is the grid-resolved integral up to
        quadrature error.
    k1_k : ndarray
        Non-negative wavenumbers of the box, 0 .. pi/dx [rad/m].
    F_k4 : ndarray, shape (len(k1_k), 4)
        Expected *one-sided* one-point spectra (F11, F22, F33, F13)
        [m^3 s^-2] at ``k1_k``, like :func:`one_point_spectra`'s (what the
        one-sided x-periodogram of the box, averaged over y and z,
        estimates; ``covariances.uu`` is the sum of ``F_k4[:, 0] dk1`` over
        the rows, the k1 = 0 row and the Nyquist row of an even Nx counted
        half).
    """

    __repr__ = summary_repr

    covariances: object
    mean_covariances: object
    k1_k: np.ndarray
    F_k4: np.ndarray


def expected_box_covariance(params: MannParameters, shape, spacing, *, correction: str = "cell",
                            hf_compensation: bool = False) -> BoxExpectation:
    """Covariances and one-point spectra a box is built to have (ensemble mean).

    Parameters
    ----------
    params, shape, spacing, correction, hf_compensation
        As for :func:`generate_box`.

    Returns
    -------
    BoxExpectation
    """
    from ._kernels import cell_average_kernel
    from .spectra import Covariances

    _check_params(params)
    shape, spacing = _check_grid(shape, spacing)
    check_choice("correction", correction, CORRECTIONS)
    st = _setup(params, shape, spacing, correction, bool(hf_compensation))
    raw = _raw_box_spectra(params, shape, spacing, st.corr_33, st.r, st.ftab, st.fbase)
    dk = _dk(shape, spacing)
    rows = raw.shape[0]
    g = st.gain_x3[:rows]
    pre2 = _prefactor(params) ** 2
    F = np.empty((rows, 4))
    F[:, :3] = raw[:, :3] * g**2
    F[:, 3] = raw[:, 3] * g[:, 0] * g[:, 2]
    F *= pre2 * dk[1] * dk[2]
    # Sum over all rows n1 = 0..N1-1: rows 1..ceil(N1/2)-1 appear twice (+-k1).
    mult = np.full(rows, 2.0)
    mult[0] = 1.0
    if shape[0] % 2 == 0:
        mult[-1] = 1.0
    tot = (mult[:, None] * F).sum(axis=0) * dk[0]
    gx, gw = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
    phi0 = np.empty((1, 3, 3))
    cell_average_kernel(np.zeros((1, 3)), 0.5 * np.asarray(dk), gx, gw, params.length_scale, params.gamma,
                        lifetime_table(), phi0)
    c0 = phi0[0] * pre2 * dk[0] * dk[1] * dk[2]
    return BoxExpectation(
        covariances=Covariances(uu=tot[0], vv=tot[1], ww=tot[2], uw=tot[3]),
        mean_covariances=Covariances(uu=c0[0, 0], vv=c0[1, 1], ww=c0[2, 2], uw=c0[0, 2]),
        k1_k=dk[0] * np.arange(rows),
        F_k4=2.0 * F,
    )


def _variance(a) -> float:
    # Accumulated slab by slab in float64: no temporary the size of the box.
    n = a.size
    s = 0.0
    s2 = 0.0
    for i in range(a.shape[0]):
        sl = np.asarray(a[i], dtype=np.float64)
        s += sl.sum()
        s2 += np.square(sl).sum()
    mean = s / n
    return s2 / n - mean * mean


def _scale_inplace(a, f):
    for i in range(a.shape[0]):
        a[i] *= f


def keep_lateral_rows(a, ny: int) -> np.ndarray:
    """``a[:, :ny, :]`` as a C-contiguous array, moved down within ``a``'s own buffer where it can be.

    For a component of :func:`generate_box` (a view into its FFT buffer,
    padded z-rows) of which only the first ``ny`` y-rows are kept (a
    laterally doubled box): the kept rows are moved to the buffer's start
    in x order, which never overwrites a row still to be read (row i's
    destination ends at (i + 1) ny nz, row i + 1's source starts at
    (i + 1) ny_gen nz_pad), instead of being copied to new memory (a tenth
    of the time: no fresh pages to fault in).  ``a`` is spent.  Any other
    layout is copied.
    """
    nx, _, nz = a.shape
    base = a
    while isinstance(base, np.ndarray) and base.base is not None:
        base = base.base
    base = np.asarray(base)
    n = nx * ny * nz * a.itemsize
    s0, s1, s2 = a.strides
    ok = (base.flags.c_contiguous and base.flags.writeable and base.nbytes >= n and s2 == a.itemsize
          and s1 >= nz * a.itemsize and s0 >= ny * s1 and a.ctypes.data == base.ctypes.data)
    if not ok:
        return np.ascontiguousarray(a[:, :ny, :])
    out = base.reshape(-1).view(np.uint8)[:n].view(a.dtype).reshape(nx, ny, nz)
    for i in range(nx):  # row 0 overlaps its own source: numpy copies through a buffer there
        out[i] = a[i, :ny, :]
    return out


def _as_dataset(arrays, spacing, attrs):
    import xarray as xr

    dims = ("x", "y", "z")[: arrays[0].ndim]
    coords = {d: (d, np.arange(n) * s, {"units": "m"}) for d, n, s in zip(dims, arrays[0].shape, spacing)}
    names = {"u": "longitudinal velocity fluctuation", "v": "lateral velocity fluctuation",
             "w": "vertical velocity fluctuation"}
    data = {c: (dims, a, {"units": "m s-1", "long_name": names[c]}) for c, a in zip("uvw", arrays)}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _progress_bar(enabled, total, desc):
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="step", leave=False)
