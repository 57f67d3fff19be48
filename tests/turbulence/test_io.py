"""HAWC2 / Mann64bit binary and NetCDF interchange of turbulence fields.

The HAWC2 conventions are pinned against the two peer generators, using
boxes they write with their own writers:

* index for index: our Dataset ``u[ix, iy, iz]`` equals the peer's in-memory
  ``U[ix, iy, iz]`` (no transposition, reversal or sign flip);
* the physical frame of those indices: the box is solenoidal with u, v, w
  positive towards increasing x, y, z index; u and w are anti-correlated;
  and the sheared eddies lean downstream with height, so increasing x index
  is downwind (given z up).  A reader that reversed x would fail the last
  check, which the test shows by reading with ``reverse_x=True``.
"""

from __future__ import annotations

import json
import re
import struct
import tracemalloc

import numpy as np
import pytest
import xarray as xr

from cwlidar_sim.turbulence.io import hawc2_paths, read_hawc2, read_netcdf, write_hawc2, write_netcdf

ATTRS = dict(alpha_eps=0.08, length_scale=33.6, gamma=3.9, seed=1234)


def synthetic_field(shape, spacing=(2.0, 3.0, 4.0), seed=0, dtype=np.float32):
    """A seeded random u, v, w field on dims x, (y, (z)) with generator-like attrs."""
    dims = ("x", "y", "z")[: len(shape)]
    rng = np.random.default_rng(seed)
    data = {c: (dims, rng.standard_normal(shape).astype(dtype)) for c in "uvw"}
    coords = {d: np.arange(n) * s for d, n, s in zip(dims, shape, spacing)}
    attrs = dict(ATTRS, **{f"d{d}": s for d, s in zip(dims, spacing)})
    return xr.Dataset(data, coords=coords, attrs=attrs)


# ---------------------------------------------------------------------------
# HAWC2: our own writer and reader
# ---------------------------------------------------------------------------
def test_hawc2_round_trip_is_exact(tmp_path):
    ds = synthetic_field((6, 5, 4))
    paths = write_hawc2(ds, tmp_path / "box")
    assert [p.name for p in paths] == ["box_u.bin", "box_v.bin", "box_w.bin"]
    back = read_hawc2(tmp_path / "box", (6, 5, 4), (2.0, 3.0, 4.0), attrs=ds.attrs)
    assert back.u.dims == ("x", "y", "z")
    for c in "uvw":
        assert back[c].dtype == np.float32
        np.testing.assert_array_equal(back[c].values, ds[c].values)
        assert back[c].attrs["units"] == "m s-1"
    for d in "xyz":
        np.testing.assert_array_equal(back[d].values, ds[d].values)
        assert back[d].attrs["units"] == "m"
    assert back.attrs == ds.attrs


def test_hawc2_file_layout_little_endian_z_fastest(tmp_path):
    nx, ny, nz = 4, 3, 5
    i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    ds = synthetic_field((nx, ny, nz))
    ds["u"] = (("x", "y", "z"), (100 * i + 10 * j + k).astype(np.float32))
    ds["u"][0, 0, 0] = 1.5
    pu, pv, pw = write_hawc2(ds, tmp_path / "box")
    for p in (pu, pv, pw):
        assert p.stat().st_size == nx * ny * nz * 4  # Nx*Ny*Nz float32, no header
    raw = pu.read_bytes()
    assert raw[:4] == struct.pack("<f", 1.5)  # little-endian float32
    flat = np.frombuffer(raw, dtype="<f4")
    assert flat[1] == ds.u.values[0, 0, 1]  # z runs fastest,
    assert flat[nz] == ds.u.values[0, 1, 0]  # then y,
    assert flat[ny * nz] == ds.u.values[1, 0, 0]  # x slowest
    np.testing.assert_array_equal(flat, ds.u.values.ravel(order="C"))


def test_hawc2_writes_views_other_dim_orders_and_float64(tmp_path):
    rng = np.random.default_rng(7)
    big = rng.standard_normal((7, 6, 5, 3))  # float64, component last: strided views
    ds = xr.Dataset({c: (("x", "y", "z"), big[..., n]) for n, c in enumerate("uvw")})
    assert not ds.u.values.flags.c_contiguous
    write_hawc2(ds.transpose("z", "x", "y"), tmp_path / "box.bin", max_chunk_bytes=1)
    back = read_hawc2(tmp_path / "box.bin", (7, 6, 5), (1.0, 1.0, 1.0))
    for n, c in enumerate("uvw"):
        np.testing.assert_array_equal(back[c].values, big[..., n].astype(np.float32))


def test_hawc2_chunk_size_does_not_change_the_file(tmp_path):
    ds = synthetic_field((9, 4, 3))
    a = write_hawc2(ds, tmp_path / "a", max_chunk_bytes=1)  # one x plane per write
    b = write_hawc2(ds, tmp_path / "b")  # whole component in one slab
    for pa, pb in zip(a, b):
        assert pa.read_bytes() == pb.read_bytes()


def test_hawc2_write_holds_less_than_one_component(tmp_path):
    # The generator hands over non-contiguous views; the writer must convert
    # slab by slab.  numpy reports its buffers to tracemalloc, so the peak of
    # new allocations during the write bounds the writer's temporaries.
    rng = np.random.default_rng(3)
    big = rng.standard_normal((64, 64, 64, 3)).astype(np.float32)
    ds = xr.Dataset({c: (("x", "y", "z"), big[..., n]) for n, c in enumerate("uvw")})
    component_bytes = 64**3 * 4
    chunk = 64 * 64 * 4 * 4  # four x planes
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        before, _ = tracemalloc.get_traced_memory()
        write_hawc2(ds, tmp_path / "box", max_chunk_bytes=chunk)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # A slab, its isfinite mask (1/4 of it) and small objects: well under
    # half a component (16 slabs); a whole-component copy would be 1 MiB.
    assert peak - before < component_bytes / 2
    back = read_hawc2(tmp_path / "box", (64, 64, 64), (1.0, 1.0, 1.0))
    np.testing.assert_array_equal(back.w.values, big[..., 2])


def test_hawc2_reverse_x(tmp_path):
    ds = synthetic_field((5, 3, 2))
    pu, _, _ = write_hawc2(ds, tmp_path / "rev", reverse_x=True, max_chunk_bytes=1)
    in_file = np.fromfile(pu, dtype="<f4").reshape(5, 3, 2)
    np.testing.assert_array_equal(in_file, ds.u.values[::-1])  # file plane j = our plane Nx-1-j
    back = read_hawc2(tmp_path / "rev", (5, 3, 2), (2.0, 3.0, 4.0), reverse_x=True)
    for c in "uvw":
        np.testing.assert_array_equal(back[c].values, ds[c].values)
    np.testing.assert_array_equal(back.x.values, ds.x.values)


def test_hawc2_memmap_read(tmp_path):
    ds = synthetic_field((6, 5, 4))
    write_hawc2(ds, tmp_path / "box")
    back = read_hawc2(tmp_path / "box", (6, 5, 4), (2.0, 3.0, 4.0), mmap=True)
    assert not back.u.data.flags.writeable  # read-only map of the file, not a copy
    for c in "uvw":
        np.testing.assert_array_equal(back[c].values, ds[c].values)
    assert float(back.v[3, 2, 1]) == float(ds.v[3, 2, 1])


def test_hawc2_explicit_paths_and_names(tmp_path):
    assert [p.name for p in hawc2_paths("out/box.bin")] == ["box_u.bin", "box_v.bin", "box_w.bin"]
    assert [p.name for p in hawc2_paths("turb_ae0.08")] == ["turb_ae0.08_u.bin", "turb_ae0.08_v.bin",
                                                          "turb_ae0.08_w.bin"]
    ds = synthetic_field((3, 2, 2))
    paths = [tmp_path / f"s1{c}.turb" for c in "uvw"]
    write_hawc2(ds, paths)
    back = read_hawc2([str(p) for p in paths], (3, 2, 2), (1.0, 1.0, 1.0))
    np.testing.assert_array_equal(back.w.values, ds.w.values)


# ---------------------------------------------------------------------------
# HAWC2: bad input
# ---------------------------------------------------------------------------
def test_hawc2_wrong_shape_names_expected_and_actual_size(tmp_path):
    write_hawc2(synthetic_field((6, 5, 4)), tmp_path / "box", sidecar=False)  # no sidecar to say the shape
    with pytest.raises(ValueError, match=r"box_u\.bin") as err:
        read_hawc2(tmp_path / "box", (6, 5, 5), (1.0, 1.0, 1.0))
    msg = str(err.value)
    assert re.search(r"\b480 bytes\b", msg) and re.search(r"\b600 bytes\b", msg), msg


def test_hawc2_missing_file(tmp_path):
    write_hawc2(synthetic_field((3, 2, 2)), tmp_path / "box", sidecar=False)
    (tmp_path / "box_v.bin").unlink()
    with pytest.raises(FileNotFoundError, match=r"component v.*box_v\.bin"):
        read_hawc2(tmp_path / "box", (3, 2, 2), (1.0, 1.0, 1.0))


@pytest.mark.parametrize(
    "shape, spacing, exc, match",
    [
        ((0, 2, 2), (1, 1, 1), ValueError, r"shape\[0\]=0"),
        ((3, 2), (1, 1, 1), ValueError, r"shape must have 3 values"),
        ((3.0, 2, 2), (1, 1, 1), TypeError, r"shape\[0\]"),
        ((3, 2, 2), (1, 0.0, 1), ValueError, r"spacing\[1\]=0.0"),
        ((3, 2, 2), (1, 1, float("nan")), ValueError, r"spacing\[2\]"),
        ((3, 2, 2), "abc", TypeError, r"spacing must be a sequence of 3 values"),
    ],
)
def test_hawc2_read_bad_grid(tmp_path, shape, spacing, exc, match):
    write_hawc2(synthetic_field((3, 2, 2)), tmp_path / "box")
    with pytest.raises(exc, match=match):
        read_hawc2(tmp_path / "box", shape, spacing)


def test_hawc2_bad_paths(tmp_path):
    with pytest.raises(ValueError, match="3 paths"):
        hawc2_paths(["a", "b"])
    with pytest.raises(ValueError, match="3 different files"):
        hawc2_paths(["a", "a", "b"])
    with pytest.raises(TypeError, match="base_or_paths"):
        hawc2_paths(3)
    # a missing folder is refused before anything is written (a ValueError, as bad input; was FileNotFoundError)
    with pytest.raises(ValueError, match=r"folder .*no_such_dir.* does not exist"):
        write_hawc2(synthetic_field((3, 2, 2)), tmp_path / "no_such_dir" / "box")


def test_hawc2_write_rejects_bad_fields(tmp_path):
    with pytest.raises(TypeError, match="xarray.Dataset"):
        write_hawc2({"u": np.zeros((2, 2, 2))}, tmp_path / "box")
    with pytest.raises(ValueError, match=r"lacks velocity component\(s\) \['w'\]"):
        write_hawc2(synthetic_field((3, 2, 2)).drop_vars("w"), tmp_path / "box")
    with pytest.raises(ValueError, match=r"dims \('x', 'y'\); allowed: \('x', 'y', 'z'\)"):
        write_hawc2(synthetic_field((3, 2)), tmp_path / "box")
    with pytest.raises(TypeError, match="reverse_x"):
        write_hawc2(synthetic_field((3, 2, 2)), tmp_path / "box", reverse_x=1)
    with pytest.raises(ValueError, match="max_chunk_bytes"):
        write_hawc2(synthetic_field((3, 2, 2)), tmp_path / "box", max_chunk_bytes=0)
    assert list(tmp_path.iterdir()) == []


def test_hawc2_non_finite_value_leaves_no_file(tmp_path):
    ds = synthetic_field((4, 3, 2))
    ds["w"][2, 1, 0] = np.nan
    with pytest.raises(ValueError, match=r"box\['w'\] has a non-finite value .* \[x=2, y=1, z=0\]"):
        write_hawc2(ds, tmp_path / "box", max_chunk_bytes=1)
    with pytest.raises(ValueError, match=r"\[x=2, y=1, z=0\]"):
        write_hawc2(ds, tmp_path / "box", reverse_x=True, max_chunk_bytes=1)
    ds["w"][2, 1, 0] = 0.0
    ds["v"] = ds["v"].astype(np.float64)
    ds["v"][0, 0, 0] = 1e39  # overflows float32
    with pytest.raises(ValueError, match=r"box\['v'\].*\[x=0, y=0, z=0\]"):
        write_hawc2(ds, tmp_path / "box")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------
# HAWC2: the peers' files and frame
# ---------------------------------------------------------------------------
PEER_SHAPE = (64, 16, 16)
PEER_SPACING = (2.0, 3.0, 4.0)
PEER_L, PEER_GAMMA, PEER_SEED = 33.6, 3.9, 5


@pytest.fixture(scope="module")
def mannrs_box(tmp_path_factory):
    mannrs = pytest.importorskip("mannrs", reason="peer generator mannrs not installed (pip install '.[test]')")
    (nx, ny, nz), (dx, dy, dz) = PEER_SHAPE, PEER_SPACING
    # Periodic in all directions, so that the spectral checks below see the
    # field the tensor was sampled for.  mannrs' get_axes() is
    # linspace(0, Lx, Nx) (endpoint included); the periodic grid spacing is Lx/Nx.
    stencil = mannrs.Stencil(L=PEER_L, gamma=PEER_GAMMA, Lx=nx * dx, Ly=ny * dy, Lz=nz * dz, Nx=nx, Ny=ny, Nz=nz,
                             aperiodic_x=False, aperiodic_y=False, aperiodic_z=False)
    wf = stencil.build(parallel=False).turbulence(1.0, PEER_SEED, parallel=False)
    folder = tmp_path_factory.mktemp("mannrs")
    wf.write(folder / "box.bin", format="HAWC2")  # the peer's own HAWC2 writer: box_u.bin, ...
    return folder / "box.bin", (wf.U, wf.V, wf.W)


@pytest.fixture(scope="module")
def hipersim_box(tmp_path_factory):
    hipersim = pytest.importorskip("hipersim", reason="peer generator hipersim not installed (pip install '.[test]')")
    field = hipersim.MannTurbulenceField.generate(
        alphaepsilon=1.0, L=PEER_L, Gamma=PEER_GAMMA, Nxyz=PEER_SHAPE, dxyz=PEER_SPACING, seed=PEER_SEED,
        double_xyz=(False, False, False), n_cpu=1)
    folder = tmp_path_factory.mktemp("hipersim")
    try:
        field.to_hawc2(folder=str(folder), basename="hip_")  # writes hip_u.turb, hip_v.turb, hip_w.turb
    except ImportError:
        pass  # the files are written before the optional htc section (needs wetb) is built
    paths = [folder / f"hip_{c}.turb" for c in "uvw"]
    return paths, tuple(field.uvw)


@pytest.fixture(params=["mannrs", "hipersim"])
def peer_box(request):
    return request.getfixturevalue(f"{request.param}_box")


def test_peer_hawc2_file_reads_index_for_index(peer_box):
    source, arrays = peer_box
    for p in hawc2_paths(source):
        assert p.stat().st_size == np.prod(PEER_SHAPE) * 4
    ds = read_hawc2(source, PEER_SHAPE, PEER_SPACING)
    for c, peer in zip("uvw", arrays):
        assert peer.shape == PEER_SHAPE
        # Exact: the same float32 values at the same [ix, iy, iz], no flip.
        np.testing.assert_array_equal(ds[c].values, np.asarray(peer, dtype=np.float32))
    # Our writer reproduces the peer's files byte for byte.
    ours = write_hawc2(ds, hawc2_paths(source)[0].parent / "ours")
    for p_peer, p_ours in zip(hawc2_paths(source), ours):
        assert p_peer.read_bytes() == p_ours.read_bytes()


def _half_space_modes(a_xyz):
    """Fourier coefficients of the independent modes k1 > 0 (no Nyquist planes), and k."""
    n1, n2, n3 = a_xyz.shape
    spec = np.fft.fftn(a_xyz.astype(np.float64))
    i1 = np.arange(1, (n1 - 1) // 2 + 1)
    i2 = np.array([i for i in range(n2) if 2 * i != n2])
    i3 = np.array([i for i in range(n3) if 2 * i != n3])
    return spec[np.ix_(i1, i2, i3)], (i1, i2, i3)


def _divergence_residual(u, v, w, spacing, signs=(1, 1, 1)):
    """|sum_j s_j k_j u_j| / sqrt(sum_j |k_j u_j|^2), summed over modes."""
    k = [2 * np.pi * np.fft.fftfreq(n, d) for n, d in zip(u.shape, spacing)]
    terms = []
    for s, a, kj, axis in zip(signs, (u, v, w), k, range(3)):
        spec, idx = _half_space_modes(a)
        shape = [1, 1, 1]
        shape[axis] = -1
        terms.append(s * kj[idx[axis]].reshape(shape) * spec)
    div = np.sum(np.abs(sum(terms)) ** 2)
    return np.sqrt(div / sum(np.sum(np.abs(t) ** 2) for t in terms))


def _lean_z(a):
    """z-score of the energy excess at k1*k3 < 0 over its mirror k1*k3 > 0.

    For each independent mode (k1>0, k2, k3>0) r = P(k1,k2,-k3) / (P(k1,k2,-k3) + P(k1,k2,k3))
    with P the periodogram.  With no lean the two are independent exponentials
    of equal mean, so r is uniform on (0, 1): mean 1/2, variance 1/12; M such
    pairs give z = (mean r - 1/2) sqrt(12 M), standard normal.
    """
    n1, n2, n3 = a.shape
    p = np.abs(np.fft.fftn(a.astype(np.float64))) ** 2
    i1 = np.arange(1, (n1 - 1) // 2 + 1)
    i2 = np.array([i for i in range(n2) if 2 * i != n2])
    i3 = np.arange(1, (n3 - 1) // 2 + 1)
    pos = p[np.ix_(i1, i2, i3)]
    neg = p[np.ix_(i1, i2, (-i3) % n3)]
    r = neg / (neg + pos)
    return (r.mean() - 0.5) * np.sqrt(12 * r.size)


def _uw_z(u, w):
    """z-score of the mean cosine of the u-w phase difference over independent modes.

    With u and w uncorrelated the phase difference of each mode is uniform,
    so cos has mean 0 and variance 1/2; M modes give
    z = sum(cos) / sqrt(M / 2), standard normal.  A negative co-spectrum
    (negative u-w covariance) pulls the phases towards pi: z < 0.
    """
    su, _ = _half_space_modes(u)
    sw, _ = _half_space_modes(w)
    cos = np.real(su * np.conj(sw)) / (np.abs(su) * np.abs(sw))
    return cos.sum() / np.sqrt(cos.size / 2)


def test_peer_hawc2_frame_is_right_handed_and_x_downwind(peer_box):
    source, _ = peer_box
    ds = read_hawc2(source, PEER_SHAPE, PEER_SPACING)
    u, v, w = (ds[c].values for c in "uvw")

    # (1) Solenoidal with u, v, w positive towards increasing x, y, z index.
    # An exactly divergence-free field gives 0; the peers deviate only in the
    # modes their finite-cell correction and Hermitian fix-ups touch, a
    # residual well below 1.  A reversed axis or a flipped component turns
    # that term's cancellation into doubling: 2 |k_j u_j| / |k u|, of order 1
    # since no term dominates.  So the convention read must beat every single
    # flip by at least a factor of 2.
    as_read = _divergence_residual(u, v, w, PEER_SPACING)
    flipped = [_divergence_residual(u, v, w, PEER_SPACING, s) for s in ((-1, 1, 1), (1, -1, 1), (1, 1, -1))]
    assert as_read < 0.5 * min(flipped), (as_read, flipped)

    # (2) Shear stress: u and w anti-correlated.  Null (no correlation) gives
    # a standard-normal z; 5 sigma rejects it.
    assert _uw_z(u, w) < -5.0

    # (3) Mann's distortion k3 = k30 - beta*k1 (speed increasing with z)
    # puts more energy at k1*k3 < 0: eddies lean downstream with height.  A
    # 5-sigma excess in both u and w, with x read as written, shows that
    # increasing x index is downwind (z up, per hipersim's to_xarray doc).
    assert _lean_z(u) > 5.0
    assert _lean_z(w) > 5.0
    # The same files read as reversed (what a reader convecting file plane 0
    # to the rotor first does) lean upstream: the check can tell.
    rev = read_hawc2(source, PEER_SHAPE, PEER_SPACING, reverse_x=True)
    assert _lean_z(rev.u.values) < -5.0


# ---------------------------------------------------------------------------
# NetCDF
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("shape", [(6, 5, 4), (7, 3), (11,)], ids=["box", "plane", "line"])
def test_netcdf_round_trip_exact(tmp_path, shape):
    ds = synthetic_field(shape)
    if len(shape) == 2:
        ds.attrs["z"] = 80.0  # nominal height of a plane
    before = ds.copy(deep=True)
    path = write_netcdf(ds, tmp_path / "field.nc")
    back = read_netcdf(path)
    assert back.u.dims == ds.u.dims
    for c in "uvw":
        assert back[c].dtype == np.float32
        np.testing.assert_array_equal(back[c].values, ds[c].values)
        assert back[c].attrs["units"] == "m s-1"
        assert back[c].attrs["long_name"]
        assert "_FillValue" not in back[c].attrs and "_FillValue" not in back[c].encoding
    for d in ds.u.dims:
        np.testing.assert_array_equal(back[d].values, ds[d].values)
        assert back[d].attrs["units"] == "m"
    assert back.attrs == ds.attrs
    xr.testing.assert_identical(ds, before)  # the caller's Dataset is not annotated in place


def test_netcdf_keeps_float64_and_existing_attributes(tmp_path):
    ds = synthetic_field((4, 3), dtype=np.float64)
    ds["u"].attrs["units"] = "cm s-1"
    back = read_netcdf(write_netcdf(ds, tmp_path / "f.nc"))
    assert back.u.dtype == np.float64
    assert back.u.attrs["units"] == "cm s-1"  # not overwritten
    np.testing.assert_array_equal(back.v.values, ds.v.values)


def test_netcdf_attribute_types_round_trip(tmp_path):
    ds = synthetic_field((5,))
    special = dict(correction="cell", hf_compensation=True, sigma_u_target=None, entropy=2**70,
                   spacing=[2.0, 3.0, 4.0], settings={"threads": 2, "names": ["a", "b"]},
                   count=np.int64(7), scale=np.float32(0.5))
    ds.attrs.update(special)
    back = read_netcdf(write_netcdf(ds, tmp_path / "f.nc"))
    assert back.attrs["correction"] == "cell"
    assert back.attrs["hf_compensation"] is True
    assert back.attrs["sigma_u_target"] is None
    assert back.attrs["entropy"] == 2**70
    np.testing.assert_array_equal(back.attrs["spacing"], [2.0, 3.0, 4.0])
    assert back.attrs["settings"] == {"threads": 2, "names": ["a", "b"]}
    assert back.attrs["count"] == 7 and back.attrs["scale"] == 0.5
    assert "cwlidar_sim_json_attrs" not in back.attrs
    for key, value in ATTRS.items():
        assert back.attrs[key] == value


def test_netcdf_opens_with_plain_xarray(tmp_path):
    ds = synthetic_field((6, 5, 4))
    path = write_netcdf(ds, tmp_path / "field.nc")
    with xr.open_dataset(path) as plain:
        assert plain.u.dtype == np.float32
        np.testing.assert_array_equal(plain.w.values, ds.w.values)
        assert plain.u.attrs["units"] == "m s-1" and plain.x.attrs["units"] == "m"
        assert plain.attrs["alpha_eps"] == ATTRS["alpha_eps"]
        assert plain.attrs["seed"] == ATTRS["seed"]


def test_netcdf_lazy_read(tmp_path):
    ds = synthetic_field((8, 5, 4))
    path = write_netcdf(ds, tmp_path / "field.nc")
    lazy = read_netcdf(path, lazy=True)
    try:
        assert not lazy.u.variable._in_memory  # nothing read yet
        np.testing.assert_array_equal(lazy.u[2:4].values, ds.u.values[2:4])
        assert lazy.attrs == ds.attrs
    finally:
        lazy.close()


def test_netcdf_bad_input(tmp_path):
    with pytest.raises(TypeError, match="xarray.Dataset"):
        write_netcdf(np.zeros(3), tmp_path / "f.nc")
    with pytest.raises(ValueError, match=r"dims \('t',\)"):
        write_netcdf(xr.Dataset({c: (("t",), np.zeros(3)) for c in "uvw"}), tmp_path / "f.nc")
    with pytest.raises(ValueError, match=r"\['v'\]"):
        write_netcdf(synthetic_field((3,)).drop_vars("v"), tmp_path / "f.nc")
    bad = synthetic_field((3,))
    bad.attrs["params"] = object()
    with pytest.raises(TypeError, match=r"field.attrs\['params'\]"):
        write_netcdf(bad, tmp_path / "f.nc")
    with pytest.raises(TypeError, match="path"):
        write_netcdf(synthetic_field((3,)), 5)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(FileNotFoundError, match="nope.nc"):
        read_netcdf(tmp_path / "nope.nc")
    xr.Dataset({"u": (("x",), np.zeros(3))}).to_netcdf(tmp_path / "only_u.nc", engine="h5netcdf")
    with pytest.raises(ValueError, match=r"lacks velocity component\(s\) \['v', 'w'\]"):
        read_netcdf(tmp_path / "only_u.nc")


# ---------------------------------------------------------------------------
# HAWC2: the sidecar (BASE.json) and HTC snippet (BASE.htc)
# ---------------------------------------------------------------------------
def asymmetric_field(shape=(5, 3, 4), spacing=(2.0, 3.0, 4.0)):
    """u = x, v = y**2, w = z + x*y [m/s]: every axis and component told apart by value."""
    x, y, z = np.meshgrid(*(np.arange(n) * s for n, s in zip(shape, spacing)), indexing="ij")
    ds = synthetic_field(shape, spacing)
    for c, a in zip("uvw", (x, y**2, z + x * y)):
        ds[c] = (("x", "y", "z"), a.astype(np.float32))
    return ds


def test_hawc2_sidecar_round_trip_without_shape_or_spacing(tmp_path):
    from cwlidar_sim import __version__
    from cwlidar_sim.turbulence import hawc2_sidecar_paths

    ds = synthetic_field((6, 5, 4))
    ds.attrs["hf_compensation"] = 1
    write_hawc2(ds, tmp_path / "box.bin")
    side, htc = hawc2_sidecar_paths(tmp_path / "box.bin")
    assert (side.name, htc.name) == ("box.json", "box.htc")
    doc = json.loads(side.read_text())
    assert doc["shape"] == [6, 5, 4] and doc["spacing"] == [2.0, 3.0, 4.0]
    assert doc["mann_parameters"] == {"alpha_eps": 0.08, "length_scale": 33.6, "gamma": 3.9} and doc["seed"] == 1234
    assert doc["convention"] == "hawc2" and doc["reverse_x"] is False
    assert doc["cwlidar_sim_version"] == __version__ and doc["files"]["u"] == "box_u.bin"
    back = read_hawc2(tmp_path / "box")  # shape, spacing and attributes from the sidecar
    for c in "uvw":
        np.testing.assert_array_equal(back[c].values, ds[c].values)
    for d in "xyz":
        np.testing.assert_array_equal(back[d].values, ds[d].values)
    assert back.attrs == ds.attrs
    assert hawc2_sidecar_paths([tmp_path / "a", tmp_path / "b", tmp_path / "c"]) is None


@pytest.mark.parametrize("convention, reverse_x, in_file", [
    ("hawc2", False, lambda a: a),
    ("hawc2", True, lambda a: a[::-1]),  # file plane j = our plane Nx-1-j
    ("openfast", False, lambda a: a[::-1, ::-1]),  # and file y j = our Ny-1-j
])
def test_hawc2_orientation_of_a_known_asymmetric_field(tmp_path, convention, reverse_x, in_file):
    ds = asymmetric_field()
    paths = write_hawc2(ds, tmp_path / "a", convention=convention, reverse_x=reverse_x)
    nx, ny, nz = 5, 3, 4
    for c, p in zip("uvw", paths):
        raw = np.fromfile(p, dtype="<f4").reshape(nx, ny, nz)
        np.testing.assert_array_equal(raw, in_file(ds[c].values))
    u = np.fromfile(paths[0], dtype="<f4").reshape(nx, ny, nz)
    assert u[0, 0, 0] == (0.0 if convention == "hawc2" and not reverse_x else 8.0)  # x of file plane 0
    v = np.fromfile(paths[1], dtype="<f4").reshape(nx, ny, nz)
    assert v[0, 0, 0] == (36.0 if convention == "openfast" else 0.0)  # y**2 of file column 0
    # the sidecar says how the planes lie: reading it needs no argument
    back = read_hawc2(tmp_path / "a")
    for c in "uvw":
        np.testing.assert_array_equal(back[c].values, ds[c].values)
    # given, the arguments override it: what a reader of the other layout sees
    other = read_hawc2(tmp_path / "a", convention="hawc2", reverse_x=False)
    np.testing.assert_array_equal(other.u.values, in_file(ds.u.values))


def test_hawc2_sidecar_mismatch_missing_or_malformed_is_refused(tmp_path):
    write_hawc2(synthetic_field((6, 5, 4)), tmp_path / "box")
    mismatch = r"shape=\(6, 5, 5\) differs from shape \(6, 5, 4\) in the sidecar .*box\.json"
    with pytest.raises(ValueError, match=mismatch):
        read_hawc2(tmp_path / "box", (6, 5, 5), (2.0, 3.0, 4.0))
    with pytest.raises(ValueError, match=r"spacing=\(2\.0, 3\.0, 5\.0\) differs from spacing \(2\.0, 3\.0, 4\.0\)"):
        read_hawc2(tmp_path / "box", spacing=(2.0, 3.0, 5.0))
    assert read_hawc2(tmp_path / "box", (6, 5, 4), (2.0, 3.0, 4.0)).u.shape == (6, 5, 4)  # agreeing: fine
    side = tmp_path / "box.json"
    text = side.read_text()
    side.write_text(text[:-20])
    with pytest.raises(ValueError, match=r"HAWC2 sidecar .*box\.json.* is not valid JSON") as err:
        read_hawc2(tmp_path / "box")
    assert "\n" not in str(err.value)
    side.write_text(text.replace('"format": "cwlidar_sim', '"format": "other'))
    with pytest.raises(ValueError, match=r"box\.json.* is not a cwlidar_sim HAWC2 sidecar"):
        read_hawc2(tmp_path / "box")
    side.write_text(json.dumps(dict(json.loads(text), shape=[6, 5])))
    with pytest.raises(ValueError, match=r"box\.json.*'shape' is \[6, 5\]"):
        read_hawc2(tmp_path / "box")
    side.unlink()
    with pytest.raises(ValueError, match=r"shape of the HAWC2 box is needed: no sidecar .*box\.json"):
        read_hawc2(tmp_path / "box")
    write_hawc2(synthetic_field((6, 5, 4)), tmp_path / "n", sidecar=False)
    assert not (tmp_path / "n.json").exists() and not (tmp_path / "n.htc").exists()


def test_hawc2_htc_snippet_as_the_hawc2_toolbox_reads_it(tmp_path):
    htc_file = pytest.importorskip("wetb.hawc2.htc_file", reason="the DTU Wind Energy toolbox (wetb, with hipersim) "
                                   "is not installed (pip install '.[test]')")
    ds = synthetic_field((16, 5, 4), spacing=(1.5, 3.0, 4.0))
    write_hawc2(ds, tmp_path / "turb")
    text = (tmp_path / "turb.htc").read_text()
    main = tmp_path / "main.htc"
    main.write_text("begin wind ;\n  turb_format 1 ;\n" + text + "end wind ;\nexit ;\n")
    mann = htc_file.HTCFile(str(main)).wind.mann
    assert [mann[f"filename_{c}"].values[0] for c in "uvw"] == [f"./turb_{c}.bin" for c in "uvw"]
    assert [mann[f"box_dim_{c}"].values for c in "uvw"] == [[16, 1.5], [5, 3.0], [4, 4.0]]
    assert mann.dont_scale.values == [1]
    assert "create_turb_parameters" not in mann  # a comment only: HAWC2 must not generate a box of its own
    assert "create_turb_parameters 33.6 0.08 3.9 1234" in text
