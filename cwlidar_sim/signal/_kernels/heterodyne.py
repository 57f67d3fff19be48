"""Tier 3: the heterodyne signal (AR(1) amplitudes, tones, noise) and its block periodograms."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..._config import NJIT, NJIT_PARALLEL
from .rng import (_GOLDEN, _START_STREAM, block_normals, block_normals_tab2, mix64, normal_pair,
                  normal_pair_polar, stream_start)


# ---------------------------------------------------------------------------
# tier 3: heterodyne signal
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def ar1_cell(key, s, step0, rho, std, first_re, first_im, out_re_t, out_im_t):
    """AR(1) amplitudes of range cell ``s`` for steps ``step0 .. step0 + len - 1`` (see ar1_amplitudes_kernel)."""
    nt = out_re_t.shape[0]
    inno = math.sqrt(max(0.0, 1.0 - rho * rho))
    ckey = mix64(np.uint64(key) ^ mix64(np.uint64(s) + _GOLDEN))
    sd = std * math.sqrt(0.5)
    ar = first_re
    ai = first_im
    for t in range(nt):
        st = stream_start(ckey, step0 + t)
        st, z0, z1 = normal_pair(st)
        if step0 + t == 0:
            ar = sd * z0
            ai = sd * z1
        else:
            ar = rho * ar + inno * sd * z0
            ai = rho * ai + inno * sd * z1
        out_re_t[t] = ar
        out_im_t[t] = ai


@numba.njit(**NJIT_PARALLEL)
def ar1_amplitudes_kernel(key, step0, rho, std_s, first_re_s, first_im_s, out_re_ts, out_im_ts):
    """AR(1) complex-Gaussian speckle amplitudes of each range cell.

    ``a[t] = rho a[t-1] + sqrt(1 - rho^2) xi[t]`` with ``E|a|^2 = std_s^2``;
    ``first_*`` is the amplitude before step ``step0`` (ignored when
    ``step0 == 0``: the first step is drawn from the stationary law).  The
    innovation of global step t of cell s comes from stream (cell s, step t).
    """
    ns = out_re_ts.shape[1]
    for s in numba.prange(ns):
        ar1_cell(key, s, step0, rho, std_s[s], first_re_s[s], first_im_s[s], out_re_ts[:, s], out_im_ts[:, s])


@numba.njit(**NJIT_PARALLEL)
def synth_kernel(key, block0, n_sub, amp_re_ts, amp_im_ts, phase0_bs, dtheta_bs, noise_std, window_n, use_window,
                 out_bn):
    """Real heterodyne samples of ``out_bn.shape[0]`` blocks starting at global block ``block0``.

    ``x[n] = sum_s Re(a_s e^{i (phase0_s + dtheta_s n)}) + noise_std * xi[n]``;
    the amplitude of cell s is constant over each of the ``n_sub`` sub-steps
    of a block (row ``b * n_sub + j`` of ``amp_*_ts``).  The tones follow the
    Chebyshev recurrence ``y[n] = 2 cos(theta) y[n-1] - y[n-2]`` (float64),
    restarted at each sub-step, with the cells interleaved so that their
    independent recurrences pipeline.  Noise of global block b comes from
    stream b (Marsaglia's polar method).

    The package now synthesises with :func:`synth_blocks_kernel` (table
    normals, vectorised tones, fused with the FFT); this unfused form is
    kept as a second, independent implementation of the same signal model
    (it is checked against the plain-Python reference in the tests).
    """
    nb, nn = out_bn.shape
    ns = dtheta_bs.shape[1]
    ln = nn // n_sub
    for b in numba.prange(nb):
        st = stream_start(key, block0 + b)
        for n in range(0, nn, 2):
            st, z0, z1 = normal_pair_polar(st)
            out_bn[b, n] = noise_std * z0
            out_bn[b, n + 1] = noise_std * z1
        y0 = np.empty(ns)
        y1 = np.empty(ns)
        c2 = np.empty(ns)
        for j in range(n_sub):
            n0 = j * ln
            for s in range(ns):
                ar = amp_re_ts[b * n_sub + j, s]
                ai = amp_im_ts[b * n_sub + j, s]
                th = dtheta_bs[b, s]
                ph = phase0_bs[b, s] + th * n0
                y0[s] = ar * math.cos(ph) - ai * math.sin(ph)
                y1[s] = ar * math.cos(ph + th) - ai * math.sin(ph + th)
                c2[s] = 2.0 * math.cos(th)
            acc0 = 0.0
            acc1 = 0.0
            for s in range(ns):
                acc0 += y0[s]
                acc1 += y1[s]
            out_bn[b, n0] += acc0
            if ln > 1:
                out_bn[b, n0 + 1] += acc1
            for n in range(2, ln):
                acc = 0.0
                for s in range(ns):
                    y2 = c2[s] * y1[s] - y0[s]
                    y0[s] = y1[s]
                    y1[s] = y2
                    acc += y2
                out_bn[b, n0 + n] += acc
        if use_window:
            for n in range(nn):
                out_bn[b, n] *= window_n[n]


@numba.njit(**NJIT_PARALLEL)
def power_average_kernel(spec_bf, m_blocks, scale, out_ef):
    """``out[e, k] = scale / M * sum_b |X[e M + b, k]|^2`` (blocks summed in order).

    The unfused form of :func:`power_sum_kernel` + :func:`combine_partials_kernel`.
    """
    ne, nf = out_ef.shape
    for e in numba.prange(ne):
        for k in range(nf):
            out_ef[e, k] = 0.0
        for b in range(e * m_blocks, (e + 1) * m_blocks):
            for k in range(nf):
                v = spec_bf[b, k]
                out_ef[e, k] += v.real * v.real + v.imag * v.imag
        for k in range(nf):
            out_ef[e, k] *= scale / m_blocks


# ---------------------------------------------------------------------------
# tier 3, fused path: one block at a time into a worker's FFT input buffer
# ---------------------------------------------------------------------------
#: Cells per group of the tone tables (:func:`tone_tables_kernel`); the tones
#: of a group are summed sample by sample in one pass (:func:`_tones_group`).
TONE_CELLS = 4
#: ``exp(i theta n)``, n < N, is ``exp(i theta S j) exp(i theta q)``, ``n = S j + q``.
_TAB_SPLIT = 32
#: The block phasor ``exp(i theta N i)`` is ``exp(i theta N S h) exp(i theta N l)``, ``i = S h + l``.
_PH_SPLIT = 64


@numba.njit(**NJIT)
def _phasor_factors(th, count, split, fac_re_2k, fac_im_2k):
    """``fac[0, j] = exp(i th split j)``, j < ceil(count / split); ``fac[1, q] = exp(i th q)``, q < split."""
    for j in range((count + split - 1) // split):
        a = th * (split * j)
        fac_re_2k[0, j] = math.cos(a)
        fac_im_2k[0, j] = math.sin(a)
    for q in range(split):
        a = th * q
        fac_re_2k[1, q] = math.cos(a)
        fac_im_2k[1, q] = math.sin(a)


@numba.njit(**NJIT)
def tone_tables_kernel(phase_s, dtheta_s, n_fft, tab_gkn, ph_re_is, ph_im_is):
    """Tone tables of one estimate: ``exp(i dtheta_s n)`` for n < N and the block phasors.

    ``tab_gkn[g, k, n]`` is ``cos(dtheta_s n)`` (k < 4) and ``sin(dtheta_s n)``
    (k = 4 + c) of cell ``s = 4 g + c`` (:data:`TONE_CELLS` = 4 cells per
    group; cells ``s >= len(dtheta_s)`` pad the last group: cos 1, sin 0).
    ``ph[i, s] = exp(i (phase_s + dtheta_s N i))`` is the Doppler phasor of
    cell s at the start of block i of the estimate, i < ``ph_re_is.shape[0]``
    (padding cells: 1).  Each value is the complex product of factors from
    cos/sin of their own angles, ``exp(i theta n) = exp(i theta 32 j) exp(i
    theta q)`` (``n = 32 j + q``) and ``exp(i phase) exp(i theta N 64 h)
    exp(i theta N l)`` (``i = 64 h + l``): a few ulp, and no error that grows
    along the block or the estimate.  ``tab_gkn`` may be float32 (the
    package's tables are: the tones are summed in float32), the phasors are
    float64.
    """
    ns = dtheta_s.shape[0]
    ng = tab_gkn.shape[0]
    nn = tab_gkn.shape[2]
    mb = ph_re_is.shape[0]
    kmax = max(nn // _TAB_SPLIT + 1, mb // _PH_SPLIT + 1, _PH_SPLIT)
    fr = np.empty((2, kmax))
    fi = np.empty((2, kmax))
    for s in range(TONE_CELLS * ng):
        g = s // TONE_CELLS
        c = s - g * TONE_CELLS
        if s >= ns:
            for n in range(nn):
                tab_gkn[g, c, n] = 1.0
                tab_gkn[g, TONE_CELLS + c, n] = 0.0
            for i in range(mb):
                ph_re_is[i, s] = 1.0
                ph_im_is[i, s] = 0.0
            continue
        th = dtheta_s[s]
        _phasor_factors(th, nn, _TAB_SPLIT, fr, fi)
        for n in range(nn):
            j = n // _TAB_SPLIT
            q = n - j * _TAB_SPLIT
            tab_gkn[g, c, n] = fr[0, j] * fr[1, q] - fi[0, j] * fi[1, q]
            tab_gkn[g, TONE_CELLS + c, n] = fr[0, j] * fi[1, q] + fi[0, j] * fr[1, q]
        _phasor_factors(th * n_fft, mb, _PH_SPLIT, fr, fi)
        p0r = math.cos(phase_s[s])
        p0i = math.sin(phase_s[s])
        for h in range((mb + _PH_SPLIT - 1) // _PH_SPLIT):
            er = p0r * fr[0, h] - p0i * fi[0, h]
            ei = p0r * fi[0, h] + p0i * fr[0, h]
            for i in range(h * _PH_SPLIT, min(mb, (h + 1) * _PH_SPLIT)):
                q = i - h * _PH_SPLIT
                ph_re_is[i, s] = er * fr[1, q] - ei * fi[1, q]
                ph_im_is[i, s] = er * fi[1, q] + ei * fr[1, q]


@numba.njit(**NJIT, inline='always')
def _tones_group(cr_s, ci_s, tab_gkn, g, lo, hi, out_n):
    """``out_n[n] += sum_c (cr cos - ci sin)`` over the 4 cells of group g, ``lo <= n < hi``, in float32.

    The four terms are summed as a tree, ``((t0 + t1) + (t2 + t3))``, then
    added to ``out_n`` (group 0: stored); rows sliced to ``[lo, hi)`` index from 0, provably
    >= 0, so the loop vectorises (8 lanes).
    """
    s = TONE_CELLS * g
    a0, a1 = np.float32(cr_s[s]), np.float32(cr_s[s + 1])
    a2, a3 = np.float32(cr_s[s + 2]), np.float32(cr_s[s + 3])
    b0, b1 = np.float32(ci_s[s]), np.float32(ci_s[s + 1])
    b2, b3 = np.float32(ci_s[s + 2]), np.float32(ci_s[s + 3])
    t = tab_gkn[g]
    c0, c1, c2, c3 = t[0][lo:hi], t[1][lo:hi], t[2][lo:hi], t[3][lo:hi]
    s0, s1, s2, s3 = t[4][lo:hi], t[5][lo:hi], t[6][lo:hi], t[7][lo:hi]
    x = out_n[lo:hi]
    if g == 0:
        for n in range(hi - lo):
            x[n] = ((a0 * c0[n] - b0 * s0[n]) + (a1 * c1[n] - b1 * s1[n])) + ((a2 * c2[n] - b2 * s2[n]) + (a3 * c3[n] - b3 * s3[n]))
    else:
        for n in range(hi - lo):
            x[n] += ((a0 * c0[n] - b0 * s0[n]) + (a1 * c1[n] - b1 * s1[n])) + ((a2 * c2[n] - b2 * s2[n]) + (a3 * c3[n] - b3 * s3[n]))


@numba.njit(**NJIT, inline='always')
def add_tones(n_sub, amp_re_st, amp_im_st, t0, ph_re_s, ph_im_s, tab_gkn, cr_s, ci_s, out_n):
    """``out_n[n] = sum_s Re(a_s exp(i phi_s) exp(i dtheta_s n))`` (float32), ``a_s`` constant over each of n_sub sub-steps.

    ``a_s = amp_*_st[s, t0 + j]`` in sub-step j, ``exp(i phi_s) = ph_*_s[s]``
    (the block's phasors), ``exp(i dtheta_s n)`` from ``tab_gkn``
    (:func:`tone_tables_kernel`, float32).  The coefficients ``a_s exp(i
    phi_s)`` are formed in float64 and rounded to float32; each group of
    :data:`TONE_CELLS` cells is one pass of :func:`_tones_group`, groups in
    order.  ``cr_s``, ``ci_s`` (length 4 times the groups) are scratch.
    """
    nn = out_n.shape[0]
    ln = nn // n_sub
    ns = amp_re_st.shape[0]
    ng = tab_gkn.shape[0]
    for s in range(ns, TONE_CELLS * ng):
        cr_s[s] = 0.0
        ci_s[s] = 0.0
    for j in range(n_sub):
        for s in range(ns):
            ar = amp_re_st[s, t0 + j]
            ai = amp_im_st[s, t0 + j]
            cr_s[s] = ar * ph_re_s[s] - ai * ph_im_s[s]
            ci_s[s] = ar * ph_im_s[s] + ai * ph_re_s[s]
        for g in range(ng):
            _tones_group(cr_s, ci_s, tab_gkn, g, j * ln, (j + 1) * ln, out_n)


@numba.njit(**NJIT)
def synth_blocks_kernel(key, block0, b_lo, b_hi, m_blocks, n_sub, amp_re_st, amp_im_st, tab_egkn, ph_re_ebs, ph_im_ebs,
                        noise_std, window_n, use_window, extra_et, ckey, ce0, cf_8, pw_2n, state_2, acc_n, words_w,
                        tails_n, out_bn):
    """Real heterodyne samples of blocks ``b_lo .. b_hi - 1`` of a chunk into rows 0.. of ``out_bn`` (float32).

    The signal of :func:`synth_kernel`, ``x[n] = noise_std * xi[n] + sum_s
    Re(a_s e^{i (phase0_s + dtheta_s n)})``, windowed.  Chunk block b is
    global block ``block0 + b``, block ``i = b mod M`` of the chunk's
    estimate ``e = b // M``; its phasors ``exp(i phase0_s) = ph_*_ebs[e, i,
    s]`` and the tones' tables ``tab_egkn[e]`` come from
    :func:`tone_tables_kernel`; noise from stream ``block0 + b``
    (:func:`block_normals_tab2`: table normals, where synth_kernel uses the
    polar method); amplitudes ``amp_*_st[s, b n_sub + j]``, j < n_sub.
    The tones are summed in float32 (:func:`add_tones`), those of all the
    call's blocks first, into the rows of ``out_bn`` (their tables stay in
    the cache, which the noise's table lookups would flush block by block);
    then block by block the float64 noise (and ``extra``) is added to the
    row, the window applied and the sum rounded to float32.  Every block depends only on
    its own inputs, so the result does not depend on how blocks are split
    between calls or threads (serial and ``nogil``: worker threads call it
    on disjoint blocks).  ``extra_et`` (rows: the chunk's estimates, M N
    samples each; or 0 rows) is added to the samples before the window: the
    continuum signal and its noise processes (:func:`continuum_shape_noise`).

    Coloured noise (``cf_8`` of length 8, else length 0): the shot-noise
    normals of each block become the RIN and the reflection too
    (:func:`colour_noise_block`, coefficients ``cf_8``, powers ``pw_2n``),
    the filter's state carried from block to block in ``state_2`` (in and
    out) and drawn afresh from its stationary law at the first block of
    each estimate (global estimate ``ce0 + e``, key ``ckey``:
    :func:`colour_start`).  A call that starts inside an estimate therefore
    continues the state its previous blocks left (the caller runs the
    blocks of an estimate in order).
    ``acc_n``, ``words_w``, ``tails_n`` are scratch (lengths N, ceil(N/2), N).
    """
    nn = acc_n.shape[0]
    coloured = cf_8.shape[0] > 0
    tones = amp_re_st.shape[0] > 0
    ncs = TONE_CELLS * tab_egkn.shape[1]
    cr_s = np.empty(ncs)
    ci_s = np.empty(ncs)
    # the tones of every block first, into the output rows: the tables stay in the cache
    if tones:
        for b in range(b_lo, b_hi):
            e = b // m_blocks
            i = b - e * m_blocks
            add_tones(n_sub, amp_re_st, amp_im_st, b * n_sub, ph_re_ebs[e, i], ph_im_ebs[e, i], tab_egkn[e], cr_s,
                      ci_s, out_bn[b - b_lo])
    for b in range(b_lo, b_hi):
        # coloured: the normals times b_1, as colour_noise_block takes them
        block_normals_tab2(stream_start(key, block0 + b), noise_std * cf_8[1] if coloured else noise_std, words_w,
                           tails_n, acc_n)
        e = b // m_blocks
        i = b - e * m_blocks
        if coloured:
            if i == 0:
                colour_start(ckey, ce0 + e, cf_8, state_2)
            colour_noise_block(acc_n, cf_8, pw_2n, state_2)
        if extra_et.shape[0] > 0:
            xr = extra_et[e, i * nn:(i + 1) * nn]
            for n in range(nn):
                acc_n[n] += xr[n]
        o = out_bn[b - b_lo]
        if tones:
            if use_window:
                for n in range(nn):
                    o[n] = np.float32((acc_n[n] + o[n]) * window_n[n])
            else:
                for n in range(nn):
                    o[n] = np.float32(acc_n[n] + o[n])
        elif use_window:
            for n in range(nn):
                o[n] = np.float32(acc_n[n] * window_n[n])
        else:
            for n in range(nn):
                o[n] = np.float32(acc_n[n])


@numba.njit(**NJIT)
def power_sum_kernel(spec_bf, n_rows, out_f):
    """``out_f[k] = sum_{b < n_rows} |X[b, k]|^2`` in float64, rows summed in order."""
    nf = out_f.shape[0]
    for k in range(nf):
        out_f[k] = 0.0
    for b in range(n_rows):
        for k in range(nf):
            v = spec_bf[b, k]
            re = np.float64(v.real)
            im = np.float64(v.imag)
            out_f[k] += re * re + im * im


@numba.njit(**NJIT)
def combine_partials_kernel(partial_erf, factor, out_ef):
    """``out[e, k] = factor * sum_r partial[e, r, k]`` (r in order)."""
    ne, nr, nf = partial_erf.shape
    for e in range(ne):
        for k in range(nf):
            out_ef[e, k] = 0.0
        for r in range(nr):
            for k in range(nf):
                out_ef[e, k] += partial_erf[e, r, k]
        for k in range(nf):
            out_ef[e, k] *= factor


# ---------------------------------------------------------------------------
# tier 3, continuum path: a Gaussian process synthesised from its spectrum
# ---------------------------------------------------------------------------
@numba.njit(**NJIT)
def continuum_correlation_fill(x_s, amp2_s, g_t, rn_t, n_fft, t_max, buf_p):
    """``buf[tau] = sum_s amp2_s exp(i 2 pi x_s tau / N) g(tau) + 2 rn(tau)`` for tau < t_max, its conjugate at P - tau.

    The complex correlation of the synthesised process (signal cells of
    power ``amp2_s = E|a_s|^2`` at ``x_s`` bins, plus twice the real noise
    correlation ``rn``, so that the real part carries ``rn``); 0 elsewhere.
    The phasor of a cell is rotated lag by lag (error O(tau eps)).
    """
    p = buf_p.shape[0]
    for i in range(p):
        buf_p[i] = 0.0j
    ns = x_s.shape[0]
    for s in range(ns):
        a = amp2_s[s]
        if a == 0.0:
            continue
        x = x_s[s] - n_fft * math.floor(x_s[s] / n_fft)
        th = 2.0 * math.pi * x / n_fft
        c = math.cos(th)
        sn = math.sin(th)
        zr = a
        zi = 0.0
        for t in range(t_max):
            buf_p[t] += complex(zr * g_t[t], zi * g_t[t])
            zr, zi = zr * c - zi * sn, zr * sn + zi * c
    for t in range(t_max):
        buf_p[t] += 2.0 * rn_t[t]
    for t in range(1, t_max):
        buf_p[p - t] = buf_p[t].conjugate()


@numba.njit(**NJIT)
def continuum_shape_noise(key, stream, buf_p, words_w, tails_n, tmp_n):
    """Replace the spectrum ``S_m`` in ``buf`` by ``sqrt(max(Re S_m, 0) / (2P)) (z0 + i z1)``.

    ``z0, z1`` standard normals from the counter-based streams
    ``stream_start(mix64(key ^ stream), c)``, c = 0, 1, .. (``tmp_n.shape[0]``
    normals each); the inverse FFT of the result is a circular complex
    Gaussian process with correlation ``(1/P) sum_m S_m exp(i 2 pi m n / P)``.
    """
    p = buf_p.shape[0]
    nc = tmp_n.shape[0]
    skey = mix64(np.uint64(key) ^ mix64(np.uint64(stream) + _GOLDEN))
    inv = 1.0 / (2.0 * p)
    c = 0
    pos = nc
    for m in range(p):
        if pos + 2 > nc:
            block_normals(stream_start(skey, c), 1.0, words_w, tails_n, tmp_n)
            c += 1
            pos = 0
        s = buf_p[m].real
        a = math.sqrt(s * inv) if s > 0.0 else 0.0
        buf_p[m] = complex(a * tmp_n[pos], a * tmp_n[pos + 1])
        pos += 2


@numba.njit(**NJIT)
def real_part_into(buf_p, n, out_n):
    """``out_n[:n] = Re buf_p[:n]``."""
    for i in range(n):
        out_n[i] = buf_p[i].real


# ---------------------------------------------------------------------------
# tier 3: RIN and the 0 Hz reflection as a colouring of the shot noise
# ---------------------------------------------------------------------------
#: Segments of a block whose local AR(1) scans run interleaved in :func:`colour_noise_block`.
COLOUR_SEGMENTS = 4


@numba.njit(**NJIT)
def colour_start(key, estimate, cf_8, state_2):
    """Stationary start of the colouring filter of one estimate: ``state = L (z0, z1)``.

    ``L = [[cf[5], 0], [cf[6], cf[7]]]`` is the Cholesky factor of the
    states' stationary covariance; ``z0, z1`` the first :func:`normal_pair`
    of stream ``stream_start(mix64(key ^ mix64(estimate + golden)), 2^62)``
    (the stream the start of the earlier per-estimate AR(1) noise used).
    """
    skey = mix64(np.uint64(key) ^ mix64(np.uint64(estimate) + _GOLDEN))
    st = stream_start(skey, _START_STREAM)
    st, z0, z1 = normal_pair(st)
    state_2[0] = cf_8[5] * z0
    state_2[1] = cf_8[6] * z0 + cf_8[7] * z1


@numba.njit(**NJIT)
def colour_noise_block(acc_n, cf_8, pw_2n, state_2):
    """In place, scaled white normals ``w = b_1 z`` -> ``y = a0 z + u_1 + u_2``, ``u_c[n] = rho_c u_c[n-1] + b_c z[n]``.

    ``cf_8 = (a0, b_1, b_2, rho_1, rho_2, ...)`` with ``b_1 > 0`` (as
    :func:`cwlidar_sim.signal.heterodyne.noise_filter` makes it).  The input
    is the normals times ``b_1`` (:func:`synth_blocks_kernel` draws them so,
    which saves a multiplication per sample): ``u_1[n] = rho_1 u_1[n-1] +
    w[n]``, ``u_2[n] = rho_2 u_2[n-1] + k_2 w[n]``, ``y = (k_0 w + u_1) +
    u_2`` with ``k_0 = a0 / b_1``, ``k_2 = b_2 / b_1``.  ``state_2`` holds
    ``u_c[-1]`` on entry and ``u_c[N-1]`` on return; ``pw_2n[c, k] =
    rho_c^(k+1)``.  The recursion is computed as a blocked scan, so that its
    serial latency is shared by :data:`COLOUR_SEGMENTS` = S segments: with
    ``G = N // S``, segment s < S - 1 is samples ``[sG, (s+1)G)`` and the last
    one ``[(S-1)G, N)``.  Pass 1 runs the S segments side by side from a zero
    state and stores ``(k_0 w + l_1) + l_2``; pass 2 adds ``pw_1[k] C_1 +
    pw_2[k] C_2``, ``C_c`` the state before the segment, carried as ``C_c <-
    pw_c[len - 1] C_c + l_c[end]``.  Exact in exact arithmetic; the rounding
    differs from the serial recursion's by a few ulp
    (``tests/reference.py::signal_colour_noise`` repeats this order).
    """
    nn = acc_n.shape[0]
    k0 = cf_8[0] / cf_8[1]
    k2 = cf_8[2] / cf_8[1]
    r1 = cf_8[3]
    r2 = cf_8[4]
    g = nn // COLOUR_SEGMENTS
    x0 = acc_n[0:g]
    x1 = acc_n[g:2 * g]
    x2 = acc_n[2 * g:3 * g]
    x3 = acc_n[3 * g:4 * g]
    p0 = q0 = p1 = q1 = p2 = q2 = p3 = q3 = 0.0
    # four independent chains per component: their latencies overlap
    for k in range(g):
        z = x0[k]
        p0 = r1 * p0 + z
        q0 = r2 * q0 + k2 * z
        x0[k] = (k0 * z + p0) + q0
        z = x1[k]
        p1 = r1 * p1 + z
        q1 = r2 * q1 + k2 * z
        x1[k] = (k0 * z + p1) + q1
        z = x2[k]
        p2 = r1 * p2 + z
        q2 = r2 * q2 + k2 * z
        x2[k] = (k0 * z + p2) + q2
        z = x3[k]
        p3 = r1 * p3 + z
        q3 = r2 * q3 + k2 * z
        x3[k] = (k0 * z + p3) + q3
    for n in range(COLOUR_SEGMENTS * g, nn):
        z = acc_n[n]
        p3 = r1 * p3 + z
        q3 = r2 * q3 + k2 * z
        acc_n[n] = (k0 * z + p3) + q3
    c1 = state_2[0]
    c2 = state_2[1]
    for s in range(COLOUR_SEGMENTS):
        lo = s * g
        hi = nn if s == COLOUR_SEGMENTS - 1 else lo + g
        ln = hi - lo
        if ln == 0:
            continue
        seg = acc_n[lo:hi]
        w1 = pw_2n[0, :ln]
        w2 = pw_2n[1, :ln]
        for k in range(ln):
            seg[k] += w1[k] * c1 + w2[k] * c2
        if s == 0:
            e1, e2 = p0, q0
        elif s == 1:
            e1, e2 = p1, q1
        elif s == 2:
            e1, e2 = p2, q2
        else:
            e1, e2 = p3, q3
        c1 = w1[ln - 1] * c1 + e1
        c2 = w2[ln - 1] * c2 + e2
    state_2[0] = c1
    state_2[1] = c2
