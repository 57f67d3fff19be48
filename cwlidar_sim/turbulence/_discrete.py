"""The discrete spectra of the generated fields, mode by mode (for conditioning).

A line, plane or box of this package is ``f(x) = sum_k S(k) exp(i k.x)`` over
the modes of its periodic grid, with independent modes except for the
conjugate pairs ``S(-k) = S(k)*`` of a real field, and ``E[S(k) S(k)^H] =
Phi_d(k)``, the *discrete* spectral matrix the generator draws each mode from
(the tensor at the mode, or its cell average near k = 0, times the cell
volume, the high-frequency gains, the Hermitian and Nyquist rules of the
generator).  Its covariance is ``C(x - x') = sum_k Phi_d(k) exp(i k.(x - x'))``.
:class:`DiscreteField` gives ``Phi_d`` for rows of k1 in the layout of
``_conditioning_kernels`` and synthesises real fields from half spectra in the
generators' layout (through ``_fft``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

#: 6-vector order of the spectral components, as in the generator's kernels.
PAIRS6 = ((0, 0), (1, 1), (2, 2), (0, 2), (0, 1), (1, 2))
#: Row chunk of the box kernels: about this many lateral modes per task.
_MODES_PER_TASK = 1 << 15


def _to6(m_n33):
    return np.stack([m_n33[..., i, j] for i, j in PAIRS6], axis=-1)


@dataclasses.dataclass(frozen=True, eq=False)
class DiscreteField:
    """Discrete spectra and synthesis of one field configuration.

    Attributes
    ----------
    kind : {"line", "plane", "box"}
    shape : tuple of int
        Real shape of the field.
    spacing : tuple of float
        Its spacing [m].
    lat : (int, int)
        Lateral grid (N2, N3) of the kernels' layout: (1, 1) line, (1, Ny)
        plane, (Ny, Nz) box.
    """

    kind: str
    shape: tuple
    spacing: tuple
    lat: tuple
    params: object
    settings: dict
    _tab: object = None

    @property
    def n1(self) -> int:
        return self.shape[0]

    @property
    def half_lat(self) -> int:
        """Length of the halved lateral axis (the rfft axis) of the half spectrum."""
        return 1 if self.kind == "line" else self.lat[1] // 2 + 1

    @property
    def rows_half(self) -> np.ndarray:
        """The k1 rows n1 = 0 .. N1/2 (non-negative k1)."""
        return np.arange(self.n1 // 2 + 1)

    @property
    def dk1(self) -> float:
        return 2.0 * math.pi / (self.shape[0] * self.spacing[0])

    def k1_of_rows(self, rows) -> np.ndarray:
        r = np.asarray(rows)
        return self.dk1 * np.where(2 * r < self.n1, r, r - self.n1)

    def phi_rows(self, rows, *, half: bool = False, threaded: bool = True) -> np.ndarray:
        """Phi_d of rows ``rows`` on the full lateral grid (or its half) [m^2 s^-2 per mode].

        Returns (len(rows), N2, N3 or N3//2+1, 6) float64 in the component
        order (11, 22, 33, 13, 12, 23); the sum over every mode of the field
        is its covariance at zero lag.  ``threaded=False`` computes on the
        calling thread (for callers that are worker threads themselves).
        """
        rows = np.ascontiguousarray(rows, dtype=np.int64)
        if self.kind == "line":
            k, F6 = self._tab
            if np.any(2 * rows > self.n1):
                raise ValueError("a line holds rows n1 <= N1/2 only (its half spectrum)")
            return np.ascontiguousarray(F6[rows][:, None, None, :])
        if self.kind == "plane":
            return self._plane_rows(rows, half)
        return self._box_rows(rows, half, threaded)

    def _plane_rows(self, rows, half):
        T = self._tab  # (N1, N2h, 6), the drawn matrices of the stored modes
        N1, N2 = self.shape
        n2h = N2 // 2 + 1
        width = n2h if half else N2
        j = np.arange(width)
        out = np.empty((rows.size, 1, width, 6))
        m1 = (N1 - rows) % N1
        stored = j < n2h
        # k2 = 0 and Nyquist columns: the smaller index of (n1, -n1) was drawn.
        special = (j == 0) | ((N2 % 2 == 0) & (j == N2 // 2))
        drawn = np.minimum(rows, m1)
        for col in np.nonzero(stored)[0]:
            src = drawn if special[col] else rows
            out[:, 0, col] = T[src, col]
        for col in np.nonzero(~stored)[0]:
            out[:, 0, col] = T[m1, N2 - col]
        return out

    def _box_rows(self, rows, half, threaded):
        from ._conditioning_kernels import box_phi_rows_kernel

        st, pre2 = self._tab
        N1, N2, N3 = self.shape
        n_j3 = N3 // 2 + 1 if half else N3
        out = np.empty((rows.size, N2, n_j3, 6))
        L, g = self.params.length_scale, self.params.gamma
        keep_mean = bool(self.settings["keep_mean"])
        per = max(1, _MODES_PER_TASK // (N2 * n_j3))
        tasks = [(lo, min(rows.size, lo + per)) for lo in range(0, rows.size, per)]

        def work(_w, t):
            lo, hi = t
            box_phi_rows_kernel(rows[lo:hi], n_j3, N1, N2, N3, *self.spacing, L, g, st.ftab, st.fbase, st.corr_33,
                                *st.r, keep_mean, out[lo:hi])

        from .. import _config

        if threaded:
            _config.run_static(tasks, work)
        else:
            for t in tasks:
                work(0, t)
        gain = st.gain_x3[rows]  # (R, 3)
        fac = np.stack([gain[:, i] * gain[:, j] for i, j in PAIRS6], axis=-1) * pre2
        out *= fac[:, None, None, :]
        return out

    # -- synthesis -----------------------------------------------------------
    def empty_spectra(self, dtype=np.float64):
        """Three zeroed half spectra and their views in the kernels' 3-D layout."""
        from .. import _fft

        specs = [_fft.empty_halfspectrum(self.shape, dtype) for _ in range(3)]
        for s in specs:
            s[...] = 0.0
        if self.kind == "line":
            views = [s[:, None, None] for s in specs]
        elif self.kind == "plane":
            views = [s[:, None, :] for s in specs]
        else:
            views = specs
        return specs, views

    def synthesize(self, specs):
        """Real fields ``sum_k S(k) exp(i k.x)`` of the half spectra (destroyed)."""
        from .. import _fft

        if self.kind == "box":
            plans = _fft.new_plan_store()
            out = [_fft.irfftn_inplace_shared(s, self.shape[-1], plans) for s in specs]
            del plans
            return out
        return [_fft.irfftn_inplace(s, self.shape[-1]) for s in specs]

    def covariance_functions(self):
        """C_c(lag) = sum_k Phi_d,c(k) exp(i k.lag) on every lag of the grid, c in PAIRS6 order.

        Returns a float64 array (6,) + shape.  Costs six inverse FFTs of the
        field's size and 8 bytes per grid point per component.
        """
        from .. import _fft

        rows = np.arange(self.n1) if self.kind != "line" else self.rows_half
        phi = self.phi_rows(rows, half=True)
        out = np.empty((6,) + tuple(self.shape))
        for c in range(6):
            s = _fft.empty_halfspectrum(self.shape, np.float64)
            s[...] = phi[..., c].reshape(s.shape)
            out[c] = _fft.irfftn_inplace(s, self.shape[-1])
        return out


def discrete_field(kind, params, shape, spacing, *, correction="cell", hf_compensation=False, keep_mean=False):
    """The :class:`DiscreteField` of ``generate_line``/``generate_plane``/``generate_box`` with these arguments."""
    settings = {"correction": correction, "hf_compensation": bool(hf_compensation), "keep_mean": bool(keep_mean)}
    shape = tuple(int(n) for n in shape)
    spacing = tuple(float(d) for d in spacing)
    if kind == "line":
        from .fields import _line_spectra

        (n,), (dx,) = shape, spacing
        _k, F = _line_spectra(params, n, dx)
        tab = (_k, _to6(F) * (2.0 * math.pi / (n * dx)))
        return DiscreteField("line", shape, spacing, (1, 1), params, settings, tab)
    if kind == "plane":
        from .fields import plane_spectra

        phi = plane_spectra(params, shape, spacing)
        dk1, dk2 = (2.0 * math.pi / (n * d) for n, d in zip(shape, spacing))
        T = _to6(phi) * (dk1 * dk2)
        T[0, 0] = 0.0  # generate_plane zeroes the mean
        T.setflags(write=False)
        return DiscreteField("plane", shape, spacing, (1, shape[1]), params, settings, T)
    from .box import _dk, _setup
    from .tensor import _prefactor

    st = _setup(params, shape, spacing, correction, bool(hf_compensation))
    dk = _dk(shape, spacing)
    pre2 = _prefactor(params) ** 2 * dk[0] * dk[1] * dk[2]
    return DiscreteField("box", shape, spacing, (shape[1], shape[2]), params, settings, (st, pre2))


def plane_phi_rows(params, shape, spacing, rows) -> np.ndarray:
    """``discrete_field("plane", ...).phi_rows(rows)``, computing only those rows (and their mirrors) [m^2 s^-2].

    The plane's whole table holds ``N1 (N2 // 2 + 1)`` matrices (63 MB for a
    600-s A2012 period); a lattice sum over a few hundred rows needs only
    theirs.  The same kernel and tables as :func:`generate_plane` (bit for
    bit the full table's values): returns (len(rows), 1, N2, 6) in the
    component order (11, 22, 33, 13, 12, 23), the columns in numpy's
    fftfreq order.
    """
    from ._kernels import plane_phi_kernel
    from .fields import _plane_table
    from .tensor import _prefactor

    N1, N2 = (int(n) for n in shape)
    n2h = N2 // 2 + 1
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    t = _plane_table(params, (N1, N2), tuple(float(d) for d in spacing))
    m1 = (N1 - rows) % N1
    need = np.unique(np.concatenate([rows % N1, m1]))
    T = np.empty((need.size, n2h, 6))
    o = np.empty((1, n2h, 3, 3))
    for i, r in enumerate(need):
        plane_phi_kernel(int(r), N1, t.dk1, t.near, t.r1, t.r2, t.j0, t.h, t.coef, t.rj0, t.rh, t.rcoef,
                         _prefactor(params) ** 2, o)
        T[i] = _to6(o[0]) * (t.dk1 * t.dk2)
    if need[0] == 0:
        T[0, 0] = 0.0  # generate_plane zeroes the mean
    at = np.searchsorted(need, rows % N1)
    at_m = np.searchsorted(need, m1)
    # as DiscreteField._plane_rows: k2 = 0 and Nyquist columns take the smaller index of (n1, -n1), the
    # columns beyond the half spectrum the mirror row's
    drawn = np.where(rows % N1 <= m1, at, at_m)
    out = np.empty((rows.size, 1, N2, 6))
    for col in range(N2):
        if col < n2h:
            special = col == 0 or (N2 % 2 == 0 and col == N2 // 2)
            out[:, 0, col] = T[drawn if special else at, col]
        else:
            out[:, 0, col] = T[at_m, N2 - col]
    return out
