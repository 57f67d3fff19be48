"""Figures of a conical (CS) campaign's results, simulation beside CS's filter model.

After CS's figures: Fig. 6 (the regression of the lidar's 10-min standard
deviation on the cup's, 3 s scans at 40 m; the axes name the scene's own
period length), Figs. 8-9 (their ratio against
height, 3 s and 1 s scans) and Figs. 11-12 (the ratio of the radial variance
from the turbulence parameter to the sonic's against height, 3 s and 1 s).
CS shows no mean-speed comparison: :func:`plot_mean_speed` is the simulation's
own check.  Every
function takes the results Dataset of a conical scene
(:func:`cwlidar_sim.campaign.periods.conical.summarise`) and returns a Figure.
A profile against height with one height (or one finite value) is drawn as
markers alone, and one with none is left out of the plot and its legend: a
legend entry always names something drawn.
"""

from __future__ import annotations

import os

import numpy as np

from ..._atomic import atomic_path
from .._labels import periods_phrase

__all__ = ["plot_std_ratio", "plot_std_scatter", "plot_mean_speed", "plot_radial_variance", "make_cs_figures"]


def _plt():
    import matplotlib.pyplot as plt

    return plt


def _scan_label(ds, j):
    return f"{float(ds.scan_s[j]):g} s scans"


def _profile(ax, x, z, *, ls, marker, xerr=None, **kw):
    """A profile ``x`` against height ``z``: a line through two finite points or more, else markers alone; none: nothing."""
    x = np.asarray(x, dtype=np.float64)
    ok = np.isfinite(x)
    if not ok.any():
        return
    if ok.sum() < 2:
        ls, marker = "none", marker or "d"
    if xerr is not None:
        ax.errorbar(x, z, xerr=xerr, ls=ls, marker=marker or "none", **kw)
    else:
        ax.plot(x, z, ls=ls, marker=marker or "none", **kw)


def plot_std_ratio(ds, var="std_ratio", ylabel=None):
    """Ratio against height (CS Figs. 8-9): simulation (mean over selected periods +- s.e.), CS's model (Kaimal), Mann, the linear theory."""
    plt = _plt()
    ylabel = f"lidar / cup {periods_phrase(ds)} standard deviation" if ylabel is None else ylabel
    fig, ax = plt.subplots(figsize=(6, 4.5))
    z = ds.height.values
    for j in range(ds.sizes["scan_s"]):
        c = f"C{j}"
        _profile(ax, ds[var][:, j], z, xerr=ds[f"{var}_sigma"][:, j], ls="-", marker="o", color=c, capsize=3,
                 label=f"simulation, {_scan_label(ds, j)}")
        _profile(ax, ds[f"{var}_model"][:, j], z, ls="--", marker="s", color=c, mfc="none",
                 label=f"CS model (Kaimal), {_scan_label(ds, j)}")
        _profile(ax, ds[f"{var}_model_mann"][:, j], z, ls=":", marker=None, color=c,
                 label=f"CS model (Mann spectra), {_scan_label(ds, j)}")
        if f"{var}_theory" in ds:  # the 3-D linear theory (campaign.periods.conical_theory), when the scene asks
            _profile(ax, ds[f"{var}_theory"][:, j], z, ls="-.", marker="^", color=c, mfc="none",
                     label=f"linear theory ({ds[f'{var}_theory'].attrs.get('theory_box', 'continuum')[:9]}), "
                           f"{_scan_label(ds, j)}")
        if f"{var}_theory_lattice" in ds:  # the same over the units' own boxes (campaign.periods.lattice_theory)
            _profile(ax, ds[f"{var}_theory_lattice"][:, j], z, ls=(0, (1, 1)), marker="v", color=c, mfc="none",
                     label=f"linear theory (lattice), {_scan_label(ds, j)}")
    ax.set_xlabel(ylabel)
    ax.set_ylabel("height [m]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_std_scatter(ds):
    """Each period: lidar against cup standard deviation over the period, per height and scan (as CS Fig. 6: 40 m, 3 s)."""
    plt = _plt()
    nj = ds.sizes["scan_s"]
    fig, axes = plt.subplots(1, nj, figsize=(5 * nj, 4.5), squeeze=False)
    for j, ax in enumerate(axes[0]):
        for i, z in enumerate(ds.height.values):
            m = ds.unit_height.values == z
            ax.plot(ds.cup_std_unit.values[m], ds.lidar_std_unit.values[m, j], "o", color=f"C{i}", label=f"{z:g} m")
        top = float(np.nanmax(ds.cup_std_unit.values)) * 1.1
        ax.plot([0, top], [0, top], "k-", lw=0.8)
        ax.plot([0, top], [0, 0.8 * top], "k:", lw=0.8, label="ratio 0.8")
        ax.set_xlabel(f"cup {periods_phrase(ds)} standard deviation [m/s]")
        ax.set_ylabel(f"lidar {periods_phrase(ds)} standard deviation [m/s]")
        ax.set_title(_scan_label(ds, j), fontsize=9)
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_mean_speed(ds):
    """Each period: lidar against cup mean speed over the period, with the mean bias per height (not in CS)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5, 4.5))
    for i, z in enumerate(ds.height.values):
        m = ds.unit_height.values == z
        b = float(ds.mean_speed_bias[i, 0]) * 100
        ax.plot(ds.cup_mean_unit.values[m], ds.lidar_mean_unit.values[m, 0], "o", color=f"C{i}",
                label=f"{z:g} m (bias {b:+.2f} %)")
    lo, hi = float(np.nanmin(ds.cup_mean_unit)) * 0.95, float(np.nanmax(ds.cup_mean_unit)) * 1.05
    ax.plot([lo, hi], [lo, hi], "k-", lw=0.8)
    ax.set_xlabel(f"cup {periods_phrase(ds)} mean speed [m/s]")
    ax.set_ylabel(f"lidar {periods_phrase(ds)} mean speed, {_scan_label(ds, 0)} [m/s]")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def plot_radial_variance(ds):
    """(TP U)^2 against the sonic-equivalent radial variance: per period, and their ratio against height (CS Figs. 11-12)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5))
    ax = axes[0]
    for i, z in enumerate(ds.height.values):
        m = ds.unit_height.values == z
        ax.plot(ds.sonic_radial_variance_unit.values[m], ds.radial_variance_unit.values[m, 0], "o", color=f"C{i}",
                label=f"{z:g} m")
    top = float(np.nanmax(ds.sonic_radial_variance_unit)) * 1.1
    ax.plot([0, top], [0, top], "k-", lw=0.8)
    ax.set_xlabel("sonic radial variance [m2/s2]")
    ax.set_ylabel(f"(TP U)^2, {_scan_label(ds, 0)} [m2/s2]")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax = axes[1]
    z = ds.height.values
    for j in range(ds.sizes["scan_s"]):
        c = f"C{j}"
        _profile(ax, ds.radial_variance_ratio[:, j], z, xerr=ds.radial_variance_ratio_sigma[:, j], ls="-",
                 marker="o", color=c, capsize=3, label=f"simulation, {_scan_label(ds, j)}")
        _profile(ax, ds.radial_variance_ratio_model[:, j], z, ls="--", marker="s", color=c, mfc="none",
                 label=f"CS model (Kaimal), {_scan_label(ds, j)}")
        _profile(ax, ds.radial_variance_ratio_model_mann[:, j], z, ls=":", marker=None, color=c,
                 label=f"CS model (Mann), {_scan_label(ds, j)}")
    ax.set_xlabel("radial variance ratio (TP U)^2 / sonic")
    ax.set_ylabel("height [m]")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def make_cs_figures(ds, out_dir) -> list:
    """Write the conical figures as PNG into ``out_dir``; returns the paths."""
    plt = _plt()
    os.makedirs(out_dir, exist_ok=True)
    figs = {"cs_std_ratio": plot_std_ratio, "cs_std_scatter": plot_std_scatter, "cs_mean_speed": plot_mean_speed,
            "cs_radial_variance": plot_radial_variance}
    paths = []
    for name, make in figs.items():
        fig = make(ds)
        path = os.path.join(os.fspath(out_dir), f"{name}.png")
        with atomic_path(path) as tmp:  # a figure on disk is whole or absent
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
