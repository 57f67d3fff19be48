"""Mann fields conditioned on measured records: the virtual twin's turbulence.

Hoffman & Ribak (1991): for a Gaussian field f observed as ``d = P f + e``
(P linear, e Gaussian noise of covariance N), the field

    f_c = f + C P^T (P C P^T + N)^-1 (d - P f - e~)

with f an unconditioned realisation and e~ a fresh draw of the noise has
exactly the conditional distribution of f given d.  Its mean is the Wiener
estimate ``C P^T (P C P^T + N)^-1 d``, its covariance ``C - C P^T (P C P^T +
N)^-1 P C``.  The noise draw e~ is what keeps the record from being forced
through its own noise: at the sensor the twin differs from the record as the
truth does, by the noise.  C here is the covariance of the *discrete* field
the generators make (``turbulence._discrete``: the tensor, the cell correction, the
gains and Hermitian rules, mode by mode), so the conditioning is exact for
the fields ``generate_line``, ``generate_plane`` and ``generate_box`` draw.

Records along a line (:class:`LineRecord`)
------------------------------------------
A sensor at rest at (x_s, y_s, z_s) sampling at rate fs for n samples sees,
under Taylor's hypothesis with the convection speed U, the field at
``x = x_s - U t`` (the package's convention, ``beam/sampling.py``: the field
moves along +x), so its record covers a whole line along x when the field's
length is ``Nx dx = U n / fs``.  Then every covariance is diagonal in k1: the
record's x-Fourier coefficient at k1 is ``A(k1) = conj(a(j)) exp(-i k1 x_s)``
with ``a(j)`` the record's DFT (divided by n), and the grid mode (k1, q)
correlates only with the records' coefficients at the same k1.  The
conditioning is a solve of size m (the record components) per k1 and the
correction ``Delta S(k1, q) = Phi_d(k1, q) sum_s conj(w_s(q) H_s(k1)) g_s(k1)``
(w_s the lateral phase factors of sensor s, H_s its response, g the solved
residual), which costs one pass over the modes and three inverse FFTs: O(N)
beyond the FFTs, like generating the field.  Between grid rows in y and z a
sensor reads the linear (bilinear) interpolate of the rows, as
``beam.sample_los`` does; the weights enter w_s, so the conditioning is exact
for that reading.  Records with fewer samples than the grid constrain the k1
they hold (assumed alias-free: block averages or filtered to their Nyquist);
every record's mean is removed and the line average at the sensor is
conditioned to it (the mean wind is the record's own mean).

A cup (``values={"speed": ...}``) measures ``sqrt((U_c + u)^2 + v^2) = U_c + u +
v^2 / (2 U_c) + O(3)``; it is conditioned on u to first order, and the
second-order term, of variance ``sigma_v^4 / (2 U_c^2)`` for Gaussian v (its
mean is absorbed in the cup's mean), is added to the cup's noise as if white.
A distance constant l0 [m] filters u by ``1 / (1 + i 2 pi f tau)``, tau = l0 /
U_c, which under Taylor is ``H(k1) = 1 / (1 - i k1 l0 U / U_c)`` on the mode
``exp(i k1 x)``.

Scattered points (:class:`PointValues`)
---------------------------------------
Velocities at isolated points (x, y, z) at one instant: the dense
Hoffman-Ribak update with the discrete covariance function ``C(lag)`` from
six inverse FFTs of Phi_d (8 bytes per grid point per component), a
Cholesky-like solve of size m = points x components (O(m^3)), and the
correction ``Delta S(k) = Phi_d(k) sum_p conj(w_p(k)) alpha_p`` (trilinear
weights, about 10 m complex operations per mode) plus three inverse FFTs.

Reproducibility: a conditioned field of seed s is the unconditioned field
of seed s plus a correction whose only randomness, the noise draw, comes from
``SeedSequence([s, 0x7477696E])``; the same seed gives the same bits for any
thread count (every k1 row is computed alone), and seeds s = 0, 1, ... give
independent twins of the same records.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping

import numpy as np

from .._validation import check_real, check_seed, check_tuple
from ._conditioning_lines import _LENGTH_RTOL
from ._discrete import discrete_field

__all__ = ["LineRecord", "PointValues", "ConditionalVariance", "convection_speed", "twin_spacing",
           "condition_field", "conditional_mean", "conditioned_line", "conditioned_plane", "conditioned_box", "conditional_variance"]

COMPONENTS = ("u", "v", "w")
#: Second entropy word of the noise draw's SeedSequence ("twin").
NOISE_TAG = 0x7477696E


def _check_values(owner, values, length=None):
    if not isinstance(values, Mapping) or not values:
        raise TypeError(f"{owner}.values must be a non-empty mapping of component -> array, got {values!r}")
    keys = set(values)
    if not (keys <= set(COMPONENTS) or keys == {"speed"}):
        raise ValueError(f"{owner}.values has keys {sorted(keys)}; allowed: a subset of ['u', 'v', 'w'] (sonic) "
                         f"or ['speed'] (cup)")
    order = [c for c in COMPONENTS + ("speed",) if c in keys]
    out = {}
    for c in order:
        a = np.array(values[c], dtype=np.float64)
        if a.ndim != 1 or (length is not None and a.size != length):
            raise ValueError(f"{owner}.values[{c!r}] has shape {a.shape}; allowed: 1-D"
                             + (f" of length {length}" if length is not None else ""))
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{owner}.values[{c!r}] has {int(np.sum(~np.isfinite(a)))} non-finite samples; "
                             f"fill or reject gaps before conditioning (analysis.records does)")
        a.setflags(write=False)
        out[c] = a
    return tuple(order), out


def _check_noise(owner, noise, comps):
    if isinstance(noise, Mapping):
        if set(noise) != set(comps):
            raise ValueError(f"{owner}.noise_std has keys {sorted(noise)}; allowed: exactly {list(comps)}")
        return {c: check_real(f"{owner}.noise_std[{c!r}]", noise[c], lo=0.0, hi=1e3) for c in comps}
    v = check_real(f"{owner}.noise_std", noise, lo=0.0, hi=1e3)
    return {c: v for c in comps}


@dataclasses.dataclass(frozen=True, eq=False)
class LineRecord:
    """One sensor's velocity record, read as a line along x under Taylor's hypothesis.

    Parameters
    ----------
    position : (float, float, float)
        (x, y, z) [m] of the sensor in the field's frame (x along the mean
        wind, y to the left, z up); sample i sees the field at
        ``x - U i / sample_rate`` (periodic).
    sample_rate : float
        fs [Hz], > 0.
    values : mapping
        ``{"u": ..., "v": ..., "w": ...}`` (any non-empty subset; a sonic,
        rotated into the mean wind) or ``{"speed": ...}`` (a cup's horizontal
        speed): equal-length 1-D arrays [m/s], finite.  Each series' mean is
        removed before conditioning.
    noise_std : float or mapping
        Standard deviation of white measurement noise per sample [m/s], >= 0,
        one for all components or one per component.
    distance_constant : float
        Cup only: l0 [m], >= 0 (0: an ideal cup).
    name : str
        Label used in messages and attributes.
    """

    position: tuple
    sample_rate: float
    values: Mapping
    noise_std: object = 0.0
    distance_constant: float = 0.0
    name: str = ""

    def __post_init__(self):
        label = f"LineRecord {self.name!r}" if self.name else "LineRecord"
        object.__setattr__(self, "position", check_tuple(f"{label}.position", self.position, 3, check_real))
        object.__setattr__(self, "sample_rate",
                           check_real(f"{label}.sample_rate", self.sample_rate, lo=0.0, hi=1e6, lo_open=True))
        comps, vals = _check_values(label, self.values)
        n = len(next(iter(vals.values())))
        comps, vals = _check_values(label, vals, n)
        if n < 8:
            raise ValueError(f"{label} has {n} samples; allowed: >= 8")
        object.__setattr__(self, "values", vals)
        object.__setattr__(self, "noise_std", _check_noise(label, self.noise_std, comps))
        l0 = check_real(f"{label}.distance_constant", self.distance_constant, lo=0.0, hi=100.0)
        if l0 > 0 and comps != ("speed",):
            raise ValueError(f"{label}.distance_constant = {l0} m applies to a cup (values={{'speed': ...}}); "
                             f"this record has {list(comps)}")
        object.__setattr__(self, "distance_constant", l0)
        if not isinstance(self.name, str):
            raise TypeError(f"LineRecord.name must be a str, got {type(self.name).__name__}")

    @property
    def components(self) -> tuple:
        return tuple(self.values)

    @property
    def kind(self) -> str:
        """"cup" for a horizontal-speed record, else "sonic"."""
        return "cup" if self.components == ("speed",) else "sonic"

    @property
    def n_samples(self) -> int:
        return len(next(iter(self.values.values())))

    @property
    def duration(self) -> float:
        """n / fs [s]: the record covers x over U times this."""
        return self.n_samples / self.sample_rate

    @property
    def mean_speed(self) -> float:
        """Mean of u (sonic) or of the speed (cup) [m/s]; NaN for a sonic without u."""
        key = "speed" if self.kind == "cup" else "u"
        return float(np.mean(self.values[key])) if key in self.values else math.nan


@dataclasses.dataclass(frozen=True, eq=False)
class PointValues:
    """Velocities measured at scattered points of the field (one instant).

    Parameters
    ----------
    positions : array_like, shape (P, 3)
        (x, y, z) [m] of the points in the field's frame; x is periodic, y and
        z must lie within the grid (a plane's or line's fixed coordinates
        must match).
    values : mapping
        ``{"u": (P,), ...}``, any non-empty subset of u, v, w [m/s] (the
        fluctuations: nothing is removed).
    noise_std : float or mapping
        Measurement noise std [m/s], >= 0.
    """

    positions: object
    values: Mapping
    noise_std: object = 0.0

    def __post_init__(self):
        pos = np.array(self.positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < 1 or not np.all(np.isfinite(pos)):
            raise ValueError(f"PointValues.positions must be a finite (P, 3) array, got shape {pos.shape}")
        pos.setflags(write=False)
        comps, vals = _check_values("PointValues", self.values, pos.shape[0])
        if comps == ("speed",):
            raise ValueError("PointValues.values takes u, v, w; a cup is a LineRecord")
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "values", vals)
        object.__setattr__(self, "noise_std", _check_noise("PointValues", self.noise_std, comps))

    @property
    def components(self) -> tuple:
        return tuple(self.values)


def _check_records(records):
    if isinstance(records, (LineRecord, PointValues)):
        records = [records]
    if isinstance(records, (str, bytes)) or not hasattr(records, "__iter__"):
        raise TypeError(f"records must be a LineRecord, a PointValues or a list of LineRecords, got {records!r}")
    records = list(records)
    if not records:
        raise ValueError("records is empty; allowed: one or more LineRecord, or one PointValues")
    for i, r in enumerate(records):
        if not isinstance(r, (LineRecord, PointValues)):
            raise TypeError(f"records[{i}] must be a LineRecord or PointValues, got {type(r).__name__}")
    if any(isinstance(r, PointValues) for r in records) and len(records) > 1:
        raise ValueError("records mixes PointValues with other records; allowed: LineRecords only, or one "
                         "PointValues (the per-k1 and the dense methods do not combine)")
    return records


def convection_speed(records) -> float:
    """Mean of the records' mean speeds (u of sonics, speed of cups) [m/s]."""
    records = [r for r in _check_records(records) if isinstance(r, LineRecord)]
    speeds = [r.mean_speed for r in records if math.isfinite(r.mean_speed)]
    if not speeds:
        raise ValueError("no record carries u or speed to give the convection speed; pass U explicitly")
    U = float(np.mean(speeds))
    if not U > 0.5:
        raise ValueError(f"the records' mean speed is {U:.3g} m/s, not a mean wind for Taylor's hypothesis "
                         f"(fluctuations only?); pass U [m/s] explicitly")
    return U


def _check_U(U, records):
    if U is None:
        U = convection_speed(records)
    return check_real("U", U, lo=0.0, hi=1e3, lo_open=True)


def twin_spacing(records, nx: int, *, U: float | None = None) -> float:
    """dx [m] at which ``nx`` points along x hold exactly the records' line, ``U T / nx``.

    Raises ValueError if the records do not share one duration T = n / fs.
    """
    from .._validation import check_int

    records = [r for r in _check_records(records) if isinstance(r, LineRecord)]
    nx = check_int("nx", nx, lo=2)
    T = _common_duration(records)
    return _check_U(U, records) * T / nx


def _common_duration(records):
    T = records[0].duration
    for r in records[1:]:
        if abs(r.duration - T) > _LENGTH_RTOL * T:
            raise ValueError(f"records {records[0].name!r} ({T:.9g} s) and {r.name!r} ({r.duration:.9g} s) differ "
                             f"in duration; allowed: one duration n / fs for all line records")
    return T


# ---------------------------------------------------------------------------
# public functions
# ---------------------------------------------------------------------------
def _params_from_attrs(field, params):
    from .parameters import MannParameters
    from .tensor import _check_params

    if params is not None:
        _check_params(params)
        return params
    try:
        return MannParameters(*(float(field.attrs[k]) for k in ("alpha_eps", "length_scale", "gamma")))
    except KeyError:
        raise ValueError("field.attrs lack alpha_eps, length_scale, gamma (not a generate_* result); "
                         "pass params") from None


def _settings(field, kind):
    from .._validation import check_choice

    if "sigma_u_target" in field.attrs:
        raise ValueError("field was rescaled to a target sigma_u (generate_box(sigma_u=...)): a data-dependent "
                         "scale is not the Gaussian field the conditioning assumes; generate it without sigma_u")
    if int(field.attrs.get("conditioned", 0)):
        raise ValueError("field is already conditioned; condition an unconditioned field on all records at once")
    if kind != "box":
        return {}
    return {"correction": check_choice("field.attrs['correction']", field.attrs.get("correction", "cell"),
                                       ("cell", "none")),
            "hf_compensation": bool(int(field.attrs.get("hf_compensation", 0))),
            "keep_mean": bool(int(field.attrs.get("keep_mean", 0)))}


def _setup(field, records, params):
    from ._conditioning_lines import _field_grid

    records = _check_records(records)
    grid = _field_grid(field)
    params = _params_from_attrs(field, params)
    nd = len(grid.shape)
    df = discrete_field(grid.kind, params, grid.shape, grid.spacing[:nd], **_settings(field, grid.kind))
    return records, grid, df


def _describe(records):
    out = []
    for i, r in enumerate(records):
        if isinstance(r, LineRecord):
            out.append({"name": r.name or f"records[{i}]", "kind": r.kind, "position": list(r.position),
                        "components": list(r.components), "noise_std": dict(r.noise_std),
                        "sample_rate": r.sample_rate, "n_samples": r.n_samples})
        else:
            out.append({"name": "points", "kind": "points", "n_points": int(r.positions.shape[0]),
                        "components": list(r.components), "noise_std": dict(r.noise_std)})
    return json.dumps(out)


def condition_field(field, records, *, seed, U: float | None = None, params=None, inplace: bool = False):
    """Condition an unconditioned field on records (Hoffman & Ribak 1991); see the module notes.

    Parameters
    ----------
    field : xarray.Dataset
        A line, plane or box as ``generate_line``/``generate_plane``/
        ``generate_box`` return it (their attributes give the tensor and, for
        a box, ``correction``, ``hf_compensation`` and ``keep_mean``, which
        must be those it was generated with).  Coordinates may be shifted;
        record positions are in the field's coordinates.
    records : LineRecord, list of LineRecord, or PointValues
        Line records (all of one duration T, with ``Nx dx = U T``) or one set
        of point values.
    seed : int or None
        Seed of the measurement-noise draw (stream ``SeedSequence([seed,
        NOISE_TAG])``).  ``None`` draws no noise: applied to a zero field
        this gives the conditional mean (:func:`conditional_mean`); applied
        to a random field it under-disperses wherever the noise matters.
    U : float, optional
        Convection speed [m/s] mapping the records' time to x (line records);
        default :func:`convection_speed` of the records.
    params : MannParameters, optional
        Default: from the field's attributes.
    inplace : bool
        Add the correction into ``field``'s arrays (default: into a copy).

    Returns
    -------
    xarray.Dataset
        The conditioned field, same layout; attributes gain ``conditioned``
        (1), ``conditioned_on`` (JSON description of the records),
        ``conditioning_method`` ("per-k1" or "dense"), ``convection_speed``
        [m/s] and ``noise_seed`` (-1 for none).
    """
    from ._conditioning_lines import _condition_lines
    from ._conditioning_points import condition_points

    records, grid, df = _setup(field, records, params)
    rng = None
    if seed is not None:
        rng = np.random.Generator(np.random.SFC64(np.random.SeedSequence([check_seed("seed", seed), NOISE_TAG])))
    dims = ("x", "y", "z")[: len(grid.shape)]
    arrays = [np.asarray(field[c].transpose(*dims).values) for c in COMPONENTS]
    # The correction is synthesised in the field's precision (float32 boxes: half the FFT work).
    dt = np.float32 if all(a.dtype == np.float32 for a in arrays) else np.float64
    specs, views = df.empty_spectra(dt)
    if isinstance(records[0], PointValues):
        condition_points(arrays, grid, df, records[0], rng, views)
        U_out, method = math.nan, "dense"
    else:
        U_out = _check_U(U, records)
        _condition_lines(arrays, grid, df, records, U_out, rng, views)
        method = "per-k1"
    delta = df.synthesize(specs)
    out = field if inplace else field.copy(deep=True)
    for c, d in zip(COMPONENTS, delta):
        da = out[c].transpose(*dims)
        a = da.values
        if da.dims != out[c].dims or not np.shares_memory(a, out[c].values):
            out[c] = (dims, a + d.astype(a.dtype), out[c].attrs)
        else:
            a += d.astype(a.dtype)
    out.attrs.update(conditioned=1, conditioned_on=_describe(records), conditioning_method=method,
                     convection_speed=U_out, noise_seed=-1 if seed is None else int(seed))
    return out


def conditional_mean(field, records, *, U: float | None = None, params=None):
    """The conditional mean field (the Wiener estimate) on ``field``'s grid: no noise, no eddies of its own."""
    import xarray as xr

    zero = xr.zeros_like(field, dtype=np.float64)
    zero.attrs = dict(field.attrs)
    return condition_field(zero, records, seed=None, U=U, params=params, inplace=True)


def conditioned_line(params, shape, spacing, seed: int, records, *, U: float | None = None, y: float = 0.0,
                     z: float = 0.0, dtype=np.float32):
    """``generate_line(params, shape, spacing, seed)`` at (y, z), conditioned on ``records`` (see :func:`condition_field`).

    The line's attributes gain ``y`` and ``z`` [m] (where ``beam.sample_los``
    places it); the records must lie on it.
    """
    from .fields import generate_line

    field = generate_line(params, shape, spacing, seed, dtype=dtype)
    field.attrs.update(y=check_real("y", y), z=check_real("z", z))
    out = condition_field(field, records, seed=seed, U=U, params=params, inplace=True)
    out.attrs["generator"] = "cwlidar_sim.turbulence.conditioned_line"
    return out


def conditioned_plane(params, shape, spacing, seed: int, records, *, U: float | None = None, z: float = 0.0,
                      dtype=np.float32):
    """``generate_plane(params, shape, spacing, seed, z=z)`` conditioned on ``records`` (see :func:`condition_field`)."""
    from .fields import generate_plane

    field = generate_plane(params, shape, spacing, seed, z=z, dtype=dtype)
    out = condition_field(field, records, seed=seed, U=U, params=params, inplace=True)
    out.attrs["generator"] = "cwlidar_sim.turbulence.conditioned_plane"
    return out


def conditioned_box(params, shape, spacing, seed: int, records, *, U: float | None = None,
                    correction: str = "cell", hf_compensation: bool = False, keep_mean: bool = False,
                    dtype=np.float32):
    """``generate_box(params, shape, spacing, seed, ...)`` conditioned on ``records`` (see :func:`condition_field`).

    The unconditioned part is the box of ``seed`` bit for bit; the twin adds
    the correction of the records, whose noise draw also comes from ``seed``.
    Cost beyond the box (per-k1 method): one pass over the modes (the
    discrete tensor again, plus about 12 P_z(P_z+1)/2 + 30 P_z flops per mode
    for P_z sensor heights) and three inverse FFTs; peak memory about twice
    the box (the correction's half spectra beside the box).
    """
    from .box import generate_box

    field = generate_box(params, shape, spacing, seed, correction=correction, hf_compensation=hf_compensation,
                         keep_mean=keep_mean, dtype=dtype)
    out = condition_field(field, records, seed=seed, U=U, params=params, inplace=True)
    out.attrs["generator"] = "cwlidar_sim.turbulence.conditioned_box"
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class ConditionalVariance:
    """Variances of u, v, w at target points before and after conditioning.

    Attributes
    ----------
    targets : ndarray, shape (T, 3)
        Target positions (x, y, z) [m] (x is irrelevant for line records).
    prior, posterior : ndarray, shape (T, 3)
        sigma^2 and sigma^2 (1 - gamma^2) of u, v, w [m^2 s^-2] of the
        discrete field (the ensemble variance of the twins about the
        conditional mean).
    k1_k : ndarray or None
        Line records: the rows' k1 >= 0 [rad/m].
    prior_ktc, posterior_ktc : ndarray or None
        Line records: variance of each mode exp(i k1 x) of the target's line,
        shape (len(k1_k), T, 3) [m^2 s^-2]; rows 0 < k1 < pi/dx stand for
        both signs (the two-sided spectrum is ``prior_ktc / dk1`` there).
    """

    targets: np.ndarray
    prior: np.ndarray
    posterior: np.ndarray
    k1_k: np.ndarray | None = None
    prior_ktc: np.ndarray | None = None
    posterior_ktc: np.ndarray | None = None

    @property
    def coherence_ktc(self):
        """gamma^2(k1) = 1 - posterior / prior per mode (line records), the records' coherence with the target."""
        if self.prior_ktc is None:
            return None
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.prior_ktc > 0, 1.0 - self.posterior_ktc / self.prior_ktc, 0.0)


def conditional_variance(field, records, targets, *, U: float | None = None, params=None) -> ConditionalVariance:
    """Prior and conditional variances of u, v, w at ``targets`` (theory for the twins' spread).

    Parameters
    ----------
    field : xarray.Dataset
        Any field of the configuration (e.g. a twin): grid and settings.
    records, U, params
        As for :func:`condition_field`.
    targets : array_like, shape (T, 3)
        Positions (x, y, z) [m] in the field's frame.

    Returns
    -------
    ConditionalVariance
    """
    from ._conditioning_lines import line_variance
    from ._conditioning_points import point_variance

    records, grid, df = _setup(field, records, params)
    t = np.array(targets, dtype=np.float64)
    if t.ndim != 2 or t.shape[1] != 3 or not np.all(np.isfinite(t)):
        raise ValueError(f"targets must be a finite (T, 3) array of positions [m], got shape {t.shape}")
    if isinstance(records[0], PointValues):
        prior, post = point_variance(grid, df, records[0], t)
        return ConditionalVariance(t, prior, post)
    k1, pk, qk = line_variance(grid, df, records, _check_U(U, records), [tuple(p[1:]) for p in t])
    mult = np.full(k1.size, 2.0)
    mult[0] = 1.0
    if grid.shape[0] % 2 == 0:
        mult[-1] = 1.0
    return ConditionalVariance(t, np.einsum("k,ktc->tc", mult, pk), np.einsum("k,ktc->tc", mult, qk), k1, pk, qk)
