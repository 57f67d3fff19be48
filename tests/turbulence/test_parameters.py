import math

import pytest

from cwlidar_sim.turbulence import MannParameters


def test_round_trip_and_frozen():
    p = MannParameters(alpha_eps=0.8, length_scale=33.6, gamma=3.9)
    assert MannParameters.from_dict(p.as_dict()) == p
    with pytest.raises(Exception):
        p.gamma = 1.0


@pytest.mark.parametrize(
    "kw, field",
    [
        (dict(alpha_eps=1.0, length_scale=-5.0, gamma=3.9), "length_scale"),
        (dict(alpha_eps=1.0, length_scale=0.0, gamma=3.9), "length_scale"),
        (dict(alpha_eps=math.nan, length_scale=30.0, gamma=3.9), "alpha_eps"),
        (dict(alpha_eps=0.0, length_scale=30.0, gamma=3.9), "alpha_eps"),
        (dict(alpha_eps=1.0, length_scale=30.0, gamma=-0.1), "gamma"),
        (dict(alpha_eps=1.0, length_scale=math.inf, gamma=1.0), "length_scale"),
    ],
)
def test_bad_values_name_field_and_range(kw, field):
    with pytest.raises(ValueError, match=field) as e:
        MannParameters(**kw)
    assert "allowed" in str(e.value)


def test_bad_type():
    with pytest.raises(TypeError, match="gamma"):
        MannParameters(1.0, 30.0, "3.9")


def test_unknown_and_missing_keys_rejected_by_name():
    with pytest.raises(ValueError, match="lenght_scale"):
        MannParameters.from_dict(dict(alpha_eps=1.0, lenght_scale=30.0, gamma=3.9))
    with pytest.raises(ValueError, match="gamma"):
        MannParameters.from_dict(dict(alpha_eps=1.0, length_scale=30.0))


def test_iec_defaults():
    # IEC 61400-1 Annex C: L = 0.8 Lambda_1, Lambda_1 = 0.7 z below 60 m,
    # 42 m above; sigma_iso = 0.55 sigma_u.
    p = MannParameters.iec(hub_height=90.0, sigma_u=2.0)
    assert p.length_scale == pytest.approx(33.6)
    assert p.gamma == 3.9
    assert math.sqrt(p.isotropic_variance) == pytest.approx(0.55 * 2.0, rel=1e-12)
    assert MannParameters.iec(hub_height=40.0, sigma_u=1.0).length_scale == pytest.approx(0.8 * 0.7 * 40.0)
    with pytest.raises(ValueError, match="hub_height"):
        MannParameters.iec(hub_height=-1.0, sigma_u=1.0)
