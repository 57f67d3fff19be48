"""Small boxes for the full-field file tests (TurbSim .bts and Bladed .wnd): an asymmetric field
whose every axis and component are told apart by value, and a seeded random one."""

import numpy as np
import xarray as xr

NX, NY, NZ = 6, 3, 4
DX, DY, DZ = 2.0, 3.0, 2.5
U = 8.5
ATTRS = {"alpha_eps": 0.08, "length_scale": 33.6, "gamma": 3.9, "seed": 7, "dx": DX, "dy": DY, "dz": DZ}


def asymmetric_box(nx=NX, ny=NY, nz=NZ):
    """u = x, v = y**2, w = z + x*y [m/s]: every axis and component told apart by value."""
    x, y, z = np.meshgrid(np.arange(nx) * DX, np.arange(ny) * DY, np.arange(nz) * DZ, indexing="ij")
    data = {"u": x, "v": y**2, "w": z + x * y}
    return xr.Dataset({c: (("x", "y", "z"), a.astype(np.float32)) for c, a in data.items()},
                      coords={"x": np.arange(nx) * DX, "y": np.arange(ny) * DY, "z": np.arange(nz) * DZ},
                      attrs=dict(ATTRS))


def random_box(seed=0, shape=(16, 5, 4)):
    rng = np.random.default_rng(seed)
    return xr.Dataset({c: (("x", "y", "z"), rng.standard_normal(shape).astype(np.float32)) for c in "uvw"},
                      coords={d: np.arange(n) * s for d, n, s in zip("xyz", shape, (DX, DY, DZ))}, attrs=dict(ATTRS))
