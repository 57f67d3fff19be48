"""Figures of a spinner campaign's results: the REWS per rosette against the rotor's, and the inflow's shear, veer, yaw.

Every function takes the results Dataset of a spinner scene
(:func:`cwlidar_sim.campaign.periods.spinner.run_unit`, joined) and returns a Figure.
"""

from __future__ import annotations

import os

import numpy as np

from ..._atomic import atomic_path

__all__ = ["plot_rews", "plot_inflow", "plot_rews_coherence", "make_spinner_figures"]


def _plt():
    import matplotlib.pyplot as plt

    return plt


def plot_rews(ds, period: int = 0):
    """The lidar's REWS per rosette for every estimate kind beside the rotor's (preview-shifted)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.0, 4.0))
    t = ds.rosette_time.values[period]
    ax.plot(t, ds.rews_rotor.values[period], "k-", lw=1.2, label="rotor (disc average, preview-shifted)")
    for j, e in enumerate(ds.estimate.values):
        ax.plot(t, ds.rews.values[period, j], ".-", ms=3, lw=0.6,
                label=f"{e}: RMSE {float(ds.rews_rmse.values[period, j]):.3f} m/s")
    ax.set_xlabel("rosette mid-time [s]")
    ax.set_ylabel("REWS along the rotor axis [m/s]")
    ax.set_title(f"period {ds.period.values[period]}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_inflow(ds, period: int = 0):
    """Vertical shear, veer and yaw estimate per rosette (every estimate kind)."""
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(7.0, 6.5), sharex=True)
    t = ds.rosette_time.values[period]
    for ax, name, label in zip(axes, ("vertical_shear", "veer", "yaw_estimate"),
                               ("dS/dz [1/s]", "veer [deg/m]", "yaw misalignment [deg]")):
        for j, e in enumerate(ds.estimate.values):
            ax.plot(t, ds[name].values[period, j], ".-", ms=3, lw=0.6, label=str(e))
        ax.set_ylabel(label)
    axes[2].plot(t, ds.yaw_rotor.values[period], "k-", lw=1.2, label="rotor (disc-averaged wind)")
    axes[2].axhline(float(ds.yaw_misalignment.values[period]), color="k", lw=0.8, ls=":", label="set")
    axes[2].legend(fontsize=7)
    axes[0].legend(fontsize=7)
    axes[-1].set_xlabel("rosette mid-time [s]")
    fig.tight_layout()
    return fig


def plot_rews_coherence(ds, period: int = 0):
    """The coherence of each estimate kind's REWS with the rotor's over the rosettes, and the linear theory's."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    k = ds.k_coherence.values[period]
    for j, e in enumerate(ds.estimate.values):
        ax.plot(k, ds.rews_coherence.values[period, j], "o", ms=4, label=str(e))
    th = ds.rews_coherence_theory.values[period]
    if np.isfinite(th).any():
        ax.plot(k, th, "k-", lw=1.2, label="linear theory (frozen)")
    ax.set_xscale("log")
    ax.set_ylim(0.0, 1.05)
    ax.set_xlabel("wavenumber k [rad/m]")
    ax.set_ylabel("coherence, lidar REWS vs rotor [-]")
    ax.set_title(f"period {ds.period.values[period]}")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def make_spinner_figures(ds, out_dir) -> list:
    """Write the figures of every period as PNG into ``out_dir``; the paths."""
    plt = _plt()
    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for ip in range(ds.period.size):
        plots = [("rews", plot_rews), ("inflow", plot_inflow)]
        if "rews_coherence" in ds:
            plots.append(("coherence", plot_rews_coherence))
        for name, fn in plots:
            fig = fn(ds, ip)
            path = os.path.join(os.fspath(out_dir), f"spinner_{name}_period{ip}.png")
            with atomic_path(path) as tmp:
                fig.savefig(tmp, dpi=110, format="png")
            plt.close(fig)
            paths.append(path)
    return paths
