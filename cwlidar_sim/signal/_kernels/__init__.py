"""numba kernels of the Doppler signal chain (imported lazily; compile on first use), by what they compute.

``rng`` (counter-based random numbers), ``spectral`` (tier 2's line shape and draw), ``processing``
(threshold, estimators, flags), ``continuum`` (continuum speckle moments), ``heterodyne`` (tier 3).
Every name is re-exported here, so callers write ``from . import _kernels as K; K.name``.

Random numbers come from a counter-based scheme: each stream (one estimate in
tier 2, one block of samples or one range cell in tier 3) starts from
``splitmix64(key ^ splitmix64(index))`` and advances as a splitmix64 sequence,
so every number depends only on (seed, index) and never on which thread drew
it.  Slow plain-Python references of every kernel are in ``tests/reference.py``.

Threads: the ``*_rows`` and tier-3 fused kernels are serial and ``nogil``; the
package runs them on its own threads, a task at a time
(``processing._run_tasks``), which copes with a core taken by another process
far better than a static ``prange`` split.  The ``prange`` kernels are kept for
direct use and give the same bits.
"""

from __future__ import annotations

from .rng import (  # noqa: F401
    acklam,
    block_normals,
    block_normals_tab2,
    mix64,
    normal_pair,
    normal_pair_polar,
    normal_u32,
    stream_start,
    tail_normal,
)
from .spectral import (  # noqa: F401
    expected_signal_kernel,
    lag_sequence_kernel,
    line_value,
    ncx2_wh,
    spectral_sample_kernel,
    spectral_sample_rows,
)
from .processing import (  # noqa: F401
    _interp_peak,
    process_kernel,
    process_one,
    process_rows,
    process_rows_variants,
    process_shat,
    valid_spectra_rows,
)
from .heterodyne import (  # noqa: F401
    TONE_CELLS,
    COLOUR_SEGMENTS,
    add_tones,
    ar1_amplitudes_kernel,
    ar1_cell,
    colour_noise_block,
    colour_start,
    combine_partials_kernel,
    continuum_correlation_fill,
    continuum_shape_noise,
    power_average_kernel,
    power_sum_kernel,
    real_part_into,
    synth_blocks_kernel,
    synth_kernel,
    tone_tables_kernel,
)
from .continuum import (  # noqa: F401
    cell_cosines_row,
    continuum_lag_rows,
    continuum_moment_rows,
    exp_small,
    noise_tail,
    fold_block_lags,
    gamma_moment_rows,
    gaussian_deposit_rows,
    gridded_lag_rows,
)
