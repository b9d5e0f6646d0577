"""Least squares of a trace's level, drift and ball-pass harmonics, and the Gauss-Newton step
on their frequency (:mod:`signatelec.estimation.analysis` fits each trace with them).

Rows are traces (or windows of one) sampled at ``tc``, the time from the middle of the trace;
the design's columns are 1, t, cos and sin of 2 pi k f t for the fitted harmonics k [, and
t cos, t sin for the frequency step]. Their normal equations are formed without the design
(:func:`harmonic_equations`: closed-form Gram matrix, phasor sums for design r), the design
itself only where a trace is too short or the equations singular. The sums over the samples
(design r, the residual) are numba passes over the phasors (``cache=True``: compiled once,
~3 s, then loaded from the cache in ~0.3 s per process, as engines/dem/ensemble.py's kernels).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Samples per block of the least-squares products: below the size at which OpenBLAS spreads a
#: product over threads, which on busy cores makes it ~30x slower, not faster.
_BLOCK = 1024


@njit(cache=True, error_model="numpy")
def pairwise_sum(a: np.ndarray) -> float:
    """np.add.reduce of a contiguous 1-D float array, as numpy adds it (the same bits, the
    sign of a zero sum included: numpy's starts from +0): below 8 values one after the other,
    up to 128 in eight running sums then pairwise, beyond that the two halves (cut at a
    multiple of 8) summed so and added."""
    n = a.size
    if n < 8:
        s = 0.0
        for i in range(n):
            s += a[i]
        return s
    if n > 128:
        half = n // 2
        half -= half % 8
        return pairwise_sum(a[:half]) + pairwise_sum(a[half:])
    # eight running sums in registers (an array of them cost an allocation per call)
    r0, r1, r2, r3, r4, r5, r6, r7 = a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]
    i = 8
    while i < n - n % 8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        s += a[i]
        i += 1
    return s + 0.0  # a sum of -0's is +0, as from numpy's start


@njit(cache=True, error_model="numpy")
def _row_sums(r: np.ndarray, tc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sum r, sum r tc) per row, numpy's sums (:func:`pairwise_sum`): the same numbers as
    ``r.sum(axis=1)`` and ``(r * tc).sum(axis=1)``, without the product's temporary."""
    rows, n = r.shape
    total, moment = np.empty(rows), np.empty(rows)
    product = np.empty(n)
    for w in range(rows):
        total[w] = pairwise_sum(r[w])
        for i in range(n):
            product[i] = r[w, i] * tc[i]
        moment[w] = pairwise_sum(product)
    return total, moment


@njit(cache=True, error_model="numpy")
def _centred(r: np.ndarray) -> np.ndarray:
    """r less its mean per row in one pass: the same numbers as
    ``r - r.mean(axis=1, keepdims=True)`` (numpy's sum, :func:`pairwise_sum`)."""
    out = np.empty_like(r)
    n = r.shape[1]
    for w in range(r.shape[0]):
        mean = pairwise_sum(r[w]) / n
        for i in range(n):
            out[w, i] = r[w, i] - mean
    return out


def _normal_equations(design: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """design design' and design r per row, summed over blocks of samples (design: rows,
    columns, samples)."""
    rows, m, n = design.shape
    gram, rhs = np.zeros((rows, m, m)), np.zeros((rows, m))
    for i in range(0, n, _BLOCK):
        d = design[:, :, i : i + _BLOCK]
        gram += np.matmul(d, d.transpose(0, 2, 1))
        rhs += np.matmul(d, r[:, i : i + _BLOCK, None])[:, :, 0]
    return gram, rhs


def apply_design(design: np.ndarray, sol: np.ndarray) -> np.ndarray:
    """design' sol per row, column by column (no threaded BLAS either)."""
    out = np.zeros((design.shape[0], design.shape[2]))
    for j in range(design.shape[1]):
        out += sol[:, j, None] * design[:, j]
    return out


def _solve_one(design: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Least squares of one row (design: columns, samples) by lstsq."""
    m, n = design.shape
    if n < m:
        sol = np.linalg.lstsq(design[:n].T, r, rcond=None)[0]
        return np.concatenate([sol, np.zeros(m - n)])
    return np.linalg.lstsq(design.T, r, rcond=None)[0]


def solve_normal(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray | None:
    """The normal equations' solution per row (a 1e-12 ridge), None if they are singular."""
    m = gram.shape[1]
    ridge = 1e-12 * np.trace(gram, axis1=1, axis2=2)[:, None, None] / m * np.eye(m)
    try:
        return np.linalg.solve(gram + ridge, rhs[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:
        return None


def solve_rows(design: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares per row by the normal equations (columns nearly orthogonal over many
    periods); lstsq when the trace is too short for that or the equations are singular.
    Returns (solution, design r) per row: r.r - solution.(design r) is the residual sum of
    squares (the residual is orthogonal to the columns)."""
    rows, m, n = design.shape
    if n >= 4 * m:
        gram, rhs = _normal_equations(design, r)
        sol = solve_normal(gram, rhs)
        if sol is not None:
            return sol, rhs
    sol = np.array([_solve_one(design[w], r[w]) for w in range(rows)])
    return sol, np.matmul(design, r[:, :, None])[:, :, 0]


def phasor_factors(tc: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(block starts, within a block) of :func:`phasors`: exp(2 pi i f[w] tc) per row, tc
    uniform, is ``starts[w, b] * within[w, j]`` at sample b B + j (B ~ sqrt(n) samples a
    block); the compiled passes form the product sample by sample instead of reading it."""
    n = tc.size
    dt = tc[1] - tc[0] if n > 1 else 0.0
    block = max(1, int(math.isqrt(n)))
    return _unit_phasors(np.asarray(f, dtype=float), float(tc[0]), dt, block, -(-n // block))


@njit(cache=True, error_model="numpy")
def _unit_phasors(f, t0, dt, block, blocks):
    """(exp(2 pi i f[w] (dt B b)), exp(2 pi i f[w] (t0 + dt j))) for b < ``blocks``, j < B =
    ``block``, as (cos, sin) of the phase: the same numbers as numpy's exp of the imaginary
    phase 2 pi f t (its real part 0), compiled (~2x faster than np.exp's complex loop)."""
    starts = np.empty((f.size, blocks), np.complex128)
    within = np.empty((f.size, block), np.complex128)
    for w in range(f.size):
        omega = 2.0 * math.pi * f[w]
        for j in range(block):
            phase = omega * (t0 + dt * j)
            within[w, j] = complex(math.cos(phase), math.sin(phase))
        for b in range(blocks):
            phase = omega * (dt * block * b)
            starts[w, b] = complex(math.cos(phase), math.sin(phase))
    return starts, within


def phasors(tc: np.ndarray, f: np.ndarray) -> np.ndarray:
    """exp(2 pi i f[w] tc) per row, tc uniform: the product of a phasor over a block of
    sqrt(n) samples and one per block start (2 sqrt(n) complex exponentials per row instead
    of n; the phase of each factor is exact to round-off, as is their product)."""
    n = tc.size
    if n < 2:
        return np.exp(2j * math.pi * f[:, None] * tc)
    starts, within = phasor_factors(tc, f)
    return (starts[:, :, None] * within[:, None, :]).reshape(f.size, -1)[:, :n]


def harmonic_design(
    tc: np.ndarray, f: np.ndarray, ks: list[int], derivative: bool, z1: np.ndarray | None = None
) -> np.ndarray:
    """Per row (frequency f[w]): columns 1, tc, cos and sin of 2 pi k f tc for k in ks
    [, tc cos, tc sin]; shape (rows, columns, samples). ``z1``: the phasors
    :func:`phasors` of ``tc`` and ``f``, when already known."""
    z1 = phasors(tc, f) if z1 is None else z1
    per = 4 if derivative else 2
    design = np.empty((f.size, 2 + per * len(ks), tc.size))
    design[:, 0] = 1.0
    design[:, 1] = tc
    zk = np.ones_like(z1)
    k_prev = 0
    for j, k in enumerate(ks):
        zk = zk * z1 if k - k_prev == 1 else zk * z1 ** (k - k_prev)
        k_prev = k
        c = 2 + per * j
        design[:, c] = zk.real
        design[:, c + 1] = zk.imag
        if derivative:
            np.multiply(tc, zk.real, out=design[:, c + 2])
            np.multiply(tc, zk.imag, out=design[:, c + 3])
    return design


def _factor_powers(factors: tuple[np.ndarray, np.ndarray], top: int) -> tuple[np.ndarray, ...]:
    """(starts^j, within^j), j = 1..top, of :func:`phasor_factors`, each (rows, m, top), by
    repeated products: z^j at sample b B + j is their product, no sample's power depending on
    another's (the passes below then vectorise)."""
    out = []
    for z in factors:
        p = np.empty(z.shape + (top,), dtype=complex)
        p[..., 0] = z
        for j in range(1, top):
            p[..., j] = p[..., j - 1] * z
        out.append(p)
    return tuple(out)


@njit(cache=True, fastmath={"reassoc", "contract"}, error_model="numpy")
def _power_sums(start_powers, within_powers, r: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """sum over samples of r z^j and r tc z^j, j = 1..top, per row (z: the phasors
    :func:`phasors`, their powers from the factors' :func:`_factor_powers`), row by row (a
    batch gives a row its numbers alone). The sums may be reassociated, so that they
    vectorise (~6x faster; ~4e-15 relative from the sequential sums). Shaped
    (rows, 2 (t^0, t^1), top, 2 (cos, sin))."""
    rows, n = r.shape
    blocks, block, top = start_powers.shape[1], within_powers.shape[1], within_powers.shape[2]
    out = np.zeros((rows, 2, top, 2))
    w_re, w_im = np.empty((top, block)), np.empty((top, block))
    for w in range(rows):
        for j in range(top):
            for i in range(block):
                w_re[j, i] = within_powers[w, i, j].real
                w_im[j, i] = within_powers[w, i, j].imag
        for b in range(blocks):
            i0 = b * block
            for j in range(top):
                s_re, s_im = start_powers[w, b, j].real, start_powers[w, b, j].imag
                c0 = c1 = c2 = c3 = 0.0
                for i in range(min(block, n - i0)):
                    z_re = s_re * w_re[j, i] - s_im * w_im[j, i]
                    z_im = s_re * w_im[j, i] + s_im * w_re[j, i]
                    a = r[w, i0 + i]
                    at = a * tc[i0 + i]
                    c0 += a * z_re
                    c1 += a * z_im
                    c2 += at * z_re
                    c3 += at * z_im
                out[w, 0, j, 0] += c0
                out[w, 0, j, 1] += c1
                out[w, 1, j, 0] += c2
                out[w, 1, j, 1] += c3
    return out


@njit(cache=True, error_model="numpy")
def _subtract_harmonics(
    r: np.ndarray,
    tc: np.ndarray,
    start_powers: np.ndarray,
    within_powers: np.ndarray,
    level: np.ndarray,
    slope: np.ndarray,
    c: np.ndarray,
) -> np.ndarray:
    """r - level - slope tc - sum_j Re(c[:, j] z^(j + 1)) per row (c: (rows, top), zero below
    the first fitted harmonic; the powers of z from :func:`_factor_powers`): per block of
    samples, c_j times the block start's power, then the harmonics added sample by sample."""
    rows, n = r.shape
    blocks, block, top = start_powers.shape[1], within_powers.shape[1], within_powers.shape[2]
    out = np.empty((rows, n))
    fit = np.empty(block)
    w_re, w_im = np.empty((top, block)), np.empty((top, block))
    for w in range(rows):
        # the within-block powers by harmonic, contiguous in the sample: the loop over the
        # samples then vectorises (the same operations on each sample)
        for j in range(top):
            for i in range(block):
                w_re[j, i] = within_powers[w, i, j].real
                w_im[j, i] = within_powers[w, i, j].imag
        for b in range(blocks):
            i0 = b * block
            m = min(block, n - i0)
            fit[:m] = 0.0
            for j in range(top):
                d = c[w, j] * start_powers[w, b, j]
                for i in range(m):
                    fit[i] += d.real * w_re[j, i] - d.imag * w_im[j, i]
            for i in range(m):
                out[w, i0 + i] = r[w, i0 + i] - level[w] - slope[w] * tc[i0 + i] - fit[i]
    return out


def _columns(ks: list[int], derivative: bool) -> np.ndarray:
    """(power of t, sine?, harmonic) of each column of :func:`harmonic_design`."""
    cols = [(0, 0, 0), (1, 0, 0)]
    for k in ks:
        cols += [(0, 0, k), (0, 1, k)] + ([(1, 0, k), (1, 1, k)] if derivative else [])
    return np.array(cols)


def _dirichlet_sums(n: int, fs: float, f: np.ndarray, top: int) -> tuple[np.ndarray, ...]:
    """sum_n t^p cos(j phi) and sum_n t^p sin(j phi), p = 0..2, j = 0..top, per row, over the
    samples t = (n - (N - 1) / 2) / fs (phi = 2 pi f t), in closed form.

    With x = pi j f / fs and D = sin(N x) / sin(x) (the Dirichlet kernel, the sum of cos(2 x m)
    over the symmetric m = n - (N - 1) / 2), the sums are D, 0, -D_xx / (4 fs^2) for cos and
    0, -D_x / (2 fs), 0 for sin, with D_x = (N cos(N x) - D cos x) / sin x and
    D_xx = (1 - N^2) D - 2 cot(x) D_x. Returns (cos sums, sin sums), each (rows, 3, top + 1),
    or None when some sin(x) is too small for the quotients (f near 0), the caller then summing
    over the samples."""
    x = math.pi * f[:, None] * np.arange(1, top + 1) / fs
    sx = np.sin(x)
    if np.any(np.abs(sx) < 1e-6):
        return None
    cx = np.cos(x)
    d = np.sin(n * x) / sx
    dx = (n * np.cos(n * x) - d * cx) / sx
    dxx = (1.0 - n * n) * d - 2.0 * cx / sx * dx
    m = np.arange(n) - 0.5 * (n - 1)
    cos_s, sin_s = np.zeros((f.size, 3, top + 1)), np.zeros((f.size, 3, top + 1))
    cos_s[:, :, 0] = [n, 0.0, float(m @ m) / (fs * fs)]
    cos_s[:, 0, 1:], cos_s[:, 2, 1:] = d, -dxx / (4.0 * fs * fs)
    sin_s[:, 1, 1:] = -dx / (2.0 * fs)
    return cos_s, sin_s


def harmonic_equations(
    tc: np.ndarray,
    f: np.ndarray,
    ks: list[int],
    r: np.ndarray,
    derivative: bool,
    fs: float,
    factors: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The normal equations (design design', design r) of :func:`harmonic_design` per row,
    without the design: every product of two columns t^p cos|sin(k phi) t^q cos|sin(l phi)
    is, by cos a cos b = (cos(a - b) + cos(a + b)) / 2 and its kin, a half sum of
    sum_n t^(p+q) cos|sin(j phi) for j = |k - l| and k + l, known in closed form
    (:func:`_dirichlet_sums`); design r needs the 4 k_max + 2 sums of r t^0..1 against the
    phasor powers (formed and summed in one compiled pass over the samples, :func:`_power_sums`),
    instead of the m (m + 1) / 2 + m products of columns (m = 18 for four harmonics with
    their t-columns). ``tc``: the samples' times from the middle, (n - (N - 1) / 2) / fs, as
    the closed form takes them. ``factors``: :func:`phasor_factors` of ``tc`` and ``f``,
    when already known. None when :func:`_dirichlet_sums` is."""
    kmax = max(ks)
    rows, n = r.shape
    sums = _dirichlet_sums(n, fs, f, 2 * kmax)
    if sums is None:
        return None
    cos_s, sin_s = sums
    powers = _factor_powers(phasor_factors(tc, f) if factors is None else factors, kmax)
    rsums = _power_sums(*powers, r, tc)
    return _assemble(_columns(ks, derivative), cos_s, sin_s, rsums, *_row_sums(r, tc))


@njit(cache=True, error_model="numpy")
def _assemble(cols, cos_s, sin_s, rsums, r_sum, rt_sum):
    """(design design', design r) per row from the closed-form sums (:func:`_dirichlet_sums`)
    and the data's (:func:`_power_sums`; ``r_sum``, ``rt_sum``: sum r and sum r t), for the
    columns ``cols`` (:func:`_columns`). Products of cosines and sines are half sums:
    cos cos (C(k-l) + C(k+l)) / 2, sin sin (C(k-l) - C(k+l)) / 2,
    cos_k sin_l (S(k+l) + sign(l-k) S(|l-k|)) / 2 and sin_k cos_l with the sign reversed;
    compiled (the numpy form's selections over the (rows, m, m) entries cost ~0.1 ms a call)."""
    rows, m = cos_s.shape[0], cols.shape[0]
    gram, rhs = np.empty((rows, m, m)), np.empty((rows, m))
    for a in range(m):
        p, sn, k = cols[a, 0], cols[a, 1], cols[a, 2]
        for b in range(m):
            q, sm, l_ = cols[b, 0], cols[b, 1], cols[b, 2]
            power, dif, tot = p + q, abs(k - l_), k + l_
            sign = float((l_ > k) - (l_ < k))
            for w in range(rows):
                if sn == 0 and sm == 0:
                    v = cos_s[w, power, dif] + cos_s[w, power, tot]
                elif sn == 1 and sm == 1:
                    v = cos_s[w, power, dif] - cos_s[w, power, tot]
                elif sn == 0:
                    v = sin_s[w, power, tot] + sign * sin_s[w, power, dif]
                else:
                    v = sin_s[w, power, tot] - sign * sin_s[w, power, dif]
                gram[w, a, b] = 0.5 * v
        for w in range(rows):
            if k > 0:
                rhs[w, a] = rsums[w, p, k - 1, sn]
            elif sn == 1:
                rhs[w, a] = 0.0
            else:
                rhs[w, a] = r_sum[w] if p == 0 else rt_sum[w]
    return gram, rhs


def harmonic_residual(
    r: np.ndarray,
    tc: np.ndarray,
    f: np.ndarray,
    ks: list[int],
    sol: np.ndarray,
    factors: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """r minus the fit ``sol`` of :func:`harmonic_design` (without t-columns) at ``f``,
    harmonics ``ks`` consecutive (those below 0.45 fs, as the analysis groups rows);
    ``factors``: :func:`phasor_factors` of ``tc`` and ``f``, when already known."""
    # Re((a_k - i b_k) z^k) = a_k cos + b_k sin: the harmonics' coefficients as complex
    c = np.zeros((f.size, ks[-1]), dtype=complex)
    c[:, ks[0] - 1 :] = sol[:, 2::2] - 1j * sol[:, 3::2]
    powers = _factor_powers(phasor_factors(tc, f) if factors is None else factors, ks[-1])
    return _subtract_harmonics(r, tc, *powers, sol[:, 0].copy(), sol[:, 1].copy(), c)


def refine_frequency(
    r: np.ndarray, tc: np.ndarray, f: np.ndarray, ks: list[int], span: float, fs: float
) -> np.ndarray:
    """One Gauss-Newton step per row on the frequency of the harmonic fit (at most ``span``
    from ``f``).

    With cos(k(w + d)t) ~ cos(kwt) - k d t sin(kwt), the fitted t cos, t sin terms of harmonic k
    are (k d b_k, -k d a_k); d is their least-squares ratio, weighted by k^2 |c_k|^2. One step
    takes the spectrum's estimate (within ~1e-3 f_bp, inside the ~1 / T basin) to ~1e-6 f_bp on
    a noise-free trace. Under noise the step is shrunk by d^2 / (d^2 + se^2), se its standard
    error (24 sigma^2 / (N T^2 sum k^2 |c_k|^2))^(1/2): a step the noise could have made moves
    little, so weak ripples keep the starting frequency instead of the noise's.
    """
    n = r.shape[1]
    t_var = float(np.mean(tc * tc))
    m = 2 + 4 * len(ks)
    # the level (a column) taken out first: the residual sum of squares from the normal
    # equations then cancels only the ripple's power, not the level's
    r = _centred(r)
    eqs = harmonic_equations(tc, f, ks, r, True, fs)
    sol = None if eqs is None else solve_normal(*eqs)
    if sol is None:
        sol, rhs = solve_rows(harmonic_design(tc, f, ks, derivative=True), r)
    else:
        rhs = eqs[1]
    rss = np.maximum(np.einsum("ij,ij->i", r, r) - np.einsum("ij,ij->i", sol, rhs), 0.0)
    return _frequency_step(sol, np.asarray(ks), rss, f, n, m, t_var, span)


@njit(cache=True, error_model="numpy")
def _frequency_step(sol, ks, rss, f, n, m, t_var, span):
    """The step of :func:`refine_frequency` per row from its fit ``sol`` (columns 1, t, then
    cos, sin, t cos, t sin of each harmonic of ``ks``) and residual sum of squares ``rss``:
    d = sum k (p_k b_k - q_k a_k) / sum k^2 (a_k^2 + b_k^2), shrunk by d^2 / (d^2 + se^2),
    over 2 pi, within ``span`` of ``f``. Compiled (the numpy form's ~30 operations on
    arrays of a few rows were ~0.1 ms a block); the same operations on each row."""
    out = np.empty(f.size)
    for w in range(f.size):
        num = den = 0.0
        for j in range(ks.size):
            k = ks[j]
            a, b, p, q = sol[w, 2 + 4 * j], sol[w, 3 + 4 * j], sol[w, 4 + 4 * j], sol[w, 5 + 4 * j]
            num += k * (p * b - q * a)
            den += k * k * (a * a + b * b)
        sigma2 = rss[w] / max(n - m, 1)
        moves = den > 0.0 and t_var > 0.0
        safe = den if moves else 1.0
        d = num / safe
        se2 = 2.0 * sigma2 / (n * t_var * safe) if t_var > 0.0 else 0.0
        d2 = d * d
        d = d * d2 / (d2 + se2) if d2 + se2 > 0.0 else 0.0
        step = d / (2.0 * math.pi) if moves else 0.0
        out[w] = min(max(f[w] + step, f[w] - span), f[w] + span)
    return out
