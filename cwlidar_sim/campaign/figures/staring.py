"""Figures of a campaign's results, after A2012 Figs. 3-8.

Every function takes the results Dataset of :func:`cwlidar_sim.campaign.run_scene`
(or :func:`cwlidar_sim.campaign.read_results`) and returns a matplotlib
Figure; :func:`make_figures` writes them all as PNG.  The misaligned-beam
theory (A2012 Eqs. 12-14) is drawn for a misaligned period only, and
``misalignment_5deg.png`` is written only for a scene with one.
"""

from __future__ import annotations

import json
import math
import os
import textwrap

import numpy as np

from ..._atomic import atomic_path

from .._labels import segment_phrase
from ..registry import get_kind

__all__ = [
    "plot_spectra",
    "plot_transfer",
    "plot_methods",
    "plot_misalignment",
    "plot_variants",
    "plot_estimator_theory",
    "make_staring_figures",
    "make_figures",
]


def _plt():
    # No backend is forced: matplotlib falls back to Agg without a display,
    # and a notebook keeps its inline backend.
    import matplotlib.pyplot as plt

    return plt


def _grid(n):
    cols = min(n, 2)
    rows = int(math.ceil(n / cols))
    return rows, cols


def _margins(fig, *, left=0.8, right=0.15, bottom=0.55, top=0.4, wspace=None, hspace=None):
    """Fixed margins in inches (whatever the figure size) instead of ``tight_layout``.

    ``tight_layout`` measures every tick label of every log axis before the
    figure is drawn again to be saved: half the drawing time of an A2012
    run's figures (2.6 of 5.7 s).  These figures have one layout each, so
    their margins are set once here.
    """
    w, h = fig.get_size_inches()
    fig.subplots_adjust(left=left / w, right=1.0 - right / w, bottom=bottom / h, top=1.0 - top / h,
                        wspace=wspace, hspace=hspace)


def _suptitle(fig, text, fontsize=12.0):
    """A figure title wrapped to the figure's width (a long one is not cut at both edges); returns its lines."""
    w = fig.get_size_inches()[0]
    per_line = max(20, int(w * 72.0 / (0.62 * fontsize)))  # ~0.55 em a character, with some room
    lines = textwrap.wrap(text, per_line)
    fig.suptitle("\n".join(lines), fontsize=fontsize)
    return len(lines)


def _misaligned(ds, i) -> bool:
    """Whether period ``i``'s beam is turned from the wind (the misaligned theory differs from the aligned)."""
    return float(ds.misalignment[i]) != 0.0


def _label(ds, i):
    return (f"period {ds.period.values[i]}: U = {float(ds.mean_speed[i]):.1f} m/s, "
            f"misalignment {float(ds.misalignment[i]):+.1f}°")


def _best_period(ds):
    """Index of the period with the smallest misalignment (A2012's period C)."""
    return int(np.argmin(np.abs(ds.misalignment.values)))


def plot_spectra(ds):
    """Premultiplied spectra k F(k) of lidar and sonic per period (A2012 Fig. 3)."""
    plt = _plt()
    P = ds.sizes["period"]
    rows, cols = _grid(P)
    fig, axes = plt.subplots(rows, cols, figsize=(5.5 * cols, 4 * rows), squeeze=False, sharey=True)
    k = ds.k.values
    for i in range(P):
        ax = axes.flat[i]
        ax.loglog(k, k * ds.spectrum_sonic[i], "k--", label="sonic $k F_{v_s}$")
        ax.loglog(k, k * ds.spectrum_lidar[i], "r-", label=f"lidar $k F_{{v_r}}$ ({ds.attrs['lidar_tier']})")
        ax.set_title(_label(ds, i), fontsize=9)
        ax.set_xlabel("$k_1$ [rad/m]")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel("$k F(k)$ [m$^2$/s$^2$]")
    for ax in axes.flat[P:]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=8)
    n = _suptitle(fig, f"Spectra of the radial speed, {segment_phrase(ds)} averaged over each period")
    _margins(fig, top=0.5 + 0.22 * n, wspace=0.08, hspace=0.35)
    return fig


def _theory(ax, ds, i=None):
    k = ds.k.values
    zR = ds.attrs["rayleigh_length"]
    ax.loglog(k, ds.transfer_theory, "k-", lw=1.5, label=f"exp(-2 k zR), zR = {zR:.2f} m")
    if i is not None and _misaligned(ds, i):
        ax.loglog(k, ds.transfer_theory_cross[i], "k:", lw=1, label="Eqs. 12, 14 (misaligned)")


def _estimator_theory(ax, ds, name, **kw):
    """Draw ``transfer_theory_estimator`` of estimator ``name`` (when the results carry it)."""
    if "transfer_theory_estimator" not in ds or name not in list(ds.estimator.values):
        return
    j = list(ds.estimator.values).index(name)
    z = float(ds.probe_length_effective[j])
    kw.setdefault("label", f"{name} theory (zR_eff = {z:.2f} m)")
    ax.loglog(ds.k.values, ds.transfer_theory_estimator[j], **kw)


def _setup(ax):
    ax.set_ylim(1e-4, 3)
    ax.set_xlabel("$k_1$ [rad/m]")
    ax.grid(True, which="both", alpha=0.3)


def plot_transfer(ds, which="ratio"):
    """Transfer function per period, method 1 ('ratio', A2012 Fig. 4) or 2 ('cross', Fig. 5)."""
    plt = _plt()
    var = {"ratio": "transfer_ratio", "cross": "transfer_cross"}[which]
    fig, ax = plt.subplots(figsize=(7, 5))
    k = ds.k.values
    for i in range(ds.sizes["period"]):
        ax.loglog(k, ds[var][i], "o-", ms=3, lw=1, label=_label(ds, i))
    _theory(ax, ds)
    _setup(ax)
    title = ("method 1: $F_{v_r}/F_{v_s}$" if which == "ratio"
             else "method 2: Re$(\\chi_{v_r v_s})^2 / F_{v_s}^2$")
    ax.set_title(title)
    ax.set_ylabel("spectral transfer function")
    ax.legend(fontsize=7)
    _margins(fig)
    return fig


def plot_methods(ds, i=None):
    """Both methods, the noise-free tier-1 lidar and the theory for one period (A2012 Fig. 6)."""
    plt = _plt()
    i = _best_period(ds) if i is None else i
    fig, ax = plt.subplots(figsize=(7, 5))
    k = ds.k.values
    ax.errorbar(k, ds.transfer_ratio[i], yerr=ds.transfer_ratio_sigma[i], fmt="o", ms=3, label="method 1 (ratio)")
    ax.errorbar(k, ds.transfer_cross[i], yerr=ds.transfer_cross_sigma[i], fmt="s", ms=3, label="method 2 (cross)")
    ax.loglog(k, ds.transfer_ratio_ideal[i], "-", color="C2", lw=1, label="method 1, noise-free tier 1")
    _theory(ax, ds, i)
    if _misaligned(ds, i):
        ax.loglog(k, ds.transfer_theory_ratio[i], "-.", color="0.4", lw=1, label="Eqs. 12, 13 (misaligned)")
    if "transfer_ratio_theory" in ds:  # the general linear theory of the period's own geometry and cells
        ax.loglog(k, ds.transfer_ratio_theory[i], "-", color="C3", lw=1, label="linear theory, method 1")
        ax.loglog(k, ds.transfer_cross_theory[i], "--", color="C3", lw=1, label="linear theory, method 2")
    _estimator_theory(ax, ds, ds.attrs.get("lidar_estimator", ""), color="C1", lw=1.5, ls="--")
    ax.set_xscale("log")
    ax.set_yscale("log")
    _setup(ax)
    ax.set_title(_label(ds, i))
    ax.set_ylabel("spectral transfer function")
    ax.legend(fontsize=8)
    _margins(fig)
    return fig


def plot_misalignment(ds, theta_deg=5.0, i=None):
    """A2012 Eqs. 12-14 at ``theta_deg`` with the tensor fitted to one period's sonic (A2012 Fig. 7)."""
    from ...analysis import misaligned_spectra, transfer_aligned
    from ...turbulence import MannParameters

    plt = _plt()
    i = _best_period(ds) if i is None else i
    if "fit_alpha_eps" in ds and np.isfinite(float(ds.fit_alpha_eps[i])):
        p = MannParameters(float(ds.fit_alpha_eps[i]), float(ds.fit_length_scale[i]), float(ds.fit_gamma[i]))
        src = f"fitted to period {ds.period.values[i]}"
    elif "mann_alpha_eps" in ds:  # a tensor per period ([turbulence] ti, iec_class, source)
        p = MannParameters(float(ds.mann_alpha_eps[i]), float(ds.mann_length_scale[i]), float(ds.mann_gamma[i]))
        src = f"period {ds.period.values[i]}'s parameters"
    else:
        p = MannParameters(ds.attrs["alpha_eps"], ds.attrs["length_scale"], ds.attrs["gamma"])
        src = "scene parameters"
    zR = ds.attrs["rayleigh_length"]
    k = np.geomspace(1e-3, 3.0, 41)  # 12 per decade: the curves are smooth in log k (each point ~20 ms)
    F_vs, F_vr, chi = misaligned_spectra(k, p, theta_deg, zR)
    fig, ax = plt.subplots(figsize=(7, 5))
    ax.loglog(k, F_vr / F_vs, "C0-", label="$F_{v_r}/F_{v_s}$ (Eqs. 12, 13)")
    ax.loglog(k, chi**2 / F_vs**2, "C1--", label="$\\chi^2/F_{v_s}^2$ (Eqs. 12, 14)")
    ax.loglog(k, transfer_aligned(k, zR), "k-", lw=1, label="exp(-2 k zR)")
    _setup(ax)
    ax.set_title(f"misalignment {theta_deg:g}°, tensor {src}\n"
                 f"αε$^{{2/3}}$ = {p.alpha_eps:.3g}, L = {p.length_scale:.3g} m, Γ = {p.gamma:.3g}", fontsize=9)
    ax.set_ylabel("spectral ratio")
    ax.legend(fontsize=8)
    _margins(fig, top=0.55)
    return fig


def _variant_groups(ds):
    """Variant names grouped: threshold raises and estimators."""
    variants = json.loads(ds.attrs.get("variants", "[]"))
    thr = [v["name"] for v in variants if "threshold_raise_percent" in v]
    est = [v["name"] for v in variants if "estimator" in v]
    return variants, thr, est


def plot_variants(ds, group="threshold", i=None):
    """Both methods for processing variants of one period: raised thresholds (A2012 Fig. 8) or estimators."""
    plt = _plt()
    i = _best_period(ds) if i is None else i
    variants, thr, est = _variant_groups(ds)
    names = thr if group == "threshold" else est
    main = (f"main ({ds.attrs['lidar_estimator']}, threshold +0 %)" if group == "threshold"
            else f"{ds.attrs['lidar_estimator']} (main)")
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    k = ds.k.values
    for ax, var, title in ((axes[0], "ratio", "method 1"), (axes[1], "cross", "method 2")):
        ax.loglog(k, ds[f"transfer_{var}"][i], "o-", ms=3, lw=1, color="k", label=main)
        if var == "cross" and group == "estimator":
            _estimator_theory(ax, ds, ds.attrs["lidar_estimator"], color="k", ls="--", lw=1)
            for j, n in enumerate(names):
                v = next(x for x in variants if x["name"] == n)
                _estimator_theory(ax, ds, v["estimator"], color=f"C{j}", ls="--", lw=1)
        for j, n in enumerate(names):
            vi = list(ds.variant.values).index(n)
            v = next(x for x in variants if x["name"] == n)
            extra = (f"threshold +{v['threshold_raise_percent']:g} %" if group == "threshold"
                     else v["estimator"])
            ax.loglog(k, ds[f"transfer_{var}_variant"][vi, i], "o-", ms=3, lw=1, color=f"C{j}", label=extra)
        ax.loglog(k, ds.transfer_theory, "k:", lw=1, label="exp(-2 k zR)")
        _setup(ax)
        ax.set_title(f"{title}, {_label(ds, i)}", fontsize=9)
    axes[0].set_ylabel("spectral transfer function")
    axes[0].legend(fontsize=8)
    _margins(fig, top=0.35, wspace=0.05)
    return fig


def plot_estimator_theory(ds, i=None):
    """Each estimator's expected method 2 (``transfer_theory_estimator``) with the run's own method 2 of one period."""
    plt = _plt()
    i = _best_period(ds) if i is None else i
    fig, ax = plt.subplots(figsize=(7, 5))
    k = ds.k.values
    for j, name in enumerate(ds.estimator.values):
        T, s = ds.transfer_theory_estimator[j].values, ds.transfer_theory_estimator_sigma[j].values
        ax.fill_between(k, np.maximum(T - s, 1e-12), T + s, color=f"C{j}", alpha=0.25, lw=0)
        _estimator_theory(ax, ds, str(name), color=f"C{j}", lw=1.5)
    ax.loglog(k, ds.transfer_cross[i], "ko", ms=3, label=f"method 2 of the run ({ds.attrs['lidar_estimator']})")
    zR = ds.attrs["rayleigh_length"]
    ax.loglog(k, ds.transfer_theory, "k:", lw=1, label=f"exp(-2 k zR), zR = {zR:.2f} m")
    _setup(ax)
    ax.set_title(f"the estimator is part of the filter ({_label(ds, i)})", fontsize=9)
    ax.set_ylabel("Re$(\\chi)^2/F_{v_s}^2$")
    ax.legend(fontsize=7)
    _margins(fig, top=0.35)
    return fig


def make_figures(ds, out_dir) -> list:
    """Write every figure of a results Dataset as PNG into ``out_dir``; returns the paths.

    The figures are its scene kind's (``ds.attrs["sensor"]``, :func:`cwlidar_sim.campaign.registry.get_kind`):
    :func:`make_staring_figures`, :func:`cwlidar_sim.campaign.figures.conical.make_cs_figures`,
    :func:`cwlidar_sim.campaign.figures.nacelle.make_nacelle_figures`, or a plugin kind's.
    """
    return get_kind(ds.attrs.get("sensor"), where="the results' sensor").figures(ds, out_dir)


def make_staring_figures(ds, out_dir) -> list:
    """Write every figure of a staring scene's results as PNG into ``out_dir``; returns the paths."""
    plt = _plt()
    os.makedirs(out_dir, exist_ok=True)
    figs = {
        "spectra": lambda: plot_spectra(ds),
        "transfer_ratio": lambda: plot_transfer(ds, "ratio"),
        "transfer_cross": lambda: plot_transfer(ds, "cross"),
        "methods": lambda: plot_methods(ds),
    }
    if any(_misaligned(ds, i) for i in range(ds.sizes["period"])):
        figs["misalignment_5deg"] = lambda: plot_misalignment(ds, 5.0)
    _, thr, est = _variant_groups(ds)
    if thr:
        figs["thresholds"] = lambda: plot_variants(ds, "threshold")
    if est:
        figs["estimators"] = lambda: plot_variants(ds, "estimator")
    if "transfer_theory_estimator" in ds:
        figs["estimator_theory"] = lambda: plot_estimator_theory(ds)
    paths = []
    for name, make in figs.items():
        fig = make()
        path = os.path.join(os.fspath(out_dir), f"{name}.png")
        with atomic_path(path) as tmp:  # a figure on disk is whole or absent
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
