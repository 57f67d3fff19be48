"""The probe volume's registry of weightings: every weighting through the one interface, and a new one added in a test."""

import math

import numpy as np
import pytest
import xarray as xr
from scipy import integrate
from scipy.special import erf

from cwlidar_sim.analysis.rews_theory import beam_transfer
from cwlidar_sim.beam import (
    WEIGHTINGS,
    BeamOptics,
    ProbeVolume,
    Weighting,
    get_weighting,
    register_weighting,
    transfer_exact,
    weight_truncated,
)
from cwlidar_sim.beam.aperture import TruncatedAperture, transfer_aperture
from cwlidar_sim.beam.cells import interval_weight, probe_cells
from cwlidar_sim.beam.probe import ApertureWeighting
from cwlidar_sim.sensors import StaringLidar, measure_staring

OPT = BeamOptics(focus=67.5)  # A2012: z_R = 5.61 m
ZR = OPT.rayleigh_length
BUILT_IN = ("exact", "lorentzian", "aperture", "point")


def test_the_registry_holds_the_built_in_weightings_and_names_the_allowed_ones():
    assert tuple(WEIGHTINGS)[:4] == BUILT_IN
    for name in BUILT_IN:
        w = get_weighting(name)
        assert isinstance(w, Weighting) and w.name == name
    with pytest.raises(ValueError, match=r"weighting='lorentzain' is not allowed \(did you mean 'lorentzian'.*"
                                         r"allowed: 'exact', 'lorentzian', 'aperture', 'point'"):
        get_weighting("lorentzain")
    # every user of a weighting name goes through the registry, with its message
    for call in (lambda: probe_cells(OPT, "gausian"), lambda: weight_truncated(OPT, "gausian"),
                 lambda: interval_weight(OPT, "gausian", 0.0, 1.0), lambda: beam_transfer(67.5, "gausian"),
                 lambda: StaringLidar(weighting="exakt")):
        with pytest.raises(ValueError, match="is not allowed.*allowed: 'exact'"):
            call()
    with pytest.raises(ValueError, match="did you mean 'exact'"):
        StaringLidar(weighting="exakt")
    with pytest.raises(TypeError, match="weighting must be"):
        get_weighting(3)


def test_register_refuses_what_is_not_a_complete_weighting():
    class Half(Weighting):
        def density(self, s, optics):
            return np.zeros(np.shape(s))

    with pytest.raises(TypeError, match=r"does not implement \['fourier', 'primitive'\]"):
        register_weighting("half", Half)
    with pytest.raises(TypeError, match="subclass"):
        register_weighting("half", dict)
    with pytest.raises(ValueError, match="taken by ExactWeighting"):
        register_weighting("exact", type(get_weighting("lorentzian")))
    assert "half" not in WEIGHTINGS


@pytest.mark.parametrize("name", BUILT_IN)
def test_each_weighting_integrates_to_one_over_the_cells(name):
    """Cells' weights plus the tail's are 1; each cell's weight is the integral of the density over it."""
    pv = ProbeVolume(OPT, name)
    c = probe_cells(OPT, name, 20.0, 0.5)
    assert c.weighting == name
    assert c.weight_tail_s.sum() == pytest.approx(1.0, abs=1e-12)
    r = probe_cells(OPT, name, 20.0, 0.5, tail="renormalise")
    assert r.weight_tail_s.sum() == pytest.approx(1.0, abs=1e-12)
    g = probe_cells(OPT, name, 200.0, 0.5, growth=0.1)  # grown cells: the same total
    assert g.weight_tail_s.sum() == pytest.approx(1.0, abs=1e-12)
    if name == "point":
        assert c.tail_weight == 0.0 and np.count_nonzero(c.weight_s) == 1
        assert c.s_s[np.argmax(c.weight_s)] == pytest.approx(0.0, abs=0.25)
        return
    for i in (0, c.n_cells // 2 - 3, c.n_cells // 2, c.n_cells - 1):
        a, b = c.edges[i], c.edges[i + 1]
        ref = integrate.quad(pv.weight, a, b, epsabs=0.0, epsrel=1e-11)[0]
        assert c.weight_s[i] == pytest.approx(ref, rel=1e-7, abs=1e-15)
        assert pv.interval(a, b) == pytest.approx(ref, rel=1e-7, abs=1e-15)


def front_transform(phi, k, r):
    """``int_{-r}^inf phi(s) exp(-i k s) ds`` by QUADPACK (QAWF for k != 0): the transform of the air in front."""
    far = 100.0 * r
    pieces = ((-r, -ZR), (-ZR, ZR), (ZR, 10.0 * r), (10.0 * r, far))
    out = np.empty(k.size, dtype=complex)
    for i, kk in enumerate(k):
        if kk == 0.0:
            out[i] = sum(integrate.quad(phi, a, b, limit=400, epsabs=0.0, epsrel=1e-12)[0]
                         for a, b in pieces + ((far, np.inf),))
            continue
        # finite pieces by QAWO; beyond `far`, s = far + v: exp(-i k s) = exp(-i k far) exp(-i k v), by QAWF
        c, sn = (sum(integrate.quad(phi, a, b, weight=wt, wvar=kk, limit=400, epsabs=1e-14)[0] for a, b in pieces)
                 for wt in ("cos", "sin"))
        tc, ts = (integrate.quad(lambda v: phi(v + far), 0.0, np.inf, weight=wt, wvar=kk, limlst=200)[0]
                  for wt in ("cos", "sin"))
        out[i] = (c - 1j * sn) + np.exp(-1j * kk * far) * (tc - 1j * ts)
    return out


def cut_lorentzian_transfer(k):
    """A2012 Eq. 4 cut at the telescope and renormalised over s > -r: its |transform|^2 by quadrature."""
    front = 0.5 + math.atan(OPT.focus / ZR) / math.pi  # Eq. 4's weight in front of the telescope
    ph = front_transform(lambda s: ZR / (math.pi * (ZR * ZR + s * s)), np.abs(k), OPT.focus) / front
    return np.abs(ph) ** 2


@pytest.mark.parametrize("name", BUILT_IN)
def test_each_weighting_transfer_is_its_analytic_form(name):
    k = np.array([0.0, 0.01, 0.05, 0.2, 0.8, 3.0])
    pv = ProbeVolume(OPT, name)
    analytic = {"lorentzian": cut_lorentzian_transfer(k),  # Eq. 4 with nothing behind the telescope
                "exact": transfer_exact(k, OPT.focus),  # quadrature of the exact weighting's transform
                "aperture": transfer_exact(k, OPT.focus),  # the unclipped aperture is the exact beam
                "point": np.ones(k.size)}[name]
    np.testing.assert_allclose(pv.transfer(k), analytic, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(pv.transfer(-k), pv.transfer(k), rtol=1e-12)  # even
    ph = beam_transfer(OPT.focus, name)(k)  # the theories' transform is the registry's
    np.testing.assert_allclose(np.abs(ph) ** 2, analytic, rtol=1e-6, atol=1e-12)
    assert ph[0] == pytest.approx(1.0, abs=1e-8)  # phi_hat(0) = 1: the weight integrates to 1


#: Every registered weighting, and a clipped aperture (T = 1.3) as an instance.
EVERY = tuple(WEIGHTINGS) + (ApertureWeighting(truncation=1.3),)
#: Foci [m]: CS's 40 m and 100 m (30 deg cone), A2012's, and a long one (the real-line Cauchy's share behind
#: the telescope, arctan(r / z_ap) / pi, is 1.8 %, 4.5 %, 2.6 % and 11 %).
FOCI = (40.0 / math.cos(math.radians(30.0)), 100.0 / math.cos(math.radians(30.0)), 67.5, 300.0)


def _ids(w):
    return w if isinstance(w, str) else repr(w)


@pytest.mark.parametrize("weighting", EVERY, ids=_ids)
def test_every_weighting_holds_its_whole_weight_in_the_air_in_front_of_the_telescope(weighting):
    """No air behind the telescope: no weight there, 1 in front, and the mean-wind tail only the air beyond the span.

    The weight in front is the quadrature of the density (not the primitive the cells use); the cells of a
    span that reaches the telescope leave to the tail exactly the density's integral beyond their far edge.
    """
    for r in FOCI:
        opt = BeamOptics(focus=r)
        pv = ProbeVolume(opt, weighting)
        behind = -r - np.array([1e-9, 0.5, 3.0, 50.0, 1e4])
        np.testing.assert_array_equal(pv.weight(behind), 0.0)
        assert float(pv.primitive(-r) - pv.primitive(-r - 1e4)) == 0.0
        c = probe_cells(opt, weighting, 30.0, 0.5, growth=0.1)
        assert c.edges[0] == -r  # the span reaches the telescope
        far = c.edges[-1]
        if pv.name == "point":
            assert c.tail_weight == 0.0 and c.weight_s.sum() == 1.0
            continue
        zR = opt.rayleigh_length
        front = sum(integrate.quad(pv.weight, a, b, limit=400, epsabs=0.0, epsrel=1e-11)[0]
                    for a, b in ((-r, -zR), (-zR, zR), (zR, far), (far, np.inf)))
        assert front == pytest.approx(1.0, abs=1e-7), r
        beyond = integrate.quad(pv.weight, far, np.inf, limit=400, epsabs=0.0, epsrel=1e-10)[0]
        assert c.tail_weight == pytest.approx(beyond, rel=1e-6), r
        assert c.weight_s.sum() + c.tail_weight == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("weighting", BUILT_IN)
def test_tier1_sees_only_the_air_in_front_of_the_telescope(weighting):
    """A wind uniform in front of the telescope and huge behind it: tier 1 returns the uniform wind.

    The staring lidar (A2012's prototype, 67.5 m) looks along +x from x = 100 m; u = C for x >= 99 m and
    1e6 m/s behind (frozen, a single instant).  The weight in front of the telescope beyond the span sees
    the mean wind U (the mean-wind tail), the rest the total wind U + C: U + C (1 - beyond), with
    ``beyond`` the density's integral beyond the span; the weight behind the telescope belongs to no air.
    """
    n, C, U = 4000, 2.0, 8.0
    x = 0.5 * np.arange(n)
    z = np.zeros(n)
    field = xr.Dataset({"u": ("x", np.where(x >= 99.0, C, 1e6)), "v": ("x", z), "w": ("x", z)}, coords={"x": x})
    lid = StaringLidar(tier="los", weighting=weighting, position=(100.0, 0.0, 0.0), azimuth_deg=0.0, span=30.0)
    r = lid.instrument.focus
    cells = lid.cells()
    assert cells.edges[0] == -r and 100.0 + r + cells.edges[-1] < x[-1]
    pv = ProbeVolume(BeamOptics(r), weighting)
    beyond = 0.0 if weighting == "point" else integrate.quad(pv.weight, cells.edges[-1], np.inf, limit=400)[0]
    rec = measure_staring(field, lid, np.zeros(1), U, None)
    assert rec.vlos_e[0] == pytest.approx(U + C * (1.0 - beyond), rel=0, abs=1e-9)
    # and what lies behind the telescope does not enter at all
    uniform = field.assign(u=("x", np.full(n, C)))
    np.testing.assert_array_equal(measure_staring(uniform, lid, np.zeros(1), U, None).vlos_e, rec.vlos_e)


@pytest.mark.parametrize("weighting", EVERY, ids=_ids)
def test_every_weightings_transform_is_that_of_its_density(weighting):
    """``fourier(k)`` is ``int phi(s) exp(-i k s) ds`` of its own density over the air in front (QUADPACK).

    The theories' transform (:func:`cwlidar_sim.analysis.rews_theory.beam_transfer`) is the same
    function, so a theory and the simulated cells use one weighting.
    """
    k = np.array([0.0, 0.003, 0.03, 0.1, 0.3, 0.8])
    for r in (67.5, 300.0):
        opt = BeamOptics(focus=r)
        pv = ProbeVolume(opt, weighting)
        ph = pv.fourier(k)
        np.testing.assert_allclose(beam_transfer(r, weighting)(k), ph, rtol=0, atol=0)
        if pv.name == "point":
            np.testing.assert_array_equal(ph, 1.0)
            continue
        ref = front_transform(pv.weight, k, r)
        np.testing.assert_allclose(ph, ref, rtol=0, atol=2e-7)


def test_a_parameterised_weighting_is_an_instance_wherever_a_name_is():
    """A clipped aperture (T = 1) through the same calls: its cells and transfer are those of its module."""
    w = ApertureWeighting(truncation=1.0)
    k = np.array([0.02, 0.1, 0.4])
    np.testing.assert_allclose(ProbeVolume(OPT, w).transfer(k), transfer_aperture(k, OPT, TruncatedAperture(1.0)),
                               rtol=1e-12)
    c = probe_cells(OPT, w, 20.0, 0.5)
    assert c.weight_tail_s.sum() == pytest.approx(1.0, abs=1e-12)
    # the clipped pupil has a longer depth of focus: less weight within +-z_R than the Gaussian's
    assert ProbeVolume(OPT, w).interval(-ZR, ZR) < ProbeVolume(OPT, "exact").interval(-ZR, ZR) - 0.02
    with pytest.raises(ValueError, match="truncation"):
        ApertureWeighting(truncation=9.0)


class GaussianGate(Weighting):
    """A pulsed lidar's range gate: a Gaussian of width SIGMA centred OFFSET beyond the nominal range."""

    SIGMA = 3.0
    OFFSET = 4.0

    def density(self, s, optics):
        x = (np.asarray(s, dtype=float) - self.OFFSET) / self.SIGMA
        return np.exp(-0.5 * x * x) / (self.SIGMA * math.sqrt(2.0 * math.pi))

    def primitive(self, s, optics):
        return 0.5 * erf((np.asarray(s, dtype=float) - self.OFFSET) / (self.SIGMA * math.sqrt(2.0)))

    def fourier(self, k, optics):
        k = np.asarray(k, dtype=float)
        return np.exp(-0.5 * (k * self.SIGMA) ** 2 - 1j * k * self.OFFSET)

    def scale(self, optics):
        return self.SIGMA  # the span counts gate widths


def test_a_new_weighting_is_one_class_and_one_registration():
    """A Gaussian range gate registered here runs through the staring lidar's tier 1 unchanged.

    In a wind growing linearly along the beam, u(x) = a + b x, the gate-weighted line-of-sight
    speed is a + b (r + OFFSET): the gate's centroid.
    """
    register_weighting("gaussian_gate", GaussianGate)
    try:
        n = 2000
        x = 0.5 * np.arange(n)
        a, b = 3.0, 0.05
        z = np.zeros(n)
        field = xr.Dataset({"u": ("x", a + b * x), "v": ("x", z), "w": ("x", z)}, coords={"x": x})
        lid = StaringLidar(tier="los", weighting="gaussian_gate", span=6.0, cell_length=0.5)
        cells = lid.cells()
        r = lid.instrument.focus
        # the span is +-6 gate widths about the nominal range; the weight outside it is the Gaussian's tails
        assert (cells.edges[0], cells.edges[-1]) == pytest.approx((-18.0, 18.0), abs=1e-12)
        lo, hi = (-18.0 - GaussianGate.OFFSET) / GaussianGate.SIGMA, (18.0 - GaussianGate.OFFSET) / GaussianGate.SIGMA
        kept = 0.5 * (erf(hi / math.sqrt(2)) - erf(lo / math.sqrt(2)))
        assert cells.truncated_fraction == pytest.approx(1.0 - kept, rel=1e-6)
        lid = lid.replace(tail="renormalise")
        rec = measure_staring(field, lid, np.arange(5) * 0.1, 0.0, None)
        # the span is cut asymmetrically about the gate's centre: renormalised cells hold the centroid
        # of the kept Gaussian, (phi(lo) - phi(hi)) / kept gate widths off its centre
        shift = GaussianGate.SIGMA * (np.exp(-lo * lo / 2) - np.exp(-hi * hi / 2)) / math.sqrt(2 * math.pi) / kept
        np.testing.assert_allclose(rec.vlos_e, a + b * (r + GaussianGate.OFFSET + shift), rtol=0, atol=1e-8)
        assert abs(shift) < 1e-3  # the cut hardly matters: the average is the gate's centroid
        # the theories take it by name too
        q = np.array([0.1, 0.5])
        np.testing.assert_allclose(beam_transfer(r, "gaussian_gate")(q), GaussianGate().fourier(q, None))
    finally:
        del WEIGHTINGS["gaussian_gate"]
    with pytest.raises(ValueError, match="is not allowed"):
        StaringLidar(weighting="gaussian_gate")
