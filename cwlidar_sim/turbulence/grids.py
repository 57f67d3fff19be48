"""Grids of one physical size: the same seed gives the same field on each.

Boxes, planes and lines key each Fourier mode's random numbers by its
wavenumber 2 pi s_i / L_i at the field's physical size ``L_i = N_i d_i``
(see :func:`~cwlidar_sim.turbulence.generate_box`).  Two grids of one
physical size and one seed therefore hold the same coefficients at every
wavenumber they share, and a comparison of a coarse and a fine grid is a
paired one.  Grids of different physical sizes share no wavenumbers (but
k = 0) and are different realisations.  To compare grids:

1. fix the physical size first, from the physics (record length, circle,
   margins) and not from the spacing: :func:`common_extent` gives the
   smallest length at least as long as needed that holds a whole number of
   cells of every spacing to compare (FFT-friendly counts by default);
2. build each grid from that size: :func:`grid_for_extent` gives the shape
   and the spacing ``L_i / N_i``;
3. place the field at the same physical origin on both grids (sensor
   coordinates relative to the field's first point must not depend on the
   spacing), and keep everything else equal: seed, parameters,
   ``correction``; ``hf_compensation`` scales each grid by its own gains
   (its purpose), so it breaks the equality of the shared coefficients.
"""

from __future__ import annotations

import fractions
import math

from .._validation import check_int, check_real, check_tuple


def grid_for_extent(extent, spacing):
    """Shape and spacing of a periodic grid of exactly the physical size ``extent``.

    Parameters
    ----------
    extent : sequence of float
        Physical size L_i of each axis [m] (1 to 3 axes), > 0.
    spacing : sequence of float
        Wanted spacing d_i of each axis [m], > 0, same length as ``extent``.

    Returns
    -------
    shape : tuple of int
        N_i = max(2, round(L_i / d_i)).
    spacing : tuple of float
        L_i / N_i [m] (equal to the wanted spacing when L_i is a whole number
        of cells, e.g. an extent from :func:`common_extent`).

    Notes
    -----
    Every grid built from one extent has N_i d_i = L_i to round-off, so its
    modes sit at the same physical wavenumbers 2 pi s / L_i and draw the
    same random numbers there.
    """
    if isinstance(extent, (str, bytes)) or not hasattr(extent, "__len__"):
        raise TypeError(f"extent must be a sequence of 1 to 3 lengths [m], got {extent!r}")
    n = len(extent)
    if n not in (1, 2, 3):
        raise ValueError(f"extent must have 1 to 3 axes, got {n}")
    ext = check_tuple("extent", extent, n, lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    sp = check_tuple("spacing", spacing, n, lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    shape = tuple(max(2, int(round(L / d))) for L, d in zip(ext, sp))
    return shape, tuple(L / N for L, N in zip(ext, shape))


def common_extent(min_extent, spacings, *, fast: bool = True, max_denominator: int = 10**6):
    """Smallest length >= ``min_extent`` holding a whole number of cells of each spacing.

    Parameters
    ----------
    min_extent : float
        Length the field must at least span [m], > 0.
    spacings : sequence of float
        The spacings to compare along this axis [m], > 0 (e.g. d, d/2, d/4).
    fast : bool
        Also make every cell count 2-3-5-smooth (``scipy.fft.next_fast_len``
        with ``real=True``), so that every grid's FFT is fast.
    max_denominator : int
        The spacings are taken as fractions p/q of a metre with q up to this
        (they must be such fractions to 1e-15 relative: a decimal spacing
        like 0.7 is 7/10 to the last bit).

    Returns
    -------
    float
        The length L [m]; ``L / d`` is a whole number for every d in
        ``spacings``.
    """
    from scipy.fft import next_fast_len

    lo = check_real("min_extent", min_extent, lo=0.0, lo_open=True)
    if isinstance(spacings, (str, bytes)) or not hasattr(spacings, "__len__") or len(spacings) == 0:
        raise TypeError(f"spacings must be a non-empty sequence of spacings [m], got {spacings!r}")
    sp = check_tuple("spacings", spacings, len(spacings), lambda nm, v: check_real(nm, v, lo=0.0, lo_open=True))
    q_max = check_int("max_denominator", max_denominator, lo=1)
    fr = []
    for i, d in enumerate(sp):
        f = fractions.Fraction(d).limit_denominator(q_max)
        if abs(float(f) - d) > 1e-15 * d:
            raise ValueError(f"spacings[{i}]={d!r} is not a fraction p/q of a metre with q <= {q_max}")
        fr.append(f)
    num = math.lcm(*(f.numerator for f in fr))
    den = math.gcd(*(f.denominator for f in fr))
    unit = fractions.Fraction(num, den)  # every spacing divides it
    m = max(1, math.ceil(fractions.Fraction(lo) / unit))
    if fast:
        counts = [unit / f for f in fr]  # cells of each spacing per unit (integers)
        while any(next_fast_len(int(m * c), real=True) != m * c for c in counts):
            m += 1
    return float(m * unit)
