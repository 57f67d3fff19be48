"""Mann (1994, 1998) spectral-tensor turbulence: tensor, spectra, fields, files."""

from .io import hawc2_paths, hawc2_sidecar_paths, read_hawc2, read_netcdf, write_hawc2, write_netcdf
from .io_bladed import read_bladed, write_bladed
from .io_turbsim import read_turbsim, write_turbsim
from .box import BoxExpectation, BoxGenerator, expected_box_covariance, generate_box
from .fields import generate_line, generate_plane, line_spectra, plane_spectra
from .grids import common_extent, grid_for_extent
from .parameters import MannParameters
from .spectra import Covariances, covariances, isotropic_spectra, one_point_spectra, subcell_variance
from .tensor import amplitude_matrix, eddy_lifetime, energy_spectrum, spectral_tensor

__all__ = [
    "MannParameters",
    "BoxExpectation",
    "BoxGenerator",
    "Covariances",
    "amplitude_matrix",
    "covariances",
    "eddy_lifetime",
    "energy_spectrum",
    "expected_box_covariance",
    "generate_box",
    "generate_line",
    "generate_plane",
    "grid_for_extent",
    "common_extent",
    "line_spectra",
    "plane_spectra",
    "isotropic_spectra",
    "one_point_spectra",
    "spectral_tensor",
    "subcell_variance",
    "hawc2_paths",
    "hawc2_sidecar_paths",
    "read_bladed",
    "read_hawc2",
    "read_netcdf",
    "read_turbsim",
    "write_bladed",
    "write_hawc2",
    "write_netcdf",
    "write_turbsim",
]
