"""Figures of a WindScanner campaign's results: each reconstructed component's transfer functions against a sonic.

Every function takes the results Dataset of a WindScanner scene
(:func:`cwlidar_sim.campaign.periods.windscanner.run_unit`, joined) and returns a Figure.
"""

from __future__ import annotations

import os

import numpy as np

from ..._atomic import atomic_path

__all__ = ["plot_transfer_components", "make_windscanner_figures"]


def plot_transfer_components(ds, period: int = 0, estimate: str = "main"):
    """A2012's methods 1 (ratio) and 2 (cross) against k for u, v and w of one period and estimate kind, with the linear theory."""
    import matplotlib.pyplot as plt

    j = list(ds.estimate.values).index(estimate)
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.8), sharey=True)
    k = ds.k.values
    for c, ax in enumerate(axes):
        for var, mark, label in (("transfer_ratio", "o", "method 1: F_lidar / F_sonic"),
                                 ("transfer_cross", "s", "method 2: Re(chi)^2 / F_sonic^2")):
            y = ds[var].values[period, j, c]
            fin = np.isfinite(y) & (y > 0)
            ax.plot(k[fin], y[fin], mark, ms=4, label=label)
            if f"{var}_theory" in ds:  # the linear theory beside it (campaign.periods.scanner_theory)
                th = ds[f"{var}_theory"].values[period, c]
                fin = np.isfinite(th) & (th > 0)
                ax.plot(k[fin], th[fin], "-" if var == "transfer_ratio" else "--", color="k", lw=1.0,
                        label=f"theory, method {1 if var == 'transfer_ratio' else 2}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wavenumber k [rad/m]")
        ax.set_title(f"{ds.component.values[c]}")
    axes[0].set_ylabel("transfer function [-]")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"period {ds.period.values[period]}, {estimate}: reconstructed wind against the sonic")
    fig.tight_layout()
    return fig


def make_windscanner_figures(ds, out_dir) -> list:
    """Write ``windscanner_transfer_<period>.png`` (main estimate) into ``out_dir``; returns the paths."""
    import matplotlib.pyplot as plt

    os.makedirs(out_dir, exist_ok=True)
    paths = []
    for ip, p in enumerate(ds.period.values):
        fig = plot_transfer_components(ds, ip)
        path = os.path.join(os.fspath(out_dir), f"windscanner_transfer_{p}.png")
        with atomic_path(path) as tmp:  # a figure on disk is whole or absent
            fig.savefig(tmp, dpi=110)
        plt.close(fig)
        paths.append(path)
    return paths
