"""Figures and long names say what was run: the segment and period lengths, the misaligned theory only for a
misaligned period, titles inside the figure, legend entries only for what is drawn; the results' sign labels."""

import json
import pathlib

import matplotlib
import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene, run_scene
from cwlidar_sim.campaign.figures import staring as figures, conical as figures_cs

matplotlib.use("Agg")

STARING = """
name = "labels"
seed = 3
duration = 600.0
[turbulence]
alpha_eps = 0.06
length_scale = 20.0
gamma = 3.9
[lidar]
tier = "los"
[analysis]
segment_duration = 300.0
fit = false
[[period]]
name = "aligned"
mean_speed = 8.0
[[period]]
name = "turned"
mean_speed = 6.0
misalignment_deg = 3.0
"""

CONICAL = """
name = "cone"
kind = "conical"
seed = 4
duration = 120.0
[scan]
heights = [40.0]
scan_revs = [1, 3]
[lidar]
tier = "los"
[[period]]
name = "a"
mean_speed = 8.0
[[period]]
name = "b"
mean_speed = 9.0
"""


@pytest.fixture(scope="module")
def staring():
    """Two 600-s periods analysed in 300-s segments: one aligned, one turned 3 deg from the wind."""
    return run_scene(loads_scene(STARING), None, progress=False)


@pytest.fixture(scope="module")
def cone():
    """Two 120-s periods of a conical scene at one height."""
    return run_scene(loads_scene(CONICAL), None, progress=False)


def _close(fig):
    import matplotlib.pyplot as plt

    plt.close(fig)


def texts_outside(fig):
    """The figure's titles and axis labels (drawn at the default size) that reach beyond the figure."""
    fig.canvas.draw()
    r, bb = fig.canvas.get_renderer(), fig.bbox
    texts = list(fig.texts) + ([fig._suptitle] if fig._suptitle is not None else [])
    for ax in fig.axes:
        if ax.get_visible():
            texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
    out = []
    for t in texts:
        if t.get_visible() and t.get_text():
            e = t.get_window_extent(r)
            if e.x0 < bb.x0 - 0.5 or e.x1 > bb.x1 + 0.5 or e.y0 < bb.y0 - 0.5 or e.y1 > bb.y1 + 0.5:
                out.append(t.get_text())
    return out


def every_text(fig):
    """Every title, axis label and legend text of a figure, as one string."""
    parts = [fig._suptitle.get_text()] if fig._suptitle is not None else []
    for ax in fig.axes:
        parts += [ax.get_title(), ax.get_xlabel(), ax.get_ylabel(), *ax.get_legend_handles_labels()[1]]
    return " | ".join(parts)


# ---------------------------------------------------------------------------
# staring scenes
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("periods", [[0], [0, 1]])
def test_the_spectra_title_lies_inside_the_figure_and_names_the_segment_length(staring, periods):
    """One period's figure is 5.5 in wide: its title used to be cut at both edges."""
    ds = staring.isel(period=periods)
    fig = figures.plot_spectra(ds)
    try:
        assert texts_outside(fig) == []
        title = fig._suptitle.get_text().replace("\n", " ")
        assert "300-s segments" in title and "10-min" not in title
    finally:
        _close(fig)


def test_every_staring_figure_keeps_its_titles_and_labels_inside(staring):
    ds = staring.isel(period=[0])
    for make in (figures.plot_spectra, lambda d: figures.plot_transfer(d, "ratio"),
                 lambda d: figures.plot_transfer(d, "cross"), figures.plot_methods):
        fig = make(ds)
        try:
            assert texts_outside(fig) == []
        finally:
            _close(fig)


def test_long_names_name_the_segment_length(staring):
    assert staring.n_segments.attrs["long_name"].startswith("300-s segments")
    assert list(staring.n_segments.values) == [2, 2]
    # results analysed in 600-s segments are A2012's 10-min ones
    scene = json.loads(staring.attrs["scene"])
    scene["analysis"]["segment_duration"] = 600.0
    fig = figures.plot_spectra(staring.assign_attrs(scene=json.dumps(scene)))
    assert "10-min segments" in fig._suptitle.get_text()
    _close(fig)


def test_the_methods_figure_draws_the_misaligned_theory_for_a_misaligned_period_only(staring):
    assert list(staring.misalignment.values) == [0.0, 3.0]
    labels = {}
    for i in (0, 1):
        fig = figures.plot_methods(staring, i)
        labels[i] = fig.axes[0].get_legend_handles_labels()[1]
        _close(fig)
    assert not any("misaligned" in lab for lab in labels[0]), labels[0]
    assert {"Eqs. 12, 13 (misaligned)", "Eqs. 12, 14 (misaligned)"} <= set(labels[1])
    # the aligned period's figure still has both methods and the aligned theory
    assert {"method 1 (ratio)", "method 2 (cross)"} <= set(labels[0])
    assert any(lab.startswith("exp(-2 k zR)") for lab in labels[0])


def test_the_misalignment_figure_is_drawn_for_a_scene_with_a_misaligned_period_only(staring, tmp_path):
    aligned = {pathlib.Path(p).name for p in figures.make_figures(staring.isel(period=[0]), tmp_path / "a")}
    assert "misalignment_5deg.png" not in aligned and "methods.png" in aligned
    assert not (tmp_path / "a" / "misalignment_5deg.png").exists()
    both = {pathlib.Path(p).name for p in figures.make_figures(staring, tmp_path / "b")}
    assert "misalignment_5deg.png" in both


def test_the_results_say_which_sign_they_carry(staring):
    """The line-of-sight series say 'toward the lidar' (the sonic, the ideal) or 'magnitude' (the estimates); and
    the numbers agree: a lidar looking into the wind reads about +U cos(misalignment) in each."""
    for name in ("sonic_10hz", "lidar_ideal"):
        assert staring[name].attrs["sign_convention"].startswith("positive toward the lidar"), name
    for name in ("lidar_speed", "lidar_10hz"):
        assert staring[name].attrs["sign_convention"].startswith("the magnitude"), name
    U = staring.mean_speed.values
    expect = U * np.cos(np.radians(staring.misalignment.values))
    for name in ("sonic_10hz", "lidar_ideal", "lidar_10hz"):
        m = np.nanmean(staring[name].values, axis=1)
        np.testing.assert_allclose(m, expect, rtol=0.1, err_msg=name)
    assert np.nanmin(staring.lidar_speed.values) >= 0.0


# ---------------------------------------------------------------------------
# conical scenes
# ---------------------------------------------------------------------------
def drawn(handle) -> bool:
    """Whether a legend handle stands for something drawn: a marker at a finite point, or a line through two."""
    from matplotlib.container import ErrorbarContainer

    line = handle.lines[0] if isinstance(handle, ErrorbarContainer) else handle
    x, y = (np.asarray(a, dtype=float) for a in line.get_data())
    n = int(np.sum(np.isfinite(x) & np.isfinite(y)))
    marker = line.get_marker() not in (None, "None", "none", "", " ")
    line_style = line.get_linestyle() not in ("None", "none", "", " ")
    if n == 0:
        return False
    if n == 1:  # one point draws no line: its legend entry must show a marker and no line
        return marker and not line_style
    return marker or line_style


CS_PLOTS = (figures_cs.plot_std_ratio, figures_cs.plot_std_scatter, figures_cs.plot_mean_speed,
            figures_cs.plot_radial_variance)


def test_single_height_conical_figures_have_legend_entries_only_for_what_is_drawn(cone):
    assert cone.sizes["height"] == 1
    for make in CS_PLOTS:
        fig = make(cone)
        try:
            for ax in fig.axes:
                handles, labels = ax.get_legend_handles_labels()
                for h, lab in zip(handles, labels):
                    assert drawn(h), f"{make.__name__}: legend entry {lab!r} stands for nothing drawn"
                assert len(set(labels)) == len(labels), labels
            assert texts_outside(fig) == []
        finally:
            _close(fig)
    # a model left out (NaN) is neither drawn nor in the legend
    blank = cone.assign(std_ratio_model_mann=cone.std_ratio_model_mann * np.nan)
    fig = figures_cs.plot_std_ratio(blank)
    labels = fig.axes[0].get_legend_handles_labels()[1]
    _close(fig)
    assert not any("Mann" in lab for lab in labels) and any("Kaimal" in lab for lab in labels)


def test_conical_figures_and_long_names_name_the_period_length(cone):
    assert cone.cup_std_unit.attrs["long_name"] == "cup 120-s standard deviation"
    assert cone.std_ratio.attrs["long_name"].startswith("lidar / cup 120-s standard deviation")
    for make in CS_PLOTS:
        fig = make(cone)
        text = every_text(fig)
        _close(fig)
        assert "10-min" not in text, (make.__name__, text)
    fig = figures_cs.plot_std_ratio(cone)
    assert fig.axes[0].get_xlabel() == "lidar / cup 120-s standard deviation"
    _close(fig)
    # 600-s periods are CS's 10-min ones; periods of different lengths are 'period' ones
    scene = json.loads(cone.attrs["scene"])
    for durations, phrase in (((600.0, 600.0), "10-min"), ((600.0, 120.0), "period")):
        for p, d in zip(scene["period"], durations):
            p["duration"] = d
        fig = figures_cs.plot_std_ratio(cone.assign_attrs(scene=json.dumps(scene)))
        assert fig.axes[0].get_xlabel() == f"lidar / cup {phrase} standard deviation"
        _close(fig)
