"""HAWC2 boxes as OpenFAST's InflowWind reads them (``convention="openfast"``).

The layout is pinned from OpenFAST's source (modules/inflowwind/src/InflowWind_IO.f90,
``IfW_HAWC_Init`` and ``Grid3D_WriteHAWC``; IfW_FlowField.f90, the Grid3D time shift):
each file holds, plane after plane (``IX = 1..nx``, file plane 0 at the rotor first),
a Fortran ``(nz, ny)`` array whose y runs opposite to InflowWind's Y; u, v, w keep their
signs; u holds fluctuations (InflowWind adds the mean profile).  The tests write files
with a writer of their own that follows ``Grid3D_WriteHAWC`` (loops IX, then IY from
NY down to 1, then a z column), look values up the way InflowWind's Grid3D
interpolation does (``TimeShifted = t + (X0 - X) / U``, ``Y = -YHWid + (iy - 1) dy``),
and require our reader plus our Taylor sampler to return the same wind.
"""

from __future__ import annotations

import numpy as np
import pytest

from cwlidar_sim.beam import sample_los
from cwlidar_sim.turbulence.io import read_hawc2, write_hawc2

NX, NY, NZ = 12, 5, 4
DX, DY, DZ = 2.0, 3.0, 2.5
U = 8.0


def inflowwind_velocity(seed=3):
    """InflowWind's grid array Vel(IC, IY, IZ, IX) (0-based here), random, u without its mean."""
    return np.random.default_rng(seed).standard_normal((3, NY, NZ, NX)).astype(np.float32)


def write_like_openfast(vel_cyzt, base, *, remove_mean=True):
    """Files laid out as OpenFAST's ``Grid3D_WriteHAWC`` writes them (our own code).

    For every time step IX, for IY = NY..1, the z column ``Vel(ic, iy, :, ix)`` as
    little-endian float32; u less its mean over time at the first y column, per height.
    """
    paths = []
    for ic, comp in enumerate("uvw"):
        mean_z = vel_cyzt[0, 0].mean(axis=1) if (ic == 0 and remove_mean) else np.zeros(NZ)
        out = bytearray()
        for ix in range(NX):
            for iy in range(NY - 1, -1, -1):
                out += (vel_cyzt[ic, iy, :, ix] - mean_z).astype("<f4").tobytes()
        path = base.with_name(f"{base.name}_{comp}.bin")
        path.write_bytes(bytes(out))
        paths.append(path)
    return paths


def inflowwind_lookup(vel_cyzt, t, X, iy, iz, *, x0=0.0):
    """Value InflowWind's periodic Grid3D field gives at (t, X) on grid node (iy, iz).

    ``TimeShifted = t + (X0 - X) / U``, time index ``TimeShifted * U / dx`` (0-based),
    taken at grid times so that no interpolation is involved.
    """
    it = (t + (x0 - X) / U) * U / DX
    assert abs(it - round(it)) < 1e-9
    return vel_cyzt[:, iy, iz, int(round(it)) % NX]


def test_openfast_box_is_read_as_inflowwind_presents_it(tmp_path):
    vel = inflowwind_velocity()
    write_like_openfast(vel, tmp_path / "ofbox")
    ds = read_hawc2(tmp_path / "ofbox", (NX, NY, NZ), (DX, DY, DZ), convention="openfast")
    assert ds.attrs["hawc2_convention"] == "openfast"
    mean_z = vel[0, 0].mean(axis=1)
    # InflowWind's rotor at X = 0; ours: the same point is x0 = (NX - 1) dx, and y, z
    # are InflowWind's shifted to start at 0 (Y = y - YHWid).
    x_ours = (NX - 1) * DX
    yhwid = 0.5 * (NY - 1) * DY
    rng = np.random.default_rng(0)
    for _ in range(25):
        it, iy, iz, ix_up = rng.integers(NX), rng.integers(NY), rng.integers(NZ), rng.integers(4)
        t = it * DX / U
        X = -ix_up * DX  # upstream of the rotor
        expect = inflowwind_lookup(vel, t, X, iy, iz).copy()
        expect[0] -= mean_z[iz]
        Y = -yhwid + iy * DY
        vel_tsc, _ = sample_los(ds, origin=(x_ours + X, Y + yhwid, iz * DZ), direction=(1.0, 0.0, 0.0),
                                ranges=[0.0], times=[t], U=U)
        np.testing.assert_allclose(vel_tsc[0, 0], expect, rtol=0, atol=2e-6)


def test_openfast_box_differs_from_the_generators_layout(tmp_path):
    # The default reader (the generators' layout) gives a different field: x and y mirrored.
    vel = inflowwind_velocity()
    write_like_openfast(vel, tmp_path / "ofbox", remove_mean=False)
    of = read_hawc2(tmp_path / "ofbox", (NX, NY, NZ), (DX, DY, DZ), convention="openfast")
    h2 = read_hawc2(tmp_path / "ofbox", (NX, NY, NZ), (DX, DY, DZ))
    for c in "uvw":
        assert not np.array_equal(of[c].values, h2[c].values)
        np.testing.assert_array_equal(of[c].values, h2[c].values[::-1, ::-1])


def test_openfast_writer_matches_the_openfast_layout_and_round_trips(tmp_path):
    vel = inflowwind_velocity(seed=7)
    ref = write_like_openfast(vel, tmp_path / "ref", remove_mean=False)
    # Our Dataset holding the field InflowWind presents: plane Nx-1-j arrives j-th.
    ds = read_hawc2(tmp_path / "ref", (NX, NY, NZ), (DX, DY, DZ), convention="openfast")
    ours = write_hawc2(ds, tmp_path / "ours", convention="openfast", max_chunk_bytes=1)
    for a, b in zip(ref, ours):
        assert a.read_bytes() == b.read_bytes()
    back = read_hawc2(tmp_path / "ours", (NX, NY, NZ), (DX, DY, DZ), convention="openfast")
    for c in "uvw":
        np.testing.assert_array_equal(back[c].values, ds[c].values)


def test_openfast_remove_u_mean_is_scale_method_mean_removal(tmp_path):
    vel = inflowwind_velocity(seed=11)
    vel[0] += 9.0  # a file that holds the mean wind in u
    write_like_openfast(vel, tmp_path / "m", remove_mean=False)
    ds = read_hawc2(tmp_path / "m", (NX, NY, NZ), (DX, DY, DZ), convention="openfast", remove_u_mean=True)
    np.testing.assert_allclose(ds.u.mean("x").values, 0.0, atol=2e-6)
    # per-point mean over x only: the fluctuations are those of the file
    raw = read_hawc2(tmp_path / "m", (NX, NY, NZ), (DX, DY, DZ), convention="openfast")
    np.testing.assert_allclose(ds.u.values, raw.u.values - raw.u.values.mean(axis=0), atol=2e-6)
    np.testing.assert_array_equal(ds.v.values, raw.v.values)


def test_openfast_convention_bad_arguments(tmp_path):
    vel = inflowwind_velocity()
    write_like_openfast(vel, tmp_path / "b")
    args = (tmp_path / "b", (NX, NY, NZ), (DX, DY, DZ))
    with pytest.raises(ValueError, match="convention='inflow'"):
        read_hawc2(*args, convention="inflow")
    with pytest.raises(ValueError, match="reverse_x=False"):
        read_hawc2(*args, convention="openfast", reverse_x=True)
    with pytest.raises(ValueError, match="mmap=False"):
        read_hawc2(*args, convention="openfast", remove_u_mean=True, mmap=True)
    ds = read_hawc2(*args)
    with pytest.raises(ValueError, match="reverse_x=False"):
        write_hawc2(ds, tmp_path / "c", convention="openfast", reverse_x=True)
    with pytest.raises(TypeError, match="remove_u_mean"):
        read_hawc2(*args, remove_u_mean=1)
