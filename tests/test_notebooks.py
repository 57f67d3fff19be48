"""Every notebook in notebooks/ runs top to bottom in quick mode (CWLIDAR_SIM_QUICK=1), and what it shows is right."""

import math
import os
import pathlib

import numpy as np
import pytest

import reference

ROOT = pathlib.Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def _stdout(nb):
    return "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
                   if o.output_type == "stream" and o.get("name") == "stdout")


def _check_a2012(nb, results):
    """The A2012 notebook: printed optics, the in-run tensor fit (fit = true) and the fitted-tensor theory."""
    from cwlidar_sim.campaign import read_results

    text = _stdout(nb)
    # A2012 Eq. 1 at the 67.5 m focus (5.61 m), and where exp(-2 k zR) is 1e-3: ln(1000) / (2 zR)
    ds = read_results(results)
    zR = ds.attrs["rayleigh_length"]
    assert zR == pytest.approx(5.61, abs=0.005)
    assert f"Rayleigh length {zR:.3f} m" in text
    assert f"= 1e-3 at k = {math.log(1e3) / (2 * zR):.3f} rad/m" in text and "0.616 rad/m" in text
    # The fit to each period's sonic spectra recovers the scene's tensor within 4 reported sd
    # (12 comparisons), with sd small enough to mean something (< 15 % of the value).
    for name in ("alpha_eps", "length_scale", "gamma"):
        fit, sd, true = ds[f"fit_{name}"].values, ds[f"fit_{name}_std"].values, ds.attrs[name]
        assert np.all(np.isfinite(fit)) and np.all(sd > 0) and np.all(sd < 0.15 * true), (name, fit, sd)
        assert np.all(np.abs(fit - true) < 4 * sd), (name, fit, true, sd)
        assert f"{name}: scene {true:.4g}, fitted per period" in text
    # The misaligned theory stored per period uses that period's fitted tensor (A2012 Eqs. 12-14):
    # checked against the plain-Python double integral at two wavenumbers of the most misaligned period.
    from cwlidar_sim.turbulence import MannParameters

    i = int(np.argmax(np.abs(ds.misalignment.values)))
    p = MannParameters(*(float(ds[f"fit_{n}"][i]) for n in ("alpha_eps", "length_scale", "gamma")))
    k = ds.k.values
    for kk in (0.1, 0.5):
        j = int(np.argmin(np.abs(k - kk)))
        F_vs, F_vr, chi = reference.misaligned_reference(k[j], p.alpha_eps, p.length_scale, p.gamma,
                                                         float(ds.misalignment[i]), zR)
        assert float(ds.transfer_theory_ratio[i, j]) == pytest.approx(F_vr / F_vs, rel=1e-4)
        assert float(ds.transfer_theory_cross[i, j]) == pytest.approx(chi**2 / F_vs**2, rel=1e-4)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs_in_quick_mode(path, tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.setenv("CWLIDAR_SIM_QUICK", "1")
    monkeypatch.setenv("CWLIDAR_SIM_OUT", str(tmp_path / "out"))
    # the kernel runs in tmp_path: put this checkout first, or it would import an installed cwlidar_sim
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(ROOT)] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    nb = nbformat.read(path, as_version=4)
    # a kernel on a loaded machine can take over the default 60 s to start
    client = nbclient.NotebookClient(nb, timeout=900, startup_timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors
    images = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if "image/png" in o.get("data", {})]
    assert len(images) >= 5
    if "a2012" in path.name:
        _check_a2012(nb, tmp_path / "out" / "a2012" / "a2012.nc")
    if "cs_" in path.name:
        _check_cs(nb, tmp_path / "out" / "cs" / "cs.nc")
    if path.name == "twin.ipynb":
        _check_twin(nb)
    if "nacelle" in path.name:
        _check_nacelle(nb, tmp_path / "out" / "nacelle" / "nacelle.nc")
    if path.name == "spinner.ipynb":
        _check_spinner(nb, tmp_path / "out" / "spinner" / "spinner.nc")
    if path.name == "windscanner.ipynb":
        _check_windscanner(nb, tmp_path / "out" / "windscanner" / "windscanner.nc")


def _check_spinner(nb, results):
    """The SpinnerLidar notebook: the rosette as published, a uniform wind returned, frozen REWS that follow the rotor."""
    import ast

    from cwlidar_sim.campaign import read_results

    text = _stdout(nb)
    assert "rosette 2.000 s, 984 estimates (492 Hz), up to 30.4 deg off the axis" in text
    line = next(t for t in text.splitlines() if t.startswith("per rosette: REWS"))
    g, U = math.radians(10.0), 10.0
    rews = ast.literal_eval(line.split("REWS ", 1)[1].split(", yaw")[0])
    yaw = ast.literal_eval(line.split("yaw ", 1)[1].split(" deg")[0])
    np.testing.assert_allclose(rews, U * math.cos(g), atol=1e-8)
    np.testing.assert_allclose(yaw, 10.0, atol=1e-8)
    lag = float(next(t for t in text.splitlines() if t.startswith("preview distance")).split("lags the rotor's REWS by ")[1]
                .split(" s")[0])
    assert 0.3 < lag < 0.7, lag  # the cone's half a second (tests/sensors/test_spinner_preview_timing.py)
    ds = read_results(results)
    j = list(ds.estimate.values).index("tier1")
    frozen = np.isnan(ds.lifetime.values)
    # tier 1, frozen turbulence: the rosette's REWS follows the rotor's within a few tenths of a m/s
    assert frozen.sum() == 2 and np.all(ds.rews_rmse.values[frozen, j] < 0.3), ds.rews_rmse.values
    assert np.all(ds.rews_correlation.values[frozen, j] > 0.9), ds.rews_correlation.values
    # the blades block the same share every period (they turn with the prisms): about a fifth of the looks
    share = ds.n_blocked.values / (ds.rosette.size * 984)
    assert np.all(share == share[0]) and 0.1 < share[0] < 0.35, share
    assert f"blocked {int(ds.n_blocked.values[0])} of {ds.rosette.size * 984} estimates" in text


def _check_windscanner(nb, results):
    """The WindScanner notebook: the published layout, the closed-form conditioning, exact reconstruction, physics."""
    from cwlidar_sim.campaign import read_results

    text = _stdout(nb)
    for el in ("56.5", "51.7", "56.4"):
        assert f"elevation {el} deg" in text
    assert "mean range 125.0 m, cond(N) 2.654" in text
    rel = float(next(t for t in text.splitlines() if t.startswith("largest difference from the closed form"))
                .split(": ")[1].split(" ")[0])
    assert rel < 1e-9, rel
    err = float(next(t for t in text.splitlines() if "largest error of the reconstructed wind" in t)
                .split("wind ")[1].split(" m/s")[0])
    assert err < 1e-9, err
    ds = read_results(results)
    j = list(ds.estimate.values).index("tier1")
    # the probe volumes (z_R ~ 19 m at 125 m) average the turbulence: every component's std below the sonic's
    ratio = ds.wind_std.values[:, j] / ds.sonic_std.values
    assert np.all((ratio > 0.2) & (ratio < 1.0)), ratio
    assert np.all(ds.n_ill_conditioned.values[:, j] == 0)
    np.testing.assert_allclose(ds.wind_mean.values[:, j, 1:], 0.0, atol=1.0)


def _check_twin(nb):
    """The twin notebook: the closed loop it prints holds (squared coherence twin-truth > 0.9 below 0.05 rad/m)."""
    text = _stdout(nb)
    line = next(s for s in text.splitlines() if s.startswith("twin-truth squared coherence below 0.05 rad/m:"))
    assert float(line.split(":")[1]) > 0.9, line


def _check_nacelle(nb, results):
    """The nacelle notebook: printed geometry, the uniform yawed wind returned, results that are physics."""
    import ast

    from cwlidar_sim.campaign import read_results

    text = _stdout(nb)
    a, U = math.radians(15.0), 12.0
    for r in (50.0, 100.0):
        assert f"r = {r:5.1f} m: preview distance {r * math.cos(a):6.1f} m, preview time {r * math.cos(a) / U:5.2f} s"\
            in text
    line = next(t for t in text.splitlines() if t.startswith("fitted wind per revolution"))
    fitted = ast.literal_eval(line.split(": ", 1)[1].split("; expected")[0])
    g = math.radians(10.0)
    np.testing.assert_allclose(fitted, [[U * math.cos(g), -U * math.sin(g), 0.0]] * 2, atol=2e-6)
    ds = read_results(results)
    np.testing.assert_allclose(ds.preview_time.values, np.broadcast_to(ds.focus.values * math.cos(a) / U, (2, 2)))
    coh = ds.coherence.values
    assert np.all((coh[np.isfinite(coh)] >= 0) & (coh[np.isfinite(coh)] <= 1))
    th = ds.coherence_theory.values
    # as the estimate sees it: NaN in the bins without an ordinate, the same bins in every row
    held = np.isfinite(th[0, 0])
    assert held.sum() >= 4 and np.all(np.isfinite(th[..., held])) and np.all(np.isnan(th[..., ~held]))
    th = th[..., held]
    # falling with k while it matters (beyond, the disc's and the circle's Bessel side lobes, below 1e-4)
    d = np.diff(th, axis=-1)
    assert np.all((d < 0) | (th[..., 1:] < 1e-3)) and np.all(th[..., -1] < 1e-3)
    # evolution decorrelates: the evolving period's analytic coherence lies below the frozen one's
    # (where the frozen coherence is not near a null of the disc's and the circle's transfers: there the
    # modes' cross terms cancel, and damping them unevenly can leave more)
    # (as the notebook's 20-s segments see it, the theory holds only the bins with an ordinate, one
    # per 0.026 rad/m, and above 0.03 only the first at each distance)
    big = th[0] > 0.03
    assert big.sum() >= 2 and np.all(th[1][big] < th[0][big]), (th[0], th[1])


def _check_cs(nb, results):
    """The CS notebook: printed geometry, and ratios that are physics, not just numbers."""
    from cwlidar_sim.campaign import read_results

    text = _stdout(nb)
    # CS's geometry at 100 m: focus z / cos 30 deg, circle 2 z tan 30 deg, spot speed 2 pi r sin 30 deg per second
    r = 100.0 / math.cos(math.radians(30.0))
    assert f"focus {r:6.1f} m" in text and f"circle D = {200 * math.tan(math.radians(30)):5.1f} m" in text
    assert f"spot speed {2 * math.pi * r * 0.5:5.0f} m/s" in text
    ds = read_results(results)
    assert ds.std_ratio.dims == ("height", "scan_s") and list(ds.scan_s.values) == [1.0, 3.0]
    # a volume- and scan-averaging lidar sees less variance than a cup; CS: about 0.8
    assert np.all((ds.std_ratio.values > 0.5) & (ds.std_ratio.values < 1.0)), ds.std_ratio.values
    # the filter model's values against CS Eq. 4's scan length and the probe filter: below 1, falling with n
    assert np.all(ds.std_ratio_model.values[:, 1] < ds.std_ratio_model.values[:, 0])
    # the mean speed of the VAD fits follows the cup's (tier 1, clean air): a circle's and a point's means
    # over U T metres of turbulence differ by about (sigma_u / U) sqrt(2 L / (U T)) (1.4 % here); 3 of those
    U, T = ds.mean_speed_unit.values, 300.0
    tol = 3 * ds.cup_std_unit.values / ds.cup_mean_unit.values * np.sqrt(2 * ds.mann_length_scale_unit.values / (U * T))
    bias = ds.mean_speed_bias_unit.values[:, 0]
    assert np.all(np.abs(bias) < tol), (bias, tol)
    # the homodyne zero crossings cost points twice per revolution, and they are counted
    assert np.all((ds.zero_crossing_loss.values > 0.02) & (ds.zero_crossing_loss.values < 0.3))
    for z in ds.height.values:
        assert f"std ratio at {z:g} m:" in text
