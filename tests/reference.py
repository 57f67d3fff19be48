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
# signal stage (cwlidar_sim/signal/_kernels/)
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


# =============================================================================
# analysis stage (cwlidar_sim/analysis/theory.py): A2012 Eqs. 12-14
# =============================================================================
def mann_phi_horizontal(k1, k2, k3, alpha_eps, L, gamma):
    """Phi_11, Phi_22, Phi_12 of the Mann tensor for arrays, numpy only (see :func:`mann_phi_components`)."""
    return mann_phi_components(k1, k2, k3, alpha_eps, L, gamma)[:3]


def _mann_rows(k1, k2, k3, alpha_eps, L, gamma):
    """``a`` and the first two rows of ``D A_iso / a`` (and k0^2, k^2, kh^2) of the Mann tensor, numpy only."""
    from scipy.special import hyp2f1

    k1, k2, k3 = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (k1, k2, k3)))
    kk = k1 * k1 + k2 * k2 + k3 * k3
    kl = np.sqrt(kk) * L
    beta = gamma * kl ** (-2.0 / 3.0) / np.sqrt(hyp2f1(1 / 3, 17 / 6, 4 / 3, -(kl ** -2.0)))
    k30 = k3 + beta * k1
    k0sq = k1 * k1 + k2 * k2 + k30 * k30
    E = alpha_eps * L ** (5 / 3) * (k0sq * L * L) ** 2 / (1 + k0sq * L * L) ** (17 / 6)
    a = np.sqrt(E / (4 * math.pi)) / k0sq
    kh2 = k1 * k1 + k2 * k2
    C1 = beta * k1 * k1 * (k0sq - 2 * k30 * k30 + beta * k1 * k30) / (kk * kh2)
    ang = np.arctan2(beta * k1 * np.sqrt(kh2), k0sq - k30 * k1 * beta)
    C2 = k2 * k0sq / kh2**1.5 * ang
    z1 = C1 - k2 / k1 * C2
    z2 = k2 / k1 * C1 + C2
    # rows of D A_iso (A_iso = a [[0, k30, -k2], [-k30, 0, k1], [k2, -k1, 0]]); the third row of D is
    # (0, 0, k0^2 / k^2), so the third row of D A_iso is (k0^2 / k^2) a (k2, -k1, 0)
    m1 = (z1 * k2, k30 - z1 * k1, -k2 * np.ones_like(k1))
    m2 = (-k30 + z2 * k2, -z2 * k1, k1)
    return a, m1, m2, k0sq, kk, kh2


def mann_phi_components(k1, k2, k3, alpha_eps, L, gamma):
    """Phi_11, Phi_22, Phi_12, Phi_33 of the Mann tensor for arrays, numpy only.

    The same formulas as :func:`mann_amplitude` (PHYSICS.md section 1, scipy's
    hyp2f1 for the lifetime, the arctan branch made continuous with atan2),
    vectorised; no package code.  k1 must be non-zero.
    """
    a, m1, m2, k0sq, kk, kh2 = _mann_rows(k1, k2, k3, alpha_eps, L, gamma)
    P11 = a * a * sum(x * x for x in m1)
    P22 = a * a * sum(x * x for x in m2)
    P12 = a * a * sum(x * y for x, y in zip(m1, m2))
    P33 = a * a * (k0sq / kk) ** 2 * kh2
    return P11, P22, P12, P33


def mann_variances(alpha_eps, L, gamma, n_t=200, n_mu=48, n_phi=48):
    """Full-space variances (uu, vv, ww) = integral of Phi_ii over all wave vectors, numpy only.

    Spherical coordinates: trapezoid in ln k over [1e-5, 1e4] / L (the integrand
    k^3 Phi is smooth in ln k and vanishes at both ends), Gauss-Legendre in
    cos(polar angle), midpoints in azimuth; beyond k = 1e4 / L the tensor is
    isotropic and E = alpha_eps k^(-5/3), whose tail gives each component
    (2/3) integral E dk = alpha_eps K^(-2/3).  For Gamma = 0 this reproduces
    (2/3) B(5/2, 1/3) / 2 alpha_eps L^(2/3) to 2e-6.
    """
    t = np.linspace(math.log(1e-5 / L), math.log(1e4 / L), n_t)
    mu, w_mu = np.polynomial.legendre.leggauss(n_mu)
    ph = (np.arange(n_phi) + 0.5) * 2 * math.pi / n_phi
    T, M, PH = np.meshgrid(t, mu, ph, indexing="ij")
    k = np.exp(T)
    s = np.sqrt(1 - M * M)
    P11, P22, _, P33 = mann_phi_components(k * s * np.cos(PH), k * s * np.sin(PH), k * M, alpha_eps, L, gamma)
    w_t = np.full(n_t, t[1] - t[0])
    w_t[[0, -1]] *= 0.5
    W = w_t[:, None, None] * w_mu[None, :, None] * (2 * math.pi / n_phi) * k**3
    tail = alpha_eps * (1e4 / L) ** (-2.0 / 3.0)
    return tuple(float(np.sum(W * P)) + tail for P in (P11, P22, P33))


def misaligned_reference(k1, alpha_eps, L, gamma, theta_deg, zR, h=0.03):
    """A2012 Eqs. 12-14 at one k1 > 0 by an independent double integral.

    Inner k3 integral: k3 = +-exp(v), trapezoid in v with step h over
    [ln(min scale) - 25, ln(max scale) + 12] (the integrand is analytic in v
    near the real axis, so the trapezoid converges exponentially).  Outer k2
    integral: scipy.integrate.quad_vec (adaptive Gauss-Kronrod) on the pieces
    cut at 0 and at the weight's kink k2 = -k1 cot(theta).
    Returns (F_vs, F_vr, chi), two-sided.
    """
    from scipy.integrate import quad_vec

    th = math.radians(theta_deg)
    c, s = math.cos(th), math.sin(th)

    def phi2(k2):
        kh = math.hypot(k1, k2)
        lo, hi = math.log(min(kh, 1.0 / L)) - 25.0, math.log(max(kh, 1.0 / L)) + 12.0
        v = np.arange(lo, hi + h, h)
        ev = np.exp(v)
        tot = 0.0
        for sign in (1.0, -1.0):
            P11, P22, P12 = mann_phi_horizontal(k1, k2, sign * ev, alpha_eps, L, gamma)
            tot += h * np.sum((c * c * P11 + s * s * P22 + 2 * c * s * P12) * ev)
        return tot

    def f(k2):
        kn = abs(k1 * c + k2 * s)
        p = phi2(k2)
        return np.array([p, p * math.exp(-2 * zR * kn), p * math.exp(-zR * kn)])

    cuts = sorted({0.0} | ({-k1 * c / s} if s != 0.0 and c != 0.0 else set()))
    pieces = [(-np.inf, cuts[0])] + list(zip(cuts[:-1], cuts[1:])) + [(cuts[-1], np.inf)]
    tot = np.zeros(3)
    for a, b in pieces:
        tot += quad_vec(f, a, b, epsrel=1e-9, epsabs=0.0, limit=400)[0]
    return tuple(tot)


# =============================================================================
# turbulence plane generator (cwlidar_sim/turbulence/_kernels/plane.py: chol3,
# fill_plane_kernel)
# =============================================================================
def turbulence_fill_plane(phi_xy33, noise, n1_lo, scale):
    """Reference for ``fill_plane_kernel``: one mode at a time with numpy's Cholesky.

    ``phi_xy33`` holds the (positive definite) spectral matrices of all rows
    of the plane; ``noise`` (rows, Ny//2 + 1, 3, 2) the standard normals of
    rows n1_lo .. n1_lo + rows.  Returns the three half-spectrum rows
    ``scale * C (a + i b)`` with C the lower Cholesky factor.
    """
    rows, n2h = noise.shape[:2]
    out = np.zeros((3, rows, n2h), complex)
    for r in range(rows):
        for s2 in range(n2h):
            c = np.linalg.cholesky(phi_xy33[n1_lo + r, s2])
            z = noise[r, s2, :, 0].astype(float) + 1j * noise[r, s2, :, 1].astype(float)
            out[:, r, s2] = scale * (c @ z)
    return out


# =============================================================================
# sensors stage (cwlidar_sim/sensors)
# =============================================================================
def sensors_resample_a2012(x):
    """A2012 Eqs. 5-7 on a 1-D list, as printed: partitions of 16, output i = 1..5 weights
    samples 3(i-1)+1 .. 3(i-1)+4 (1-based) by {0.2(6-i), 1, 1, 0.2 i}, divided by 3.2."""
    out = []
    for p in range(len(x) // 16):
        part = x[16 * p: 16 * p + 16]
        for i in range(1, 6):
            w = ((6 - i) / 5, 1.0, 1.0, i / 5)
            acc = 0.0
            for n in range(1, 5):
                acc = acc + w[n - 1] * part[n + 3 * (i - 1) - 1]
            out.append(acc / 3.2)
    return out


def sensors_block_average(x, m, flags=None):
    """Block means over the finite samples of each whole block of m; (means, counts, OR of flags)."""
    means, counts, fl = [], [], []
    for b in range(len(x) // m):
        vals = [v for v in x[b * m: b * m + m] if math.isfinite(v)]
        counts.append(len(vals))
        means.append(sum(vals) / len(vals) if vals else math.nan)
        f = 0
        if flags is not None:
            for v in flags[b * m: b * m + m]:
                f |= int(v)
        fl.append(f)
    return means, counts, fl


def sensors_expected_spectrum(x_es, amp_s, window_n, rho, nf):
    """Expected signal periodogram by its defining sums (no recurrence, no FFT, no table):
    S[e, k] = sum_s amp_s (G(k - x_es) + G(k + x_es)),
    G(u) = sum_{|d|<N} R_w(d) rho^|d| cos(2 pi u d / N) / R_w(0)   (G is real: R_w is even)."""
    n = len(window_n)
    w = np.asarray(window_n, dtype=np.float64)
    r = np.array([sum(w[i] * w[i + d] for i in range(n - d)) for d in range(n)])
    a = r / r[0] * np.array([rho**d for d in range(n)])
    d = np.arange(1, n)

    def g(u):
        return a[0] + 2.0 * np.sum(a[1:] * np.cos(2.0 * math.pi * u * d / n))

    ne, ns = np.shape(x_es)
    out = np.zeros((ne, nf))
    for e in range(ne):
        for k in range(nf):
            for s in range(ns):
                out[e, k] += amp_s[s] * (g(k - x_es[e][s]) + g(k + x_es[e][s]))
    return out


# =============================================================================
# turbulence box generator (cwlidar_sim/turbulence/_kernels/: normal_at,
# normals_kernel, fill_box_kernel): counter-based ziggurat noise and the
# half spectrum of a small uncorrected box, one mode at a time.
# =============================================================================
_BOX_MASK = (1 << 64) - 1
_BOX_GOLDEN = 0x9E3779B97F4A7C15


def box_mix64(z):
    """SplitMix64 finaliser on Python ints."""
    z &= _BOX_MASK
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _BOX_MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _BOX_MASK
    return z ^ (z >> 31)


def box_ziggurat_tables(n=256, r=3.6541528853610088, bits=53):
    """Marsaglia & Tsang (2000) layers of exp(-x^2/2): edges x_0 (virtual) .. x_n = 0.

    Returns (w, k, f): x_i 2^-bits, floor(2^bits x_{i+1} / x_i) and f(x_i) with f(x_n) = 1.
    """
    def f(x):
        return math.exp(-0.5 * x * x)

    v = r * f(r) + math.sqrt(0.5 * math.pi) * math.erfc(r / math.sqrt(2.0))
    x = [v / f(r), r]
    while len(x) < n:
        x.append(math.sqrt(-2.0 * math.log(v / x[-1] + f(x[-1]))))
    x.append(0.0)
    w = [xi * 2.0**-bits for xi in x[:n]]
    k = [int(x[i + 1] / x[i] * 2.0**bits) for i in range(n)]
    fy = [f(xi) for xi in x[:n]] + [1.0]
    return w, k, fy


_BOX_ZIG = None


def box_first_word(key, c):
    """The 64-bit word normal ``c`` starts from: SplitMix64 output c under ``key``."""
    return box_mix64(int(key) + (int(c) + 1) * _BOX_GOLDEN)


def box_normal(key, key_b, c):
    """Normal number ``c`` of the box noise: ziggurat (bits 0-7 layer, bit 8 sign, bits 11-63
    position) on ``box_first_word``; rejected draws continue on the SplitMix64 stream started at
    mix64(key_b + (c + 1) G)."""
    global _BOX_ZIG
    if _BOX_ZIG is None:
        _BOX_ZIG = box_ziggurat_tables()
    w_tab, k_tab, f_tab = _BOX_ZIG
    r = 3.6541528853610088
    w = box_first_word(key, c)
    t = box_mix64(int(key_b) + (int(c) + 1) * _BOX_GOLDEN)

    def nxt():
        nonlocal t
        t = (t + _BOX_GOLDEN) & _BOX_MASK
        return box_mix64(t)

    def uniform(z):
        return ((z >> 11) + 0.5) * 2.0**-53

    while True:
        i = w & 0xFF
        sign = -1.0 if (w >> 8) & 1 else 1.0
        u = w >> 11
        x = u * w_tab[i]
        if u < k_tab[i]:
            return sign * x
        if i == 0:
            while True:
                a = -math.log(uniform(nxt())) / r
                b = -math.log(uniform(nxt()))
                if b + b > a * a:
                    return sign * (r + a)
        y = f_tab[i] + uniform(nxt()) * (f_tab[i + 1] - f_tab[i])
        if y < math.exp(-0.5 * x * x):
            return sign * x
        w = nxt()


def box_noise_keys(seed):
    """(key, key_b) of a seed: the first two 64-bit words of numpy's SeedSequence(seed)."""
    k = np.random.SeedSequence(seed).generate_state(2, dtype=np.uint64)
    return int(k[0]), int(k[1])


def _box_chol_lower(a):
    """Lower Cholesky factor of a symmetric positive semi-definite 3x3 matrix, column by column;
    a pivot <= 1e-12 of the largest diagonal entry gives a zero column."""
    c = [[0.0] * 3 for _ in range(3)]
    eps = 1e-12 * max(a[i][i] for i in range(3))
    for j in range(3):
        d = a[j][j] - sum(c[j][q] ** 2 for q in range(j))
        if d <= eps:
            continue
        c[j][j] = math.sqrt(d)
        for i in range(j + 1, 3):
            c[i][j] = (a[i][j] - sum(c[i][q] * c[j][q] for q in range(j))) / c[j][j]
    return c


def box_half_spectrum(shape, spacing, seed, alpha_eps, L, gamma):
    """Half spectrum of a zero-mean box with correction="none", by its definition.

    Mode n = (n1, n2, n3), n3 = 0 .. N3//2, with signed indices s_i (numpy's fftfreq signs: index
    N/2 of an even axis is -N/2; s3 = n3) has the counter index
    m = (s1 + 2^24) 2^36 + (s2 + 2^17) 2^18 + n3 (keyed by the wavenumber, not by the position)
    and normals a_j = z(6 m + 2 j), b_j = z(6 m + 2 j + 1) (``box_normal``); its coefficients are
    c_i = sqrt(dk1 dk2 dk3) sum_j M_ij(k_n) (a_j + i b_j) / sqrt(2) with M from ``mann_amplitude``
    and (k1, k2) in numpy's fftfreq order, k3 = n3 dk3.  In the z-Nyquist plane (even N3) M is
    the lower Cholesky factor of (Phi(k1, k2, pi/dz) + Phi(k1, k2, -pi/dz)) / 2 (a zero pivot
    gives a zero column).  In the planes n3 = 0 and n3 = N3/2, of each pair (n1, n2), (-n1, -n2)
    the one with the larger index n1 N2 + n2 is the conjugate of the other, a self-conjugate mode
    becomes sqrt(2) times its real part; c(0) = 0.  Returns (3, N1, N2, N3//2+1).
    """
    N1, N2, N3 = shape
    nh = N3 // 2 + 1
    key, key_b = box_noise_keys(seed)
    dk = [2.0 * math.pi / (n * d) for n, d in zip(shape, spacing)]
    out = np.zeros((3, N1, N2, nh), complex)
    for n1 in range(N1):
        k1 = dk[0] * (n1 if 2 * n1 < N1 else n1 - N1)
        for n2 in range(N2):
            k2 = dk[1] * (n2 if 2 * n2 < N2 else n2 - N2)
            for n3 in range(nh):
                s1 = n1 if 2 * n1 < N1 else n1 - N1
                s2 = n2 if 2 * n2 < N2 else n2 - N2
                m = ((s1 + 2**24) << 36) + ((s2 + 2**17) << 18) + n3
                z = [box_normal(key, key_b, 6 * m + j) for j in range(6)]
                if N3 % 2 == 0 and n3 == nh - 1:
                    amp = _box_chol_lower(np.mean([np.dot(a, np.transpose(a)) for a in (
                        np.array(mann_amplitude(k1, k2, sg * dk[2] * n3, alpha_eps, L, gamma)) for sg in (1, -1))],
                        axis=0))
                else:
                    amp = mann_amplitude(k1, k2, dk[2] * n3, alpha_eps, L, gamma)
                for i in range(3):
                    out[i, n1, n2, n3] = math.sqrt(dk[0] * dk[1] * dk[2] / 2.0) * sum(
                        amp[i][j] * complex(z[2 * j], z[2 * j + 1]) for j in range(3))
    planes = [0] + ([N3 // 2] if N3 % 2 == 0 else [])
    for n3 in planes:
        for n1 in range(N1):
            for n2 in range(N2):
                m1, m2 = (-n1) % N1, (-n2) % N2
                if (m1, m2) == (n1, n2):
                    out[:, n1, n2, n3] = math.sqrt(2.0) * out[:, n1, n2, n3].real
                elif n1 * N2 + n2 > m1 * N2 + m2:
                    out[:, n1, n2, n3] = np.conj(out[:, m1, m2, n3])
    out[:, 0, 0, 0] = 0.0
    return out


# =============================================================================
# signal stage, fused tier-3 path and row kernels (cwlidar_sim/signal/_kernels/:
# block_normals, tone_tables_kernel, synth_blocks_kernel, power_sum_kernel,
# combine_partials_kernel)
# =============================================================================
def signal_block_normals(key, block, n, noise_std=1.0):
    """Reference for ``block_normals(stream_start(key, block), ...)``: the stream's
    ``normal_pair`` sequence (exact ndtri), first n values."""
    st = signal_stream_start(key, block)
    out = []
    while len(out) < n:
        st, z0, z1 = signal_normal_pair(st)
        out += [z0, z1]
    return noise_std * np.array(out[:n])


def signal_tone_tables(phase_s, dtheta_s, n_fft, m_blocks, cells=4):
    """Reference for ``tone_tables_kernel`` (one estimate): cos/sin of each angle on its own.

    Returns ``tab[g, k, n]`` (cos(theta_s n) for k < cells, sin for k >= cells, s = cells g + k mod
    cells; padding cells: theta = 0) and the block phasors ``exp(i (phase_s + theta_s N i))``,
    shape (M, cells * groups), padding cells 1."""
    ns = len(dtheta_s)
    ng = -(-ns // cells)
    tab = np.zeros((ng, 2 * cells, n_fft))
    ph = np.ones((m_blocks, cells * ng), complex)
    for s in range(cells * ng):
        g, c = divmod(s, cells)
        th = float(dtheta_s[s]) if s < ns else 0.0
        for n in range(n_fft):
            tab[g, c, n] = math.cos(th * n)
            tab[g, cells + c, n] = math.sin(th * n)
        if s < ns:
            for i in range(m_blocks):
                a = float(phase_s[s]) + th * n_fft * i
                ph[i, s] = complex(math.cos(a), math.sin(a))
    return tab, ph.real, ph.imag


def signal_gaussian_deposit(x_s, amp_s, n_fft, m, tau_g, half):
    """Reference for ``gaussian_deposit_rows`` (one row): every weight from its own exponential.

    ``out[(m0 + j) mod M] += amp_s exp(-((m0 + j) h - theta_s)^2 / (4 tau_g))``, |j| <= half,
    ``theta_s = 2 pi (x_s mod N) / N``, ``m0`` the grid point nearest theta_s, ``h = 2 pi / M``."""
    out = [0.0] * m
    h = 2.0 * math.pi / m
    for x, a in zip(x_s, amp_s):
        th = 2.0 * math.pi * (x % n_fft) / n_fft
        m0 = int(math.floor(th / h + 0.5))
        for j in range(-half, half + 1):
            d = (m0 + j) * h - th
            out[(m0 + j) % m] += a * math.exp(-d * d / (4.0 * tau_g))
    return np.array(out)


def signal_colour_start(key, estimate, cf):
    """Reference for ``colour_start``: L (z0, z1) from the first normal pair of the estimate's start stream."""
    skey = signal_mix64(int(key) ^ signal_mix64(int(estimate) + _SIG_GOLDEN))
    _, z0, z1 = signal_normal_pair(signal_stream_start(skey, 1 << 62))
    return [cf[5] * z0, cf[6] * z0 + cf[7] * z1]


def signal_colour_noise(w_n, cf, state, segments=4):
    """Reference for ``colour_noise_block``: the blocked scan in the kernel's order of operations.

    The input is the white normals times ``b_1`` (``w = b_1 z``, as the kernel takes them);
    ``y = a0 z + u_1 + u_2``, ``u_c[n] = rho_c u_c[n-1] + b_c z[n]``, from ``state`` (u_c[-1]),
    as ``u_1 = rho_1 u_1 + w``, ``u_2 = rho_2 u_2 + k_2 w``, ``y = (k_0 w + u_1) + u_2``
    (``k_0 = a0 / b_1``, ``k_2 = b_2 / b_1``).  The block is cut into ``segments`` segments
    (the last takes the remainder), each scanned from zero, then ``rho_c^(k+1) C_c`` added
    with the carried state ``C_c``.  Returns (y, new state).  Plain Python floats: the same
    IEEE operations as the kernel.
    """
    a0, b1, b2, r1, r2 = (float(c) for c in cf[:5])
    k0, k2 = a0 / b1, b2 / b1
    n = len(w_n)
    g = n // segments
    bounds = [(s * g, n if s == segments - 1 else (s + 1) * g) for s in range(segments)]
    y = [0.0] * n
    ends = []
    for lo, hi in bounds:
        p = q = 0.0
        for k in range(lo, hi):
            w = float(w_n[k])
            p = r1 * p + w
            q = r2 * q + k2 * w
            y[k] = (k0 * w + p) + q
        ends.append((p, q))
    # the powers rho^(k+1) by repeated multiplication, as _filter_powers makes them
    pw1, pw2 = [r1], [r2]
    for _ in range(n - 1):
        pw1.append(pw1[-1] * r1)
        pw2.append(pw2[-1] * r2)
    c1, c2 = float(state[0]), float(state[1])
    for (lo, hi), (e1, e2) in zip(bounds, ends):
        if hi == lo:
            continue
        for k in range(hi - lo):
            y[lo + k] += pw1[k] * c1 + pw2[k] * c2
        c1 = pw1[hi - lo - 1] * c1 + e1
        c2 = pw2[hi - lo - 1] * c2 + e2
    return np.array(y), [c1, c2]


def signal_noise_filter_correlation(cf, lags):
    """Correlation of ``a0 z + u_1 + u_2`` at the given lags from its impulse response ``h_0 = a0 + b_1 + b_2``,
    ``h_k = b_1 rho_1^k + b_2 rho_2^k``: ``r(tau) = sum_k h_k h_{k+tau}`` (truncated where rho^k < 1e-18)."""
    a0, b1, b2, r1, r2 = (float(c) for c in cf[:5])
    lags = [int(t) for t in lags]
    rmax = max(r1, r2)
    n_terms = (int(math.ceil(math.log(1e-18) / math.log(rmax))) if rmax > 0 else 1) + max(lags) + 1
    k = np.arange(n_terms, dtype=np.float64)
    h = b1 * r1**k + b2 * r2**k
    h[0] += a0
    return np.array([np.dot(h[: n_terms - t], h[t:]) for t in lags])


def signal_synth_blocks(key, block0, b_lo, b_hi, m_blocks, n_sub, amp_re_st, amp_im_st, phase_es, dtheta_es,
                        noise_std, window_n, colour=None):
    """Reference for ``synth_blocks_kernel``: every tone sample from cos/sin of its own phase
    ``phase_es[e, s] + dtheta_es[e, s] (N i + n)`` (block i of estimate e), no recurrence.

    ``colour = (ckey, ce0, cf, state)``: the normals coloured by :func:`signal_colour_noise`,
    the state drawn by :func:`signal_colour_start` at each estimate's first block (``state``,
    a list, is updated in place)."""
    n = len(window_n)
    ln = n // n_sub
    ns = len(amp_re_st)
    out = np.zeros((b_hi - b_lo, n))
    for b in range(b_lo, b_hi):
        e, i = divmod(b, m_blocks)
        x = signal_block_normals(key, block0 + b, n, noise_std)
        if colour is not None:
            ckey, ce0, cf, state = colour
            if i == 0:
                state[:] = signal_colour_start(ckey, ce0 + e, cf)
            x, state[:] = signal_colour_noise(float(cf[1]) * x, cf, state)
        for s in range(ns):
            for k in range(n):
                ph = phase_es[e][s] + dtheta_es[e][s] * (n * i + k)
                a = complex(amp_re_st[s][b * n_sub + k // ln], amp_im_st[s][b * n_sub + k // ln])
                x[k] += (a * complex(math.cos(ph), math.sin(ph))).real
        out[b - b_lo] = x * np.asarray(window_n)
    return out


def signal_power_sum(spec_bf, n_rows):
    """Reference for ``power_sum_kernel``: sum of |X|^2 over the first n_rows rows."""
    nf = len(spec_bf[0])
    out = [0.0] * nf
    for b in range(n_rows):
        for k in range(nf):
            out[k] += abs(complex(spec_bf[b][k])) ** 2
    return np.array(out)


def signal_continuum_moments(x_s, amp_s, g_t, rn_t, window_n, m_blocks):
    """Reference for ``spectral.continuum_moments`` (one estimate): the defining lag sums, plain numpy.

    Block-lag correlation of bin k, ``c_k(j) = sum_{|d|<N} (R_w(d)/R_w(0)) R(jN + d) exp(-2i pi k d / N)``
    with ``R(tau) = g(|tau|) sum_s 2 amp_s cos(2 pi x_s tau / N) + rn(|tau|)``; the mean of an
    M-block average is ``c_k(0) + 1`` and its variance ``[(c_k(0) + 1)^2 + 2 sum_j (1 - j/M)
    |c_k(j)|^2] / M`` (twice at 0 and N/2).  ``g_t``, ``rn_t`` hold lags 0..len-1 (0 beyond).
    """
    n = window_n.size
    rw = np.array([np.dot(window_n[: n - d], window_n[d:]) for d in range(n)])
    rw = rw / rw[0]
    nt = g_t.size

    def corr(tau):
        tau = abs(tau)
        if tau >= nt:
            return 0.0
        c = g_t[tau] * sum(2.0 * a * math.cos(2.0 * math.pi * x * tau / n) for x, a in zip(x_s, amp_s))
        return c + rn_t[tau]

    nf = n // 2 + 1
    nj = (nt + n - 1) // n + 1
    ck = np.zeros((nj, nf), dtype=complex)
    for j in range(nj):
        r = np.array([rw[abs(d)] * corr(j * n + d) for d in range(-(n - 1), n)])
        d = np.arange(-(n - 1), n)
        for k in range(nf):
            ck[j, k] = np.sum(r * np.exp(-2j * math.pi * k * d / n))
    mean = ck[0].real + 1.0
    q = sum((1.0 - j / m_blocks) * np.abs(ck[j]) ** 2 for j in range(1, nj))
    var = (mean**2 + 2.0 * q) / m_blocks
    var[0] *= 2.0
    var[-1] *= 2.0
    return mean, var


# =============================================================================
# cup anemometer (cwlidar_sim/sensors/_cup_kernels.py)
# =============================================================================
def cup_first_order(V, h, l0, mean_speed, speed_dependent=False):
    """Reference for ``first_order_kernel``: the convolution integral, input linear between samples.

    ``S(t_{n+1}) = a S(t_n) + int_0^h exp(-(h - s)/tau) / tau * V(t_n + s) ds`` with V linear,
    integrated by composite Simpson with 2000 panels (not the closed form).
    """
    out = [float(V[0])]
    for i in range(len(V) - 1):
        tau = l0 / (max(out[-1], 1e-3) if speed_dependent else mean_speed)
        s = np.linspace(0.0, h, 2001)
        g = np.exp(-(h - s) / tau) / tau * (V[i] + (V[i + 1] - V[i]) * s / h)
        wts = np.ones(2001)
        wts[1:-1:2] = 4
        wts[2:-1:2] = 2
        integral = (h / 2000) / 3 * np.dot(wts, g)
        out.append(math.exp(-h / tau) * out[-1] + integral)
    return np.array(out)


# =============================================================================
# CS's conical filter model (cwlidar_sim/analysis/cs_model.py), by quadrature, not closed forms
# =============================================================================
CS_SHAPES = {"boxcar": lambda x, l: np.ones_like(x), "rectified_sine": lambda x, l: np.abs(np.sin(np.pi * x / l)),
             "rectified_cosine": lambda x, l: np.abs(np.cos(np.pi * x / l))}


def _gauss_legendre(n):
    """Gauss-Legendre nodes and weights on [-1, 1] (Golub-Welsch on the tridiagonal Jacobi matrix, cached)."""
    if n not in _GL_CACHE:
        from scipy.linalg import eigh_tridiagonal

        j = np.arange(1, n)
        x, v = eigh_tridiagonal(np.zeros(n), j / np.sqrt(4.0 * j * j - 1.0))
        _GL_CACHE[n] = (x, 2.0 * v[0] ** 2)
    return _GL_CACHE[n]


_GL_CACHE = {}


def cs_scan_transfer_quadrature(k, length, kind, n=800):
    """|f_hat(k) / f_hat(0)|^2 of the weighting ``CS_SHAPES[kind]`` on |x| <= l/2, by Gauss-Legendre in x.

    The weighting is even and smooth on [0, l/2], so ``f_hat(k) = 2 int_0^{l/2} f(x) cos(k x) dx``.
    Accurate while k l / 2 stays below about n / 4 rad.
    """
    x, w = _gauss_legendre(n)
    x = 0.25 * length * (x + 1.0)
    w = 0.25 * length * w
    f = CS_SHAPES[kind](x, length)
    # an elementwise sum, not a BLAS product: BLAS threads stall on a loaded machine
    ft = np.sum(np.cos(np.multiply.outer(np.asarray(k, dtype=np.float64), x)) * (w * f), axis=-1) / np.sum(w * f)
    return ft**2


def cs_kaimal_one_sided(k, z, u_star):
    """Kaimal's neutral u, v, w spectra written from the formulas (Kaimal et al. 1972; CS Eq. 9), one-sided."""
    f = k * z / (2.0 * math.pi)
    c = u_star**2 * z / (2.0 * math.pi)
    return (c * 102.0 / (1.0 + 33.0 * f) ** (5.0 / 3.0), c * 17.0 / (1.0 + 9.5 * f) ** (5.0 / 3.0),
            c * 2.1 / (1.0 + 5.3 * f ** (5.0 / 3.0)))


def cs_model_quadrature(z, U, n_rev, zR, half_angle_deg=30.0, u_star=1.0, k_lo=1e-6, n_panels=80, order=8):
    """CS's filtered Kaimal integrals by composite Gauss-Legendre in ln k, the scan filters by quadrature in x.

    Returns lidar_var_u (F_u L_lor L_u) and hp_i (F_i L_lor (1 - L_i)) for u, v, w; l_az = D + U (n - 1/2)
    with D = 2 z tan Phi and a 1 s revolution; L_lor = exp(-2 zR k).  The upper limit 40 / (2 zR) leaves
    out exp(-40) of the probe-filtered integrands.
    """
    phi = math.radians(half_angle_deg)
    l_az = 2.0 * z * math.tan(phi) + U * (n_rev - 0.5)
    k_hi = 20.0 / zR
    edges = np.linspace(math.log(k_lo), math.log(k_hi), n_panels + 1)
    t, wt = np.polynomial.legendre.leggauss(order)
    mid, half = 0.5 * (edges[1:] + edges[:-1]), 0.5 * np.diff(edges)
    s = (mid[:, None] + half[:, None] * t[None, :]).ravel()
    ws = (half[:, None] * wt[None, :]).ravel()
    k = np.exp(s)
    dk = ws * k
    Fu, Fv, Fw = cs_kaimal_one_sided(k, z, u_star)
    lor = np.exp(-2.0 * zR * k)
    Lu, Lv, Lw = (cs_scan_transfer_quadrature(k, l_az, kind) for kind in ("rectified_sine", "rectified_cosine",
                                                                           "boxcar"))
    return {"lidar_var_u": float(np.dot(Fu * lor * Lu, dk)), "hp_u": float(np.dot(Fu * lor * (1 - Lu), dk)),
            "hp_v": float(np.dot(Fv * lor * (1 - Lv), dk)), "hp_w": float(np.dot(Fw * lor * (1 - Lw), dk)),
            "l_az": l_az}


# =============================================================================
# turbulence conditioning (cwlidar_sim/turbulence/conditioning.py): dense Gaussian conditioning
# =============================================================================
def conditioning_box_covariance(shape, spacing, alpha_eps, L, gamma):
    """Covariance matrix of (u, v, w) at every node of a box with correction="none", from its definition.

    Odd sizes only (no Nyquist modes, so every mode is the plain tensor at its wave vector):
    ``Sigma[(i, a), (j, b)] = sum over the modes k != 0 of dk1 dk2 dk3 (M M^T)_ij(k) cos(k.(x_a - x_b))``
    with M from ``mann_amplitude``; component-major order, nodes in C order of (ix, iy, iz).
    """
    if any(n % 2 == 0 for n in shape):
        raise ValueError("odd sizes only")
    dk = [2.0 * math.pi / (n * d) for n, d in zip(shape, spacing)]
    idx = [np.arange(n) - n // 2 for n in shape]  # signed mode indices, symmetric
    K = np.array(np.meshgrid(*[i * d for i, d in zip(idx, dk)], indexing="ij")).reshape(3, -1).T
    phi = np.zeros((K.shape[0], 3, 3))
    for m, (k1, k2, k3) in enumerate(K):
        a = np.array(mann_amplitude(k1, k2, k3, alpha_eps, L, gamma))
        phi[m] = a @ a.T * dk[0] * dk[1] * dk[2]
    X = np.array(np.meshgrid(*[np.arange(n) * d for n, d in zip(shape, spacing)], indexing="ij")).reshape(3, -1).T
    N = X.shape[0]
    lag = X[:, None, :] - X[None, :, :]  # (N, N, 3)
    cos = np.cos(np.einsum("abd,md->abm", lag, K))  # (N, N, modes)
    S = np.zeros((3 * N, 3 * N))
    for i in range(3):
        for j in range(3):
            S[i * N:(i + 1) * N, j * N:(j + 1) * N] = cos @ phi[:, i, j]
    return S


def conditioning_dense(Sigma, Hm, d, noise_var):
    """Mean and covariance of x ~ N(0, Sigma) given d = Hm x + e, e ~ N(0, diag(noise_var)) (textbook formulas)."""
    S = Hm @ Sigma @ Hm.T + np.diag(noise_var)
    K = np.linalg.solve(S, Hm @ Sigma).T
    return K @ d, Sigma - K @ Hm @ Sigma


def conditioning_trilinear_row(shape, spacing, p, comp):
    """Row of the measurement matrix: component ``comp`` at point p, trilinear, x periodic (as beam.sample_los)."""
    N = int(np.prod(shape))
    row = np.zeros(3 * N)
    corners = []
    for ax in range(3):
        f = p[ax] / spacing[ax]
        if ax == 0:
            i = int(math.floor(f))
            t = f - i
            corners.append([(i % shape[0], 1 - t), ((i + 1) % shape[0], t)])
        else:
            i = min(int(math.floor(f)), shape[ax] - 2)
            t = f - i
            corners.append([(i, 1 - t), (i + 1, t)])
    for ix, bx in corners[0]:
        for iy, by in corners[1]:
            for iz, bz in corners[2]:
                row[comp * N + (ix * shape[1] + iy) * shape[2] + iz] += bx * by * bz
    return row


def mann_one_point(k1, alpha_eps, L, gamma, h=0.02):
    """Two-sided one-point spectra F11, F22, F33 at one k1 > 0 by an independent quadrature, numpy only.

    The trapezoid rule after ``k2 = k1 sinh(u)`` (u >= 0, the integrand being
    even in k2) and ``k3 = c + k1 sinh(v)``, with c the k3 of the shear peak
    on k2 = 0 (where k3 + beta k1 = 0, found by bisection with scipy's hyp2f1):
    steps of ``k1 h`` at the peak, growing geometrically away from it, so
    every scale from k1 to 1/L and beyond is resolved; the integrand of
    :func:`mann_phi_components` decays like exp(-14/3 |u|), so the ranges end
    where it is below 1e-13 of its peak.  For k1 L >= 0.03 and Gamma <= 8,
    halving h changes nothing above 2e-9; below that the steps near k3 = 0
    (|c| h there) need a smaller h (at k1 L = 0.01, Gamma = 8: 1e-6 between
    h = 0.02 and 0.01).
    """
    from scipy.special import hyp2f1

    def beta_of(k):
        kl = k * L
        return gamma * kl ** (-2.0 / 3.0) / math.sqrt(hyp2f1(1 / 3, 17 / 6, 4 / 3, -(kl ** -2.0)))

    lo, hi = 0.0, beta_of(k1) if gamma > 0 else 0.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mid < beta_of(k1 * math.sqrt(1 + mid * mid)) else (lo, mid)
    c = -0.5 * (lo + hi) * k1
    top = max(1.0 / L, k1, abs(c)) * 1e7 / k1
    u = np.arange(0.0, math.asinh(top) + h, h)
    w_u = np.full(u.size, h * 2.0)  # both signs of k2
    w_u[0] = h
    v = np.arange(-math.asinh(top) - h, math.asinh(top) + h, h)
    k2 = k1 * np.sinh(u)[:, None]
    k3 = c + k1 * np.sinh(v)[None, :]
    jac = (k1 * np.cosh(u) * w_u)[:, None] * (k1 * np.cosh(v) * h)[None, :]
    P11, P22, _, P33 = mann_phi_components(k1, k2, k3, alpha_eps, L, gamma)
    return tuple(float(np.sum(jac * P)) for P in (P11, P22, P33))


# =============================================================================
# turbulence files (cwlidar_sim/turbulence/io_turbsim.py, io_bladed.py): the bytes, from the formats' specs
# =============================================================================
# Written value by value with struct from TurbSim's writers WrBinTURBSIM and WrBinBLADED (OpenFAST
# modules/turbsim/src/TS_FileIO.f90) and InflowWind's readers of the same files; no numpy.  The fields are
# nested lists [time step][z row][y column] of the values at the rotor, u as the whole wind.
def _f32(x):
    """x rounded to float32, as a Python float."""
    import struct

    return struct.unpack("<f", struct.pack("<f", x))[0]


def _nint16(x):
    """Fortran NINT (half away from zero), clipped to int16."""
    i = int(math.copysign(math.floor(abs(x) + 0.5), x))
    return min(32767, max(-32768, i))


def turbsim_bts_bytes(u, v, w, dz, dy, dt, mean_speed, hub_height, z_bottom, description, periodic=True):
    """A TurbSim .bts file: the 70-byte header, the description, then int16 (t, z, y, component)."""
    import struct

    nt, nz, ny = len(u), len(u[0]), len(u[0][0])
    comps = (u, v, w)
    slope, offset = [], []
    for comp in comps:
        values = [comp[t][k][j] for t in range(nt) for k in range(nz) for j in range(ny)]
        lo, hi = min(values), max(values)
        s = _f32(65535.0 / (hi - lo)) if hi > lo else 1.0
        slope.append(s)
        offset.append(_f32(-32768.0 - s * lo))
    out = bytearray(struct.pack("<h", 8 if periodic else 7))
    for n in (nz, ny, 0, nt):
        out += struct.pack("<i", n)
    for x in (dz, dy, dt, mean_speed, hub_height, z_bottom):
        out += struct.pack("<f", x)
    for s, o in zip(slope, offset):
        out += struct.pack("<f", s) + struct.pack("<f", o)
    out += struct.pack("<i", len(description)) + description.encode("ascii")
    for t in range(nt):
        for k in range(nz):
            for j in range(ny):
                for c in range(3):
                    out += struct.pack("<h", _nint16(slope[c] * comps[c][t][k][j] + offset[c]))
    return bytes(out)


def bladed_wnd_bytes(u, v, w, dz, dy, dx, mean_speed, z_centre, ti_percent, seed, left_hand_rule=True):
    """A TurbSim-style Bladed .wnd file: the 104-byte header (id -99, type 4), then int16 (t, z, y, component).

    ``u`` is the whole wind; each value is stored as (value - mean) / (U TI / 100 / 1000), v negated under
    the left-hand rule.
    """
    import struct

    nt, nz, ny = len(u), len(u[0]), len(u[0][0])
    out = bytearray(struct.pack("<h", -99) + struct.pack("<h", 4) + struct.pack("<i", 3))
    for x in (0.0, 0.0, z_centre, *ti_percent, dz, dy, dx):
        out += struct.pack("<f", x)
    out += struct.pack("<i", nt // 2)
    for x in (mean_speed, 0.0, 0.0, 0.0):
        out += struct.pack("<f", x)
    for n in (0, seed, nz, ny):
        out += struct.pack("<i", n)
    for _ in range(6):
        out += struct.pack("<f", 0.0)
    u32 = _f32(mean_speed)
    scale = [0.001 * u32 * _f32(t) / 100.0 for t in ti_percent]
    mean = (u32, 0.0, 0.0)
    sign = (1.0, -1.0 if left_hand_rule else 1.0, 1.0)
    comps = (u, v, w)
    for t in range(nt):
        for k in range(nz):
            for j in range(ny):
                for c in range(3):
                    out += struct.pack("<h", _nint16(sign[c] * (comps[c][t][k][j] - mean[c]) / scale[c]))
    return bytes(out)


# =============================================================================
# analysis stage (cwlidar_sim/analysis/linear_theory.py): spectra of linear functionals
# =============================================================================
def linear_functional_cross_spectrum(k1, alpha_eps, L, gamma, U, looks_a, looks_b, h=0.05):
    """Two-sided ``integral g_a^H Phi g_b dk2 dk3`` at one k1 > 0 for horizontal point looks, plain numpy.

    ``looks_*`` are lists of ``(weight, (nx, ny), (x, y, z), t)``: the
    functional ``sum weight * (nx u + ny v)(x, y, z)`` taken at time t under
    Taylor's hypothesis (mean wind U along +x), so
    ``g = sum weight (nx, ny) exp(i (k.p - k1 U t))``.  The tensor is
    :func:`mann_phi_components` (no package code); the (k2, k3) plane is
    summed on a tensor product of the trapezoid rule in ``v`` with ``k = +-exp(v)``
    in each direction, step ``h`` over ``[ln(min scale) - 20, ln(max scale) + 9]``.
    """
    lo = math.log(min(k1, 1.0 / L)) - 20.0
    hi = math.log(max(k1, 1.0 / L)) + 9.0
    v = np.arange(lo, hi + h, h)
    ev = np.exp(v)
    q = np.concatenate([-ev[::-1], ev])
    wq = np.concatenate([ev[::-1], ev]) * h
    total = 0.0 + 0.0j
    for k2, w2 in zip(q, wq):
        k3 = q
        P11, P22, P12, _ = mann_phi_components(k1, k2, k3, alpha_eps, L, gamma)

        def g(looks):
            gx = np.zeros(k3.size, dtype=complex)
            gy = np.zeros(k3.size, dtype=complex)
            for c, (nx, ny), (x, y, z), t in looks:
                e = np.exp(1j * (k1 * (x - U * t) + k2 * y + k3 * z))
                gx += c * nx * e
                gy += c * ny * e
            return gx, gy

        ax, ay = g(looks_a)
        bx, by = g(looks_b)
        val = np.conj(ax) * (P11 * bx + P12 * by) + np.conj(ay) * (P12 * bx + P22 * by)
        total += w2 * np.sum(wq * val)
    return total


def mann_phi_matrix(k1, k2, k3, alpha_eps, L, gamma):
    """The whole Mann tensor ``Phi_ij`` (shape (..., 3, 3)) for arrays, numpy only: :func:`mann_phi_components`'
    rows of ``D A_iso`` (the same formulas) with the third row, ``Phi = (D A_iso)(D A_iso)^T``."""
    a, m1, m2, k0sq, kk, kh2 = _mann_rows(k1, k2, k3, alpha_eps, L, gamma)
    k1, k2, _ = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (k1, k2, k3)))
    m = np.stack([np.stack(m1, -1), np.stack(m2, -1),
                  (k0sq / kk)[..., None] * np.stack([k2, -k1 * np.ones_like(k2), 0.0 * k2], -1)], -2)
    return (a * a)[..., None, None] * np.einsum("...ik,...jk->...ij", m, m)


def linear_functional_matrix(k1, k2, k3, w, alpha_eps, L, gamma, U, outputs):
    """``2 sum_n w_n g_a(k_n)^H Phi(k_n) g_b(k_n)`` at one k1 > 0 over given (k2, k3) nodes, plain numpy.

    ``outputs`` is a list (one per output a) of lists of looks ``(w_c, p, n, z_R, t, tau)``: the output
    ``sum w_c . (the Lorentzian average exp(-z_R |q|) along n of u about p)`` taken at time t through a
    first-order filter of time constant tau (0: none), under Taylor's hypothesis (U along +x), so
    ``g_a = sum w_c exp(i (k.p - k1 U t)) exp(-z_R |k.n|) / (1 - i k1 U tau)`` (``H(omega)`` at
    ``omega = -k1 U``).  The tensor is :func:`mann_phi_matrix` (no package code).
    """
    k2 = np.asarray(k2, dtype=float)
    k3 = np.asarray(k3, dtype=float)
    phi = mann_phi_matrix(k1, k2, k3, alpha_eps, L, gamma)
    g = np.zeros((len(outputs), k2.size, 3), dtype=complex)
    for o, looks in enumerate(outputs):
        for w_c, p, n, zr, t, tau in looks:
            e = (np.exp(1j * (k1 * (p[0] - U * t) + k2 * p[1] + k3 * p[2]))
                 * np.exp(-zr * np.abs(k1 * n[0] + k2 * n[1] + k3 * n[2])) / (1.0 - 1j * k1 * U * tau))
            g[o] += e[:, None] * np.asarray(w_c, dtype=float)[None, :]
    return 2.0 * np.einsum("n,ani,nij,bnj->ab", np.asarray(w, dtype=float), np.conj(g), phi, g)


def log_plane_nodes(k1, L, h):
    """Tensor-product trapezoid nodes (k2, k3, weight) over the plane, ``k = +-exp(v)`` in each direction, step
    ``h`` in v over ``[ln(min(k1, 1/L)) - 20, ln(max(k1, 1/L)) + 9]`` (:func:`linear_functional_cross_spectrum`'s)."""
    lo = math.log(min(k1, 1.0 / L)) - 20.0
    hi = math.log(max(k1, 1.0 / L)) + 9.0
    v = np.arange(lo, hi + h, h)
    ev = np.exp(v)
    q = np.concatenate([-ev[::-1], ev])
    wq = np.concatenate([ev[::-1], ev]) * h
    k2, k3 = (a.ravel() for a in np.meshgrid(q, q, indexing="ij"))
    return k2, k3, np.outer(wq, wq).ravel()
