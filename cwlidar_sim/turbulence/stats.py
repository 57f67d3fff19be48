"""Statistics of a generated field against the tensor it was built from."""

from __future__ import annotations

import math

import numpy as np

from .._atomic import atomic_path
from .box import expected_box_covariance
from .parameters import MannParameters
from .spectra import covariances, one_point_spectra


def _params_of(field) -> MannParameters:
    try:
        return MannParameters(field.attrs["alpha_eps"], field.attrs["length_scale"], field.attrs["gamma"])
    except KeyError as e:
        raise ValueError(f"field has no Mann parameter attribute {e.args[0]!r}; allowed: a generated field") from None


def _spacing_of(field):
    return tuple(float(field.attrs[k]) for k in ("dx", "dy", "dz"))


def box_spectra(box):
    """x-periodogram of a box averaged over y and z.

    Returns
    -------
    k1_k : ndarray
        Wavenumbers 0 .. pi/dx [rad/m].
    F_k4 : ndarray
        *One-sided* spectra (F11, F22, F33, Re F13) [m^3 s^-2], like
        :func:`~cwlidar_sim.turbulence.one_point_spectra`'s: the sum of
        F dk1 over the rows, the k1 = 0 and Nyquist rows counted half, is
        the variance.
    """
    nx = box.sizes["x"]
    dx = float(box.attrs["dx"])
    dk = 2 * math.pi / (nx * dx)
    X = {}
    for c in "uvw":
        X[c] = np.fft.rfft(np.asarray(box[c].values, dtype=np.float64), axis=0)
    norm = 2.0 / (nx**2 * dk)
    F = np.stack([
        (np.abs(X["u"]) ** 2).mean(axis=(1, 2)),
        (np.abs(X["v"]) ** 2).mean(axis=(1, 2)),
        (np.abs(X["w"]) ** 2).mean(axis=(1, 2)),
        (X["u"] * X["w"].conj()).real.mean(axis=(1, 2)),
    ], axis=1) * norm
    return dk * np.arange(F.shape[0]), F


def box_report(box) -> dict:
    """Sample covariances of a box beside the three theoretical references.

    Returns
    -------
    dict
        ``sample``: variances and u-w covariance of the box [m^2 s^-2];
        ``expected``: what the generator builds in the ensemble mean;
        ``grid_resolved``: the tensor integrated over |k_i| <= pi/d_i;
        ``full``: over all wave vectors; ``ratio_to_grid_resolved`` and
        ``ratio_to_full``: sample / reference.
    """
    params = _params_of(box)
    spacing = _spacing_of(box)
    shape = tuple(box.sizes[d] for d in ("x", "y", "z"))
    u, v, w = (np.asarray(box[c].values, dtype=np.float64) for c in "uvw")
    sample = dict(uu=u.var(), vv=v.var(), ww=w.var(), uw=float(((u - u.mean()) * (w - w.mean())).mean()))
    exp = expected_box_covariance(params, shape, spacing, correction=box.attrs.get("correction", "cell"),
                                  hf_compensation=bool(box.attrs.get("hf_compensation", 0)))
    refs = {
        "expected": exp.covariances,
        "grid_resolved": covariances(params, spacing),
        "full": covariances(params),
    }
    out = {"shape": list(shape), "spacing_m": list(spacing), "params": params.as_dict(),
           "sample": {k: float(x) for k, x in sample.items()}}
    for name, c in refs.items():
        out[name] = {k: float(getattr(c, k)) for k in ("uu", "vv", "ww", "uw")}
    for name in ("grid_resolved", "full"):
        out[f"ratio_to_{name}"] = {k: out["sample"][k] / out[name][k] for k in ("uu", "vv", "ww", "uw")}
    return out


def plot_box_spectra(box, path) -> None:
    """Premultiplied one-point spectra of a box against the analytic ones (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    params = _params_of(box)
    dx, dy, dz = _spacing_of(box)
    k, F = box_spectra(box)
    k, F = k[1:], F[1:]
    # Log-spaced bands for a readable estimate.
    edges = np.geomspace(k[0], k[-1] * 1.0001, 40)
    idx = np.digitize(k, edges)
    kb = np.array([k[idx == i].mean() for i in np.unique(idx)])
    Fb = np.array([F[idx == i].mean(axis=0) for i in np.unique(idx)])
    kt = np.geomspace(k[0], k[-1], 60)
    full = np.array(one_point_spectra(kt, params)).T
    grid = np.array(one_point_spectra(kt, params, k2_max=math.pi / dy, k3_max=math.pi / dz)).T
    fig, ax = plt.subplots(figsize=(7, 4.5))
    labels = ["$F_{11}$ (u)", "$F_{22}$ (v)", "$F_{33}$ (w)", "$-F_{13}$ (uw)"]
    sign = [1, 1, 1, -1]
    for i, (lab, col) in enumerate(zip(labels, ["C0", "C1", "C2", "C3"])):
        ax.loglog(kb, sign[i] * kb * Fb[:, i], "o", ms=3, color=col, label=f"box {lab}")
        ax.loglog(kt, sign[i] * kt * full[:, i], "-", color=col, lw=1)
        ax.loglog(kt, sign[i] * kt * grid[:, i], "--", color=col, lw=1)
    ax.set_xlabel("$k_1$ [rad/m]")
    ax.set_ylabel("$k_1 F(k_1)$ [m$^2$ s$^{-2}$] (one-sided)")
    shape = tuple(box.sizes[d] for d in ("x", "y", "z"))
    ax.set_title(f"Mann box {shape[0]}x{shape[1]}x{shape[2]}, d=({dx:g},{dy:g},{dz:g}) m, "
                 f"L={params.length_scale:g} m, $\\Gamma$={params.gamma:g}", fontsize=9)
    ax.plot([], [], "k-", lw=1, label="tensor, full")
    ax.plot([], [], "k--", lw=1, label="tensor, grid-resolved")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:  # a figure on disk is whole or absent
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
