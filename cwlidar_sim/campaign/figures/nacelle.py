"""Figures of a nacelle campaign's results: coherence against wavenumber, preview, estimator, evolution, std ratio.

Every function takes the results Dataset of a nacelle scene
(:func:`cwlidar_sim.campaign.periods.nacelle.run_unit`, joined) and returns a Figure.
"""

from __future__ import annotations

import os

import numpy as np

from ..._atomic import atomic_path

__all__ = ["plot_coherence_focus", "plot_estimators", "plot_evolution", "plot_preview", "plot_std_ratio",
           "make_nacelle_figures"]


def _plt():
    import matplotlib.pyplot as plt

    return plt


def _frozen_period(ds):
    """Index of the first frozen period (lifetime NaN), else 0."""
    frozen = np.flatnonzero(~np.isfinite(ds.lifetime.values))
    return int(frozen[0]) if frozen.size else 0


def _estimate(ds, name):
    return list(ds.estimate.values).index(name)


def plot_coherence_focus(ds, period=None):
    """Coherence against k for every focus distance (tier 1, with its 95 % interval) beside the theory."""
    plt = _plt()
    ip = _frozen_period(ds) if period is None else period
    j = _estimate(ds, "tier1")
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    k = ds.k.values
    for i, r in enumerate(ds.focus.values):
        c = f"C{i}"
        ax.plot(k, ds.coherence.values[ip, i, j], "o", color=c, ms=4, label=f"simulated, r = {r:g} m")
        ax.fill_between(k, ds.coherence_lower.values[ip, i, j], ds.coherence_upper.values[ip, i, j], color=c,
                        alpha=0.15, lw=0)
        th = ds.coherence_theory.values[ip, i]
        fin = np.isfinite(th)  # the analytic one as estimated: only the bins that hold ordinates
        if fin.any():
            ax.plot(k[fin], th[fin], "-", color=c, label=f"analytic as estimated, r = {r:g} m")
    ax.axhline(0.5, color="0.5", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("wavenumber k [rad/m]")
    ax.set_ylabel("REWS-lidar coherence [-]")
    ax.set_title(f"period {ds.period.values[ip]}: tier 1 (ideal line-of-sight speeds)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_estimators(ds, period=None):
    """Coherence against k at the middle focus distance, one curve per estimate kind (tier 1, the chain's)."""
    plt = _plt()
    ip = _frozen_period(ds) if period is None else period
    i = ds.sizes["focus"] // 2
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for j, e in enumerate(ds.estimate.values):
        kh = float(ds.k_half.values[ip, i, j])
        ax.plot(ds.k.values, ds.coherence.values[ip, i, j], "o-", ms=3, label=f"{e} (k_0.5 = {kh:.3g} rad/m)")
    ax.axhline(0.5, color="0.5", lw=0.8, ls=":")
    ax.set_xscale("log")
    ax.set_ylim(0, 1.02)
    ax.set_xlabel("wavenumber k [rad/m]")
    ax.set_ylabel("REWS-lidar coherence [-]")
    ax.set_title(f"estimators at r = {float(ds.focus.values[i]):g} m ({ds.attrs.get('lidar_tier', '')} tier)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_evolution(ds):
    """k at coherence 0.5 against focus distance for every period (frozen and evolving), simulated and analytic."""
    plt = _plt()
    j = _estimate(ds, "tier1")
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    r = ds.focus.values
    for ip, p in enumerate(ds.period.values):
        T = float(ds.lifetime.values[ip])
        lab = f"{p} ({'frozen' if not np.isfinite(T) else f'lifetime {T:g} s'})"
        ax.plot(r, ds.k_half.values[ip, :, j], "o-", color=f"C{ip}", label=f"{lab}, simulated")
        ax.plot(r, ds.k_half_theory.values[ip], "s--", mfc="none", color=f"C{ip}", label=f"{lab}, analytic")
    ax.set_xlabel("focus distance r [m]")
    ax.set_ylabel("k at coherence 0.5 [rad/m]")
    ax.set_title("turbulence evolution: the preview's bandwidth")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_preview(ds):
    """Preview time against focus distance, per period."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for ip, p in enumerate(ds.period.values):
        ax.plot(ds.focus.values, ds.preview_time.values[ip], "o-", label=f"{p}, U = {float(ds.mean_speed[ip]):g} m/s")
    ax.set_xlabel("focus distance r [m]")
    ax.set_ylabel("preview time r cos(a) / U [s]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def _against_focus(ax, r, y, **kw):
    """``y`` against focus distance ``r``: a line through two finite points or more, else markers; none: nothing."""
    y = np.asarray(y, dtype=np.float64)
    ok = np.isfinite(y)
    if not ok.any():
        return
    if ok.sum() < 2:
        kw = {**kw, "ls": "none"}
    ax.plot(np.asarray(r)[ok], y[ok], **kw)


def plot_std_ratio(ds):
    """Lidar / rotor std ratio and their correlation against focus distance per period: simulated (tier 1) and theory.

    The simulated values are the paired series' (``std_ratio``, ``correlation``:
    one period each); the general linear theory's (``std_ratio_theory``,
    ``correlation_theory``, :mod:`cwlidar_sim.campaign.periods.nacelle_theory`:
    the continuum, frozen periods only) and, where the results hold it, the
    lattice of the period's own box (``*_theory_lattice``) are drawn beside them.
    """
    plt = _plt()
    j = _estimate(ds, "tier1")
    r = ds.focus.values
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, var, lab in zip(axes, ("std_ratio", "correlation"), ("lidar / rotor std ratio [-]",
                                                                  "lidar-rotor correlation coefficient [-]")):
        for ip, p in enumerate(ds.period.values):
            c = f"C{ip}"
            if var in ds:  # (results written before the std ratio was simulated have none)
                _against_focus(ax, r, ds[var].values[ip, :, j], color=c, ls="-", marker="o", label=f"{p}, simulated")
            if f"{var}_theory" in ds:
                box = ds[f"{var}_theory"].attrs.get("theory_box", "continuum")
                _against_focus(ax, r, ds[f"{var}_theory"].values[ip], color=c, ls="--", marker="s", mfc="none",
                               label=f"{p}, linear theory ({box.split(' ')[0]})")
            if f"{var}_theory_lattice" in ds:
                _against_focus(ax, r, ds[f"{var}_theory_lattice"].values[ip], color=c, ls=(0, (1, 1)), marker="v",
                               mfc="none", label=f"{p}, linear theory (lattice)")
        ax.set_xlabel("focus distance r [m]")
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.suptitle("the preview's std ratio and correlation over each period (tier 1)", fontsize=10)
    fig.tight_layout()
    return fig


def make_nacelle_figures(ds, out_dir) -> list:
    """Write the nacelle figures as PNG into ``out_dir``; returns the paths."""
    plt = _plt()
    os.makedirs(out_dir, exist_ok=True)
    figs = {"coherence_focus": lambda: plot_coherence_focus(ds), "estimators": lambda: plot_estimators(ds),
            "evolution": lambda: plot_evolution(ds), "preview_time": lambda: plot_preview(ds),
            "std_ratio": lambda: plot_std_ratio(ds)}
    paths = []
    for name, make in figs.items():
        fig = make()
        path = os.path.join(os.fspath(out_dir), f"nacelle_{name}.png")
        with atomic_path(path) as tmp:  # a figure on disk is whole or absent
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
