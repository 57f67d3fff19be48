"""numba kernels of the Mann tensor and of the field generators (imported lazily; compile on first use),
by what they compute.

``tensor`` (the amplitude matrix and eddy lifetime, exact), ``integrals`` (one-point spectra, adaptive
cell averages, the plane's k3 integrals), ``rng`` (counter-based normals), ``fast_tensor`` (the box's
tabulated amplitudes), ``box`` (the box generator's fill, expected spectra and Hermitian planes),
``plane`` (the plane's spectra tables and fill).  Every name, private ones included, is re-exported
here, so callers write ``from ._kernels import name`` or ``from . import _kernels as K; K.name``.

Only the arithmetic lives here; validation, tables and memory management are in the public
wrappers (``tensor.py``, ``spectra.py``, ``box.py``, ``fields.py``).
"""

from __future__ import annotations

from .tensor import (  # noqa: F401
    amplitude,
    amplitude_many,
    amplitude_params,
    lifetime_f,
    LOG_X_HI,
    LOG_X_LO,
    matrix_from_params,
    _accumulate_phi,
    _phi6_of_params,
    accumulate_phi_at,
)
from .integrals import (  # noqa: F401
    cell_average_kernel,
    cell_integral,
    onepoint_kernel,
    plane_cells_kernel,
    plane_kernel,
    plane_rows_kernel,
    _gl_block,
    _MAX_DEPTH,
    _STACK,
)
from .rng import (  # noqa: F401
    BOX_MAX_SHAPE,
    PLANE_MAX_SHAPE,
    box_row_counter,
    plane_noise_kernel,
    plane_row_counter,
    mix64,
    normal_at,
    normals_kernel,
    ZIG_F,
    ZIG_K,
    ZIG_R,
    ZIG_W,
    ziggurat_tables,
    _bits_f64,
    _f64_bits,
    _GOLDEN,
    _LOW8,
    _MIX1,
    _MIX2,
    _normal_slow,
    _row_normals,
    _TWO_M53,
    _U1,
    _U11,
    _U27,
    _U30,
    _U31,
    _U52,
    _U63,
    _U8,
    _uniform_open,
)
from .fast_tensor import (  # noqa: F401
    atan2_poly,
    box_lifetime,
    box_params,
    box_params_many,
    lifetime_bits_nodes,
    pow_m17_12,
    _ATAN_C,
    _atan_poly,
    _box_params_row,
    _chol3_scalars,
    _FB,
    _FMASK,
    _FSCALE,
    _FSHIFT,
    _nyquist_row,
    _PB,
    _PLOW,
    _PMASK,
    _POW_E,
    _POW_M,
    _PSCALE,
    _PSHIFT,
    _row_constants,
    _TAN_PI8,
)
from .box import (  # noqa: F401
    box_amplitude,
    box_spectrum_kernel,
    fill_box_kernel,
    hermitian_plane_kernel,
    stencil_kernel,
    _hermitian_partner,
    _in_region,
    _mode_out,
    _signed_index,
    _SQRT2,
    _wavenumber,
)
from .plane import (  # noqa: F401
    chol3,
    fill_plane_kernel,
    plane_mode,
    plane_phi_kernel,
    _spline6,
)
