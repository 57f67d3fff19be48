"""The one ``[turbulence]`` table of every scene kind: what a user knows (ti, sigma_u, IEC class), the surface
layer with stability, the explicit tensor; the same parameters in every kind; refusals named by key."""

import math

import numpy as np
import pytest

from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.scenes.conical import SurfaceTurbulenceSpec
from cwlidar_sim.campaign.scenes.nacelle import NacelleTurbulenceSpec
from cwlidar_sim.campaign.scenes.load import load_scene
from cwlidar_sim.campaign.scenes.staring import TurbulenceSpec
from cwlidar_sim.turbulence import MannParameters
from cwlidar_sim.turbulence.spectra import one_point_spectra
from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

KINDS = (TurbulenceSpec, SurfaceTurbulenceSpec, NacelleTurbulenceSpec)


def u_variance(p: MannParameters) -> float:
    """sigma_u^2 of the tensor: the analytic one-point spectrum F11 integrated over k1.

    Trapezoids in ln k1 from 1e-6 / L to 1e4 / L, and above it the inertial range's k1^(-5/3) tail in closed
    form (1.5 k F11 at the top); the spectrum is one-sided (the package's convention), so the half line holds
    all of the variance.
    """
    x = np.linspace(math.log(1e-6), math.log(1e4), 1500)
    k = np.exp(x) / p.length_scale
    g = one_point_spectra(k, p)[0] * k
    return float(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(x))) + 1.5 * g[-1]


@pytest.mark.parametrize("cls", KINDS)
def test_ti_gives_a_tensor_of_that_u_variance(cls):
    p = cls.from_dict({"ti": 0.1, "height": 80.0}).params(None, 10.0)
    assert u_variance(p) == pytest.approx((0.1 * 10.0) ** 2, rel=2e-4)
    # IEC 61400-1 Annex C's length scale above 60 m and its Gamma when not given
    assert (p.length_scale, p.gamma) == (pytest.approx(0.8 * 42.0), 3.9)


def test_sigma_u_length_scale_gamma_and_the_iec_length_below_60_m():
    p = TurbulenceSpec.from_dict({"sigma_u": 1.3, "length_scale": 25.0, "gamma": 2.5}).params()
    assert (p.length_scale, p.gamma) == (25.0, 2.5)
    assert u_variance(p) == pytest.approx(1.3**2, rel=2e-4)
    low = TurbulenceSpec.from_dict({"sigma_u": 1.0, "height": 40.0}).params()
    assert low.length_scale == pytest.approx(0.8 * 0.7 * 40.0)


@pytest.mark.parametrize("cls", KINDS)
@pytest.mark.parametrize("cat, iref", [("A+", 0.18), ("A", 0.16), ("B", 0.14), ("C", 0.12)])
def test_iec_class_is_the_normal_turbulence_model(cls, cat, iref):
    spec = cls.from_dict({"iec_class": cat, "height": 90.0})
    for U in (6.0, 12.0):
        p, su, _ = spec.resolve(None, U)
        assert su == pytest.approx(iref * (0.75 * U + 5.6), rel=1e-12)
        if cat == "B" and U == 12.0:
            assert u_variance(p) == pytest.approx((0.14 * (0.75 * 12.0 + 5.6)) ** 2, rel=2e-4)


@pytest.mark.parametrize("table", [{"ti": 0.12, "height": 70.0}, {"iec_class": "A", "height": 30.0, "gamma": 3.0},
                                   {"sigma_u": 1.1, "length_scale": 40.0},
                                   {"alpha_eps": 0.07, "length_scale": 21.0, "gamma": 3.2},
                                   {"source": "mann1994", "z0": 0.03, "obukhov_length": -150.0, "height": 60.0}])
def test_the_same_table_gives_the_same_tensor_in_every_kind(table):
    got = [cls.from_dict(dict(table)).resolve(None, 9.0) for cls in KINDS]
    assert got[0] == got[1] == got[2]
    if "obukhov_length" in table:  # Monin-Obukhov: unstable air mixes more than neutral air at the same U
        neutral = surface_layer_parameters(60.0, 9.0, z0=0.03)
        assert got[0][1] > neutral[1] and got[0][2] > neutral[2]


def test_conical_units_take_their_own_height_and_period_speed():
    spec = SurfaceTurbulenceSpec.from_dict({"ti": 0.1})
    for z, U in ((40.0, 8.0), (100.0, 12.0)):
        assert spec.params(z, U) == TurbulenceSpec.from_dict({"ti": 0.1, "height": z}).params(None, U)
    assert spec.params(40.0, 8.0).length_scale == pytest.approx(0.8 * 0.7 * 40.0)
    assert spec.params(100.0, 8.0).alpha_eps != spec.params(100.0, 12.0).alpha_eps


def test_explicit_keys_reproduce_the_old_tables_exactly():
    old = MannParameters(0.06224407174474577, 18.76, 3.9)
    explicit = {"alpha_eps": old.alpha_eps, "length_scale": old.length_scale, "gamma": old.gamma}
    for cls in KINDS:
        assert cls.from_dict(dict(explicit)).params(None, 7.0) == old
    fixed = SurfaceTurbulenceSpec.from_dict({"source": "fixed", **explicit})
    assert fixed.resolve(80.0, 8.0) == (old, None, None)
    assert fixed.as_dict() == {"source": "fixed", "z0": 0.01, **explicit}  # the older spelling keeps its identity
    # the kinds' default tables: the nacelle's tensor, the conical surface layer (z0 = 0.01)
    assert NacelleTurbulenceSpec().params(None, 12.0) == MannParameters(0.1, 33.6, 3.9)
    assert NacelleTurbulenceSpec.from_dict({"gamma": 3.0}).params(None, 12.0) == MannParameters(0.1, 33.6, 3.0)
    cs = SurfaceTurbulenceSpec()
    assert cs.as_dict() == {"source": "mann1994", "z0": 0.01}
    assert cs.resolve(60.0, 9.0) == surface_layer_parameters(60.0, 9.0, z0=0.01, source="mann1994")


def test_bundled_scenes_resolve_to_their_old_parameters():
    from importlib import resources

    folder = resources.files("cwlidar_sim.campaign") / "data" / "scenes"
    a = load_scene(folder / "a2012.toml")
    assert a.turbulence.params(None, a.periods[0].mean_speed) == MannParameters(0.06224407174474577, 18.76, 3.9)
    assert a.turbulence.as_dict() == {"alpha_eps": 0.06224407174474577, "length_scale": 18.76, "gamma": 3.9}
    cs = load_scene(folder / "cs.toml")
    assert cs.turbulence.as_dict() == {"source": "mann1994", "z0": 0.01}
    for p in cs.periods[:2]:
        for z in cs.scan.heights:
            assert cs.turbulence.resolve(z, p.mean_speed) == surface_layer_parameters(z, p.mean_speed, z0=0.01)
    n = load_scene(folder / "nacelle.toml")
    assert n.turbulence.as_dict() == {"alpha_eps": 0.1, "length_scale": 33.6, "gamma": 3.9}
    assert {n.period_params(p) for p in n.periods} == {MannParameters(0.1, 33.6, 3.9)}


@pytest.mark.parametrize("cls, table, match", [
    (TurbulenceSpec, {"ti": 0.1, "sigma_u": 1.0, "height": 50.0}, r"ti and sigma_u each set sigma_u; keep one"),
    (TurbulenceSpec, {"ti": 0.1, "alpha_eps": 0.1, "height": 50.0}, r"keep ti or alpha_eps"),
    (SurfaceTurbulenceSpec, {"iec_class": "B", "source": "mann1994"}, r"keep iec_class or source"),
    (SurfaceTurbulenceSpec, {"source": "mann1994", "alpha_eps": 0.1}, r"keep source or alpha_eps"),
    (TurbulenceSpec, {"fit_to": "s.nc", "ti": 0.1}, r"give either fit_to or ti, not both"),
    (TurbulenceSpec, {"ti": 0.6, "height": 50.0}, r"turbulence\.ti=0\.6 is out of range; allowed: \(0(\.0)?, 0\.5\]"),
    (NacelleTurbulenceSpec, {"sigma_u": -1.0}, r"turbulence\.sigma_u=-1\.0 is out of range"),
    (SurfaceTurbulenceSpec, {"iec_class": "D"}, r"turbulence\.iec_class.*'D'"),
    (TurbulenceSpec, {"ti": 0.1, "height": 50.0, "gamma": 9.0}, r"turbulence\.gamma=9\.0 is above 8"),
    (TurbulenceSpec, {"ti": 0.1, "length_scale": 9000.0}, r"turbulence\.length_scale=9000\.0 m is above"),
    (TurbulenceSpec, {"alpha_eps": -1.0, "length_scale": 20.0, "gamma": 3.9}, r"turbulence\.alpha_eps=-1\.0"),
    (TurbulenceSpec, {"ti": 0.1}, r"turbulence\.height: a staring scene has no measurement height"),
    (NacelleTurbulenceSpec, {"source": "mann1994"}, r"turbulence\.height: a nacelle scene"),
    (SurfaceTurbulenceSpec, {"source": "iec", "obukhov_length": -100.0}, r"turbulence\.obukhov_length.*neutral"),
    (TurbulenceSpec, {"source": "mann1994", "height": 80.0, "obukhov_length": 20.0},
     r"turbulence\.obukhov_length=20\.0 is out of range; allowed: \|L\| >= height / 2 = 40 m"),
    (TurbulenceSpec, {"alpha_eps": 0.1, "length_scale": 20.0, "gamma": 3.9, "z0": 0.1},
     r"turbulence\.z0 .*needs source"),
    (SurfaceTurbulenceSpec, {"fit_to": "s.nc"}, r"turbulence\.fit_to.*kinds that take fit_to: staring"),
    (NacelleTurbulenceSpec, {"condition_on": [{"path": "m.csv", "kind": "sonic", "position": [0, 0, 0]}]},
     r"turbulence\.condition_on.*kinds that take condition_on: staring, conical"),
    (TurbulenceSpec, {"iec_class": "B", "height": 30.0,
                      "condition_on": [{"path": "m.csv", "kind": "sonic", "position": [0, 0, 0]}]},
     r"turbulence\.condition_on: a staring twin needs one tensor .* iec_class"),
    (TurbulenceSpec, {}, r"turbulence needs one of"),
    (TurbulenceSpec, {"ti_": 0.1}, r"unknown key\(s\) in turbulence: \['ti_'\] \(did you mean 'ti'"),
])
def test_conflicting_and_out_of_range_tables_refused_by_key(cls, table, match):
    with pytest.raises((ValueError, TypeError), match=match):
        cls.from_dict(table)


SCENE = """
name = "ti"
seed = 4
duration = 600.0
[turbulence]
{turbulence}
[lidar]
tier = "los"
[analysis]
segment_duration = 300.0
fit = false
[[period]]
name = "slow"
mean_speed = {slow}
[[period]]
name = "fast"
mean_speed = 12.0
"""


def test_taylor_limit_applies_to_the_resolved_sigma_u_of_each_period():
    loads_scene(SCENE.format(turbulence='sigma_u = 2.0\nheight = 30.0', slow=4.0))  # 0.5 at 4 m/s: accepted
    with pytest.raises(ValueError, match=r"turbulence\.sigma_u = 2\.0 gives .* sigma_u/U = 0\.53 in period\[0\] \('slow'\) "
                                         r"\(mean_speed = 3\.8 m/s\).*allowed: sigma_u <= 1\.9 m/s"):
        loads_scene(SCENE.format(turbulence='sigma_u = 2.0\nheight = 30.0', slow=3.8))
    # A+: 0.18 (0.75 U + 5.6) <= 0.5 U from U = 1.008 / 0.365 = 2.76 m/s
    with pytest.raises(ValueError, match=r"turbulence\.iec_class = 'A\+' .* period\[0\] \('slow'\).*mean_speed >= 2\.76 m/s"):
        loads_scene(SCENE.format(turbulence='iec_class = "A+"\nheight = 30.0', slow=2.5))
    loads_scene(SCENE.format(turbulence='iec_class = "A+"\nheight = 30.0', slow=2.8))


def test_staring_periods_get_their_own_tensor(tmp_path):
    from cwlidar_sim.campaign import run_scene
    from cwlidar_sim.campaign.periods.staring_field import scene_params

    scene = loads_scene(SCENE.format(turbulence="ti = 0.1\nheight = 33.5", slow=6.0))
    assert scene_params(scene) == (None, None)  # no one tensor for the scene
    ds = run_scene(scene, tmp_path, progress=False)
    a = ds.mann_alpha_eps.values
    # sigma_u = ti U: alpha_eps grows as U^2 at a fixed length scale and Gamma
    assert a[1] / a[0] == pytest.approx((12.0 / 6.0) ** 2, rel=1e-12)
    assert np.allclose(ds.mann_length_scale.values, 0.8 * 0.7 * 33.5, rtol=1e-12)
    mean = TurbulenceSpec.from_dict({"ti": 0.1, "height": 33.5}).params(None, 9.0)
    assert ds.attrs["alpha_eps"] == mean.alpha_eps  # the theory's tensor: at the mean of the mean speeds
    # the sonic's u variance follows each period's sigma_u (one 600 s record: within its sampling scatter)
    u = ds.sonic_velocity.sel(component="u").values
    ratio = np.nanvar(u[1]) / np.nanvar(u[0])
    assert 4.0 / 2.0 < ratio < 4.0 * 2.0
    assert math.isfinite(float(ds.transfer_ratio.mean()))
