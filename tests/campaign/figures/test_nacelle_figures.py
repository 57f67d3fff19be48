"""The nacelle figures draw the general linear theory's std ratio and correlation beside the simulated values."""

import matplotlib
import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.campaign.figures import nacelle as figures

matplotlib.use("Agg")

FOCUS = [50.0, 100.0, 150.0]


def _results(theory=True, lattice=False):
    """A nacelle results Dataset's std-ratio variables: a frozen period (theory finite) and an evolving one (NaN)."""
    rng = np.random.default_rng(5)
    sim = lambda base: base + 0.02 * rng.standard_normal((2, 3, 2))  # noqa: E731
    ds = xr.Dataset(
        {"std_ratio": (("period", "focus", "estimate"), sim(1.1)),
         "correlation": (("period", "focus", "estimate"), sim(0.9)),
         "lifetime": (("period",), [np.nan, 15.0])},
        coords={"period": ["frozen", "evolving"], "focus": FOCUS, "estimate": ["tier1", "main"]})
    th = {"std_ratio_theory": [1.21, 1.13, 1.08], "correlation_theory": [0.93, 0.95, 0.91]}
    for v, x in th.items():
        if theory:
            ds[v] = (("period", "focus"), np.array([x, [np.nan] * 3]), {"theory_box": "continuum (no box)"})
        if lattice:
            ds[f"{v}_lattice"] = (("period", "focus"), np.array([x, [np.nan] * 3]) - 0.01)
    return ds, th


def _lines(ax, y):
    """The axis's lines whose data are (FOCUS, y), with their labels."""
    return [ln.get_label() for ln in ax.get_lines()
            if np.allclose(ln.get_xdata(), FOCUS) and np.allclose(ln.get_ydata(), y, rtol=0, atol=1e-12)]


def test_the_std_ratio_figure_draws_the_theory_beside_the_simulation():
    import matplotlib.pyplot as plt

    ds, th = _results()
    fig = figures.plot_std_ratio(ds)
    ratio_ax, corr_ax = fig.axes
    for ax, v in ((ratio_ax, "std_ratio"), (corr_ax, "correlation")):
        assert _lines(ax, th[f"{v}_theory"]) == ["frozen, linear theory (continuum)"], v
        assert _lines(ax, ds[v].values[0, :, 0]) == ["frozen, simulated"]  # tier 1
        assert _lines(ax, ds[v].values[1, :, 0]) == ["evolving, simulated"]
        labels = [ln.get_label() for ln in ax.get_lines()]
        assert not any("evolving, linear" in s for s in labels)  # NaN: nothing drawn, nothing in the legend
        assert set(ax.get_legend_handles_labels()[1]) == set(labels)
    plt.close(fig)
    # the lattice, where the results hold it, is drawn too
    ds, th = _results(lattice=True)
    fig = figures.plot_std_ratio(ds)
    assert _lines(fig.axes[0], np.array(th["std_ratio_theory"]) - 0.01) == ["frozen, linear theory (lattice)"]
    plt.close(fig)
    # results without the theory (older files): the simulation alone, no theory line
    fig = figures.plot_std_ratio(_results(theory=False)[0])
    assert not any("theory" in ln.get_label() for ax in fig.axes for ln in ax.get_lines())
    plt.close(fig)


def test_make_nacelle_figures_writes_the_std_ratio_figure(tmp_path, monkeypatch):
    ds, _ = _results()
    for name in ("plot_coherence_focus", "plot_estimators", "plot_evolution", "plot_preview"):
        monkeypatch.setattr(figures, name, lambda *a, **k: __import__("matplotlib.pyplot").pyplot.figure())
    paths = figures.make_nacelle_figures(ds, tmp_path)
    assert str(tmp_path / "nacelle_std_ratio.png") in paths and (tmp_path / "nacelle_std_ratio.png").stat().st_size > 0


if __name__ == "__main__":
    pytest.main([__file__, "-q"])
