"""Slow plain-Python references for the package's numba kernels (append-only, one section per stage)."""

import math

import numpy as np


# =============================================================================
# beam stage (cwlidar_sim/beam/_kernels.py)
# =============================================================================
def beam_sample_points(u, v, w, grid, wrap, origin, n_tc, range_s, time_t, U, add_mean=False):
    """Reference for ``sample_points_kernel``: loops over every point, trilinear interpolation.

    ``u, v, w`` have shape (nx, ny, nz) (ny = nz = 1 for a line, nz = 1 for a
    plane); ``grid`` = (x0, y0, z0, dx, dy, dz).  x is periodic; y and z are
    periodic if ``wrap``, otherwise the point must lie inside the nodes.
    Returns (vel_tsc, vlos_ts).
    """
    nx, ny, nz = u.shape
    n_t, n_s = len(time_t), len(range_s)
    vel = np.zeros((n_t, n_s, 3))
    vlos = np.zeros((n_t, n_s))

    def axis(p, p0, h, n, periodic):
        if n == 1:
            return 0, 0, 0.0
        f = (p - p0) / h
        if periodic:
            f = f % n
            i = int(math.floor(f))
            t = f - i
            i = i % n
            return i, (i + 1) % n, t
        i = min(max(int(math.floor(f)), 0), n - 2)
        return i, i + 1, f - i

    for it in range(n_t):
        for js in range(n_s):
            p = [origin[d] + range_s[js] * n_tc[it][d] for d in range(3)]
            p[0] -= U * time_t[it]
            i0, i1, tx = axis(p[0], grid[0], grid[3], nx, True)
            j0, j1, ty = axis(p[1], grid[1], grid[4], ny, wrap)
            k0, k1, tz = axis(p[2], grid[2], grid[5], nz, wrap)
            out = []
            for a in (u, v, w):
                val = 0.0
                for ii, wx in ((i0, 1 - tx), (i1, tx)):
                    for jj, wy in ((j0, 1 - ty), (j1, ty)):
                        for kk, wz in ((k0, 1 - tz), (k1, tz)):
                            val += wx * wy * wz * float(a[ii, jj, kk])
                out.append(val)
            if add_mean:
                out[0] += U
            vel[it, js] = out
            vlos[it, js] = sum(n_tc[it][d] * out[d] for d in range(3))
    return vel, vlos


# ---------------------------------------------------------------------------
# Turbulence: plain-Python Mann (1994) amplitude matrix, straight from the
# formulas of PHYSICS.md section 1 (scipy's hyp2f1 for the lifetime, Mann's
# arctan written with the branch taken care of by hand).
# ---------------------------------------------------------------------------


def mann_amplitude(k1, k2, k3, alpha_eps, L, gamma):
    """M with Phi = M M^T, for one wave vector, in plain Python."""
    from scipy.special import hyp2f1

    kk = k1 * k1 + k2 * k2 + k3 * k3
    if kk == 0.0:
        return [[0.0] * 3 for _ in range(3)]
    k = math.sqrt(kk)
    beta = gamma * (k * L) ** (-2.0 / 3.0) / math.sqrt(hyp2f1(1 / 3, 17 / 6, 4 / 3, -((k * L) ** -2)))
    k30 = k3 + beta * k1
    k0sq = k1 * k1 + k2 * k2 + k30 * k30
    k0 = math.sqrt(k0sq)
    E = alpha_eps * L ** (5 / 3) * (k0 * L) ** 4 / (1 + (k0 * L) ** 2) ** (17 / 6)
    a = math.sqrt(E / (4 * math.pi)) / k0sq
    A = [[0.0, a * k30, -a * k2], [-a * k30, 0.0, a * k1], [a * k2, -a * k1, 0.0]]
    kh2 = k1 * k1 + k2 * k2
    if k1 == 0.0:
        z1, z2 = -beta, 0.0
    else:
        C1 = beta * k1 * k1 * (k0sq - 2 * k30 * k30 + beta * k1 * k30) / (kk * kh2)
        arg = beta * k1 * math.sqrt(kh2) / (k0sq - k30 * k1 * beta)
        ang = math.atan(arg)
        # Mann's arctan is continuous in beta from 0: when the denominator is
        # negative the principal value is off by pi.
        if k0sq - k30 * k1 * beta < 0:
            ang += math.pi if arg < 0 else -math.pi
        C2 = k2 * k0sq / kh2 ** 1.5 * ang
        z1 = C1 - k2 / k1 * C2
        z2 = k2 / k1 * C1 + C2
    D = [[1.0, 0.0, z1], [0.0, 1.0, z2], [0.0, 0.0, k0sq / kk]]
    return [[sum(D[i][l] * A[l][j] for l in range(3)) for j in range(3)] for i in range(3)]


# =============================================================================
# signal stage (cwlidar_sim/signal/_kernels.py)
# =============================================================================
_SIG_MASK = (1 << 64) - 1
_SIG_GOLDEN = 0x9E3779B97F4A7C15


def signal_mix64(z):
    """splitmix64 finaliser on Python ints."""
    z &= _SIG_MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _SIG_MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _SIG_MASK
    return z ^ (z >> 31)


def signal_stream_start(key, index):
    return signal_mix64(int(key) ^ signal_mix64((int(index) * _SIG_GOLDEN + _SIG_GOLDEN) & _SIG_MASK))


def signal_normal_u32(u):
    """Exact inverse normal CDF of (u + 1/2) / 2**32 (the kernel interpolates a table / uses Acklam)."""
    from scipy.special import ndtri

    return float(ndtri((u + 0.5) / 2.0**32))


def signal_normal_pair(state):
    state = (state + _SIG_GOLDEN) & _SIG_MASK
    z = signal_mix64(state)
    return state, signal_normal_u32(z >> 32), signal_normal_u32(z & 0xFFFFFFFF)


def signal_normal_pair_polar(state):
    while True:
        state = (state + _SIG_GOLDEN) & _SIG_MASK
        z = signal_mix64(state)
        a = (z >> 32) * 2.0**-31 - 1.0
        b = (z & 0xFFFFFFFF) * 2.0**-31 - 1.0
        s = a * a + b * b
        if 0.0 < s < 1.0:
            f = math.sqrt(-2.0 * math.log(s) / s)
            return state, a * f, b * f


def signal_line_shape(u, n_fft, window_n, rho):
    """G(u) by its defining double sum over sample pairs (no table, no FFT)."""
    n = len(window_n)
    r0 = sum(w * w for w in window_n)
    acc = 0.0
    for d in range(-(n - 1), n):
        rw = sum(window_n[i] * window_n[i + abs(d)] for i in range(n - abs(d)))
        acc += rw * rho ** abs(d) * math.cos(2 * math.pi * u * d / n_fft)
    return acc / r0


def signal_expected_spectrum(x_es, amp_es, g, nf):
    """Reference for ``expected_signal_kernel``: out[e, k] = sum_s amp[e, s] (g(k - x) + g(k + x)), with g a callable."""
    ne, ns = x_es.shape
    out = np.zeros((ne, nf))
    for e in range(ne):
        for k in range(nf):
            for s in range(ns):
                out[e, k] += amp_es[e, s] * (g(k - x_es[e, s]) + g(k + x_es[e, s]))
    return out


def signal_spectral_sample(sig_ef, noise_f, gain_eg, m_blocks, key, e0=0, ne=None):
    """Reference for ``spectral_sample_kernel`` (exact normals, same streams)."""
    nf = len(noise_f)
    ne = sig_ef.shape[0] if ne is None else ne
    out = np.zeros((ne, nf))
    for e in range(ne):
        es = 0 if sig_ef.shape[0] == 1 else e
        st = signal_stream_start(key, e0 + e)
        for k in range(0, nf, 2):
            st, z0, z1 = signal_normal_pair(st)
            for kk, z in ((k, z0), (k + 1, z1)):
                if kk >= nf:
                    break
                g = gain_eg[e, 0] if gain_eg.shape[1] == 1 else gain_eg[e, kk]
                nu = m_blocks if kk in (0, nf - 1) else 2.0 * m_blocks
                ms, mn = sig_ef[es, kk] * g, noise_f[kk]
                lam = nu * ms / mn
                rho = (nu + 2 * lam) / (nu + lam)
                f = (nu + lam) ** 2 / (nu + 2 * lam)
                b = max(0.0, 1 - 2 / (9 * f) + z * math.sqrt(2 / (9 * f)))
                out[e, kk] = mn / nu * rho * f * b**3
    return out


def signal_process_one(spec, bg, k_lo, k_hi, t, est, window, second_frac, guard, g=None):
    """Reference for ``process_one`` given the final threshold level t on y = S/B - 1.

    est: 'median', 'centroid', 'peak', 'peak_parabolic', 'peak_gaussian', or 'ml'
    (needs ``g``, the line shape callable).  Returns (x in bins or nan, flags).
    """
    nf = len(spec)
    y = [spec[k] / bg[k] - 1.0 for k in range(nf)]
    p = [y[k] - t if (k_lo <= k < k_hi and y[k] > t) else 0.0 for k in range(nf)]
    total = sum(p)
    if total <= 0:
        return math.nan, 1
    # groups of positive bins, merged across gaps of at most 2 empty bins
    groups, cur, gap = [], 0.0, 3
    for k in range(k_lo, k_hi):
        if p[k] > 0:
            if gap > 2 and cur > 0:
                groups.append(cur)
                cur = 0.0
            cur += p[k]
            gap = 0
        else:
            gap += 1
    groups.append(cur)
    groups.sort(reverse=True)
    flags = 8 if len(groups) > 1 and groups[1] >= second_frac * groups[0] else 0
    kp = max(range(nf), key=lambda k: (p[k], -k))
    if est == "median":
        half, cum = total / 2, 0.0
        for k in range(nf):
            if p[k] > 0 and cum + p[k] >= half:
                x = k - 0.5 + (half - cum) / p[k]
                break
            cum += p[k]
    elif est == "centroid":
        x = sum(k * p[k] for k in range(nf)) / total
    elif est == "ml":
        from scipy.optimize import minimize_scalar

        lo, hi = max(k_lo, kp - 8), min(k_hi, kp + 9)
        shat = np.array(spec[lo:hi]) / np.array(bg[lo:hi])
        kk = np.arange(lo, hi)

        def nll_x(x0):
            gk = np.array([(g(k - x0) + g(k + x0)) / g(0.0) for k in kk])

            def nll_a(la):
                mu = 1 + np.exp(la) * gk
                return np.sum(np.log(mu) + shat / mu)

            r = minimize_scalar(nll_a, bounds=(-30, 30), method="bounded", options={"xatol": 1e-10})
            return r.fun

        r = minimize_scalar(nll_x, bounds=(kp - 1, kp + 1), method="bounded", options={"xatol": 1e-8})
        x = r.x
    else:
        yl = y[kp - 1] if kp >= 1 else 0.0
        yr = y[kp + 1] if kp + 1 < nf else 0.0
        yc = y[kp]
        if est == "peak":
            right = yr >= yl
            yn = yr if right else yl
            if yc <= 0 or yn <= 0:
                d = 0.0
            else:
                r = math.sqrt(yn / yc)
                d = r / (1 + r) if window == "rect" else (2 * r - 1) / (1 + r)
                d = min(0.5, max(0.0, d))
                d = d if right else -d
        else:
            if est == "peak_gaussian" and min(yl, yc, yr) > 0:
                yl, yc, yr = math.log(yl), math.log(yc), math.log(yr)
            den = yl - 2 * yc + yr
            d = 0.0 if den >= 0 else min(0.5, max(-0.5, 0.5 * (yl - yr) / den))
        x = kp + d
    if x < k_lo + guard:
        flags |= 4
    if x > nf - 1 - guard:
        flags |= 2
    return x, flags


def signal_ar1_amplitudes(key, step0, n_steps, rho, std_s, first_re, first_im):
    """Reference for ``ar1_amplitudes_kernel``: (re, im) arrays of shape (n_steps, n_cells)."""
    ns = len(std_s)
    re = np.zeros((n_steps, ns))
    im = np.zeros((n_steps, ns))
    inno = math.sqrt(max(0.0, 1 - rho * rho))
    for s in range(ns):
        ckey = signal_mix64(int(key) ^ signal_mix64(s + _SIG_GOLDEN))
        sd = std_s[s] * math.sqrt(0.5)
        ar, ai = first_re[s], first_im[s]
        for t in range(n_steps):
            _, z0, z1 = signal_normal_pair(signal_stream_start(ckey, step0 + t))
            if step0 + t == 0:
                ar, ai = sd * z0, sd * z1
            else:
                ar, ai = rho * ar + inno * sd * z0, rho * ai + inno * sd * z1
            re[t, s], im[t, s] = ar, ai
    return re, im


def signal_synth(key, block0, n_blocks, n_fft, n_sub, amp_re, amp_im, phase0_bs, dtheta_bs, noise_std, window_n):
    """Reference for ``synth_kernel``: tones by cos/sin of each sample's phase (no recurrence)."""
    out = np.zeros((n_blocks, n_fft))
    ln = n_fft // n_sub
    ns = dtheta_bs.shape[1]
    for b in range(n_blocks):
        st = signal_stream_start(key, block0 + b)
        for n in range(0, n_fft, 2):
            st, z0, z1 = signal_normal_pair_polar(st)
            out[b, n], out[b, n + 1] = noise_std * z0, noise_std * z1
        for n in range(n_fft):
            j = n // ln
            for s in range(ns):
                ph = phase0_bs[b, s] + dtheta_bs[b, s] * n
                a = complex(amp_re[b * n_sub + j, s], amp_im[b * n_sub + j, s])
                out[b, n] += (a * complex(math.cos(ph), math.sin(ph))).real
        out[b] *= window_n
    return out


def signal_power_average(spec_bf, m_blocks, scale):
    """Reference for ``power_average_kernel``."""
    nb, nf = spec_bf.shape
    ne = nb // m_blocks
    out = np.zeros((ne, nf))
    for e in range(ne):
        for b in range(e * m_blocks, (e + 1) * m_blocks):
            for k in range(nf):
                out[e, k] += abs(complex(spec_bf[b, k])) ** 2
    return out * scale / m_blocks
