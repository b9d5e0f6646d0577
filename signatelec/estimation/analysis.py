"""One analysis of a bearing-resistance trace, which every feature group reads.

A trace is the bearing's resistance ``r[n]`` (ohm) sampled uniformly at ``sample_rate_hz`` while
the inner ring turns at ``omega_rad_s``. Each ball entering or leaving the load zone changes the
Kirchhoff network (seed sections 3-4), so the resistance ripples at the ball-pass frequency
f_bp = Z omega_c / 2 pi (:meth:`~signatelec.config.bearing.Bearing.ball_pass_frequency_hz`) and
its harmonics. :func:`analyse_trace` fits, once per trace, the level, a linear drift and the
harmonics at the found f_bp by least squares over the whole trace, and takes the Welch spectra
of the detrended trace and of the residual; :mod:`signatelec.estimation.features` turns the
result (:class:`TraceAnalysis`) into features.

Frequencies are tied to f_bp: the Welch segment spans ``passes_per_segment`` ball passes, so the
spectra of one continuous signal do not depend on the sampling rate or the trace length.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from signatelec.config.bearing import Bearing
from signatelec.estimation.harmonic_fit import (
    apply_design,
    harmonic_design,
    harmonic_equations,
    harmonic_residual,
    pairwise_sum,
    phasor_factors,
    refine_frequency,
    solve_normal,
    solve_rows,
)
from signatelec.estimation.window_spectra import (
    find_ball_pass,
    sorted_select,
    take_rows,
    welch_rows,
)
from signatelec.measurement.band import N_HARMONICS, SEARCH_REL
from signatelec.physics.kinematics import expected_ball_pass_hz

#: Ball passes per Welch segment: resolution f_bp / 4, bins at multiples of f_bp / 4.
PASSES_PER_SEGMENT = 4
#: Phase bins of the folded raw trace.
FOLD_BINS = 16
#: Samples per block of the compiled sums (:func:`_statistics_pass`).
_SUM_BLOCK = 128


@dataclass(frozen=True)
class TraceAnalysis:
    """What every feature group reads: the fit of level, drift and harmonics, and spectra.

    ``coefficients[k - 1]`` is the complex amplitude c_k of harmonic k, the trace being
    ``level + drift t + Re(sum_k c_k exp(2 pi i k f_bp t))`` (t from the middle of the trace);
    ``noise_density[k - 1]``
    the one-sided density (ohm^2/Hz) of the residual around k f_bp; ``psd`` and
    ``residual_psd`` the Welch densities of the detrended trace and of the residual at
    ``psd_freq_hz``, from 0 Hz to the first bin at or above (2 K + 1) f_bp for K harmonics
    (above every band the features read, the highest [K + 1/2, 2 K + 1/2) f_bp; f_bp the
    largest of the rows of its segment length analysed with it, so a grid may hold a bin more;
    the whole one-sided grid when that lies beyond it; bin 0 alone when f_bp <= 0), and
    ``residual_power_ohm2`` the residual's power by the same density over its whole grid less
    the last bin (df times their sum); ``statistics`` the whole-trace statistics of
    :func:`_row_statistics`.
    """

    sample_rate_hz: float
    omega_rad_s: float
    n_samples: int
    duration_s: float
    level_ohm: float
    drift_ohm_per_s: float
    expected_hz: float
    ball_pass_hz: float
    search_peak_ratio: float
    coefficients: np.ndarray
    noise_density: np.ndarray
    residual: np.ndarray
    detrended: np.ndarray
    psd_freq_hz: np.ndarray
    psd: np.ndarray
    residual_psd: np.ndarray
    residual_power_ohm2: float
    n_fitted: int
    statistics: dict

    @property
    def n_harmonics(self) -> int:
        """Harmonics fitted or, above 0.45 fs, set to 0 (the length of ``coefficients``)."""
        return int(self.coefficients.size)

    @property
    def level_scale(self) -> float:
        """|level|, or 1 ohm when the level is 0 (relative features stay finite)."""
        return abs(self.level_ohm) if self.level_ohm != 0.0 else 1.0


def _as_trace(resistance_ohm) -> np.ndarray:
    r = np.asarray(resistance_ohm, dtype=float).ravel()
    if r.size == 0:
        raise ValueError("empty trace: a trace needs at least one sample")
    if not np.all(np.isfinite(r)):
        raise ValueError("trace holds NaN or infinite values; repair it first")
    return r


@functools.lru_cache(maxsize=4)
def _sample_times(n: int, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(times from the first sample, times from the middle tc, tc less its mean, the sum of
    its squares) of ``n`` samples at ``fs``, read-only, kept for the next block of the same
    length (~0.06 ms a block to form)."""
    t0 = np.arange(n) / fs
    tc = (np.arange(n) - 0.5 * (n - 1)) / fs
    tcc = tc - tc.mean()
    for a in (t0, tc, tcc):
        a.flags.writeable = False
    return t0, tc, tcc, float(np.sum(tcc * tcc))


@njit(cache=True, error_model="numpy")
def band_means(f, p, start, lo, hi) -> np.ndarray:
    """:func:`band_mean` of each row's spectrum over each band
    [lo, hi) (the rows' spectra end to end in ``f``, ``p``: row w at start[w]:start[w + 1]);
    NaN where no bin is in a band."""
    rows, bands = lo.shape
    out = np.empty((rows, bands))
    for w in range(rows):
        fw = f[start[w] : start[w + 1]]
        pw = p[start[w] : start[w + 1]]
        for b in range(bands):
            i = np.searchsorted(fw, lo[w, b])
            j = np.searchsorted(fw, hi[w, b])
            out[w, b] = pairwise_sum(pw[i:j]) / (j - i) if j > i else np.nan
    return out


def band_mean(f: np.ndarray, p: np.ndarray, lo: float, hi: float) -> float:
    """Mean of ``p`` over the bins of ``f`` (ascending) in [lo, hi); interpolated at the
    band's centre when no bin is in it."""
    # two scalar searches: ~1.6 us against ~4 us for one over the pair (tuple to array)
    i, j = int(f.searchsorted(lo)), int(f.searchsorted(hi))
    if j > i:
        return float(np.add.reduce(p[i:j])) / float(j - i)
    if f.size == 0:
        return 0.0
    return float(np.interp(0.5 * (lo + hi), f, p))


def band_power(f: np.ndarray, p: np.ndarray, lo: float, hi: float) -> float:
    """Integral of a one-sided PSD over [lo, hi): mean density times width."""
    hi = min(hi, f[-1] if f.size else hi)
    if hi <= lo:
        return 0.0
    return band_mean(f, p, lo, hi) * (hi - lo)


def analyse_trace(
    resistance_ohm,
    sample_rate_hz: float,
    omega_rad_s: float,
    *,
    n_harmonics: int = N_HARMONICS,
    bearing: Bearing | None = None,
    search_rel: float = SEARCH_REL,
    passes_per_segment: int = PASSES_PER_SEGMENT,
) -> TraceAnalysis:
    """Fit level, drift and the ball-pass harmonics of one trace; Welch spectra of it and of
    the residual. Raises ValueError on an empty or non-finite trace or a rate <= 0.

    The ball-pass frequency: the peak of the summed harmonic power in a zero-padded spectrum,
    then Gauss-Newton on the harmonic least-squares fit (unbiased to ~1e-5 of f_bp on a
    noise-free trace, against ~1e-3 for the padded spectrum alone).
    """
    r = _as_trace(resistance_ohm)
    fs = float(sample_rate_hz)
    if not fs > 0.0 or not math.isfinite(fs):
        raise ValueError(f"sample_rate_hz = {sample_rate_hz!r}: must be a finite rate > 0")
    omega = np.array([float(omega_rad_s)])
    return _analyse(r[None], fs, omega, n_harmonics, bearing, search_rel, passes_per_segment)[0]


@njit(cache=True, error_model="numpy")
def _line_fit(x: np.ndarray, tcc: np.ndarray, denom: float) -> tuple[np.ndarray, np.ndarray]:
    """(mean, least-squares slope against the centred times ``tcc``) per row; the slope 0 when
    ``denom`` (sum tcc^2) is 0. numpy's sums (:func:`pairwise_sum`): the same numbers as
    ``x.mean(axis=1)`` and ``np.sum(tcc * (x - mean), axis=1) / denom``, without the
    temporaries."""
    rows, n = x.shape
    level, slope = np.empty(rows), np.zeros(rows)
    centred = np.empty(n)
    for w in range(rows):
        level[w] = pairwise_sum(x[w]) / n
        if denom > 0.0:
            for i in range(n):
                centred[i] = tcc[i] * (x[w, i] - level[w])
            slope[w] = pairwise_sum(centred) / denom
    return level, slope


@njit(cache=True, error_model="numpy")
def _detrend(x: np.ndarray, level: np.ndarray, slope: np.ndarray, tc: np.ndarray) -> np.ndarray:
    """x - level - slope tc per row, in one pass."""
    out = np.empty_like(x)
    for w in range(x.shape[0]):
        for i in range(x.shape[1]):
            out[w, i] = x[w, i] - level[w] - slope[w] * tc[i]
    return out


def _by_harmonics(f_bp: np.ndarray, n_harmonics: int, fs: float) -> dict[tuple, np.ndarray]:
    """Rows grouped by the harmonics below 0.45 fs that their f_bp allows: 1 to the count of
    k with k f_bp < 0.45 fs (all of them when f_bp <= 0), all rows at once."""
    below = np.arange(1, n_harmonics + 1) * f_bp[:, None] < 0.45 * fs
    count = np.count_nonzero(below, axis=1)
    return {tuple(range(1, int(c) + 1)): np.flatnonzero(count == c) for c in np.unique(count)}


#: The statistics of :func:`_row_statistics`, in the order of :func:`_statistics_pass`'s columns.
STATISTICS = (
    "median",
    "mad",
    "q75",
    "q25",
    "residual_std",
    "residual_mad",
    "residual_white",
    "residual_var",
    "residual_m4",
    "raw_skew",
    "raw_kurtosis",
)


@njit(cache=True, error_model="numpy")
def _kth_deviation(s: np.ndarray, med: float, split: int, k: int) -> float:
    """The k-th smallest (from 0) of |s_i - med|, ``s`` sorted and ``split`` the count of
    s_i <= med: the deviations are two ascending runs, med - s[split - 1 - i] and
    s[split + j] - med, and the k-th of their union is found by bisection on how many come
    from the first (O(log n), as the k-th of two sorted arrays)."""
    la, lb = split, s.size - split
    lo, hi = max(0, k + 1 - lb), min(k + 1, la)
    while lo < hi:
        i = (lo + hi) // 2  # i from the first run, k + 1 - i from the second
        if med - s[split - 1 - i] < s[split + k - i] - med:
            lo = i + 1
        else:
            hi = i
    a = med - s[split - lo] if lo > 0 else -math.inf
    b = s[split + k - lo] - med if k + 1 - lo > 0 else -math.inf
    return max(a, b)


@njit(cache=True, error_model="numpy")
def _sorted_mad(s: np.ndarray, med: float) -> float:
    """np.median(np.abs(x - med)) of ``s`` = x sorted, without a second sort."""
    n = s.size
    h = n // 2
    split = np.searchsorted(s, med, side="right")
    upper = _kth_deviation(s, med, split, h)
    return upper if n % 2 else (_kth_deviation(s, med, split, h - 1) + upper) / 2.0


@njit(cache=True, error_model="numpy")
def _statistics_pass(det, res, det_sorted, res_sorted, t, f_bp, fold):
    """Per row: the values of :data:`STATISTICS` and, if ``fold``, the fold at f_bp (counts and
    sums of the detrended samples in :data:`FOLD_BINS` phase bins; ``t``: the samples' times
    from 0, ``arange(n) / fs``), in two passes over the samples (means, then centred moments);
    the residual's MAD NaN when ``res_sorted`` has no columns. Sums run in blocks of
    :data:`_SUM_BLOCK` samples added to a total: round-off ~(block + n / block) eps of the
    summed magnitudes, against numpy's pairwise ~log2(n) eps (both far below the 1e-9 the
    features are held to)."""
    rows, n = det.shape
    values = np.zeros((rows, 11))
    counts = np.zeros((rows, FOLD_BINS), np.int64)
    sums = np.zeros((rows, FOLD_BINS))
    bins = np.empty(n, np.int64)
    for w in range(rows):
        med = sorted_select(det_sorted[w], 0.5)
        values[w, 0] = med
        values[w, 1] = _sorted_mad(det_sorted[w], med)
        values[w, 2] = sorted_select(det_sorted[w], 0.75)
        values[w, 3] = sorted_select(det_sorted[w], 0.25)
        if res_sorted.shape[1] == n:
            values[w, 5] = _sorted_mad(res_sorted[w], sorted_select(res_sorted[w], 0.5))
        else:
            values[w, 5] = np.nan
        s_e = s_d = s_e2 = s_e4 = s_de = 0.0
        for lo in range(0, n, _SUM_BLOCK):
            b_e = b_d = b_e2 = b_e4 = b_de = 0.0
            for i in range(lo, min(lo + _SUM_BLOCK, n)):
                e = res[w, i]
                e2 = e * e
                b_e += e
                b_d += det[w, i]
                b_e2 += e2
                b_e4 += e2 * e2
                if i > 0:
                    b_de += e - res[w, i - 1]
            s_e += b_e
            s_d += b_d
            s_e2 += b_e2
            s_e4 += b_e4
            s_de += b_de
        m_e, m_d = s_e / n, s_d / n
        m_de = s_de / (n - 1) if n > 1 else 0.0
        c_e2 = c_de2 = c_w2 = c_w3 = c_w4 = 0.0
        for lo in range(0, n, _SUM_BLOCK):
            b_e2 = b_de2 = b_w2 = b_w3 = b_w4 = 0.0
            for i in range(lo, min(lo + _SUM_BLOCK, n)):
                e = res[w, i] - m_e
                b_e2 += e * e
                if i > 0:
                    d = res[w, i] - res[w, i - 1] - m_de
                    b_de2 += d * d
                x = det[w, i] - m_d
                x2 = x * x
                b_w2 += x2
                b_w3 += x2 * x
                b_w4 += x2 * x2
            c_e2 += b_e2
            c_de2 += b_de2
            c_w2 += b_w2
            c_w3 += b_w3
            c_w4 += b_w4
        e_std = math.sqrt(c_e2 / n)
        values[w, 4] = e_std
        values[w, 6] = math.sqrt(c_de2 / (n - 1)) / math.sqrt(2.0) if n > 2 else e_std
        values[w, 7] = s_e2 / n
        values[w, 8] = s_e4 / n
        var = c_w2 / n
        if var > 0.0:
            sd = math.sqrt(var)
            values[w, 9] = c_w3 / n / sd**3
            values[w, 10] = c_w4 / n / var**2 - 3.0
        if fold and n >= FOLD_BINS:
            for i in range(n):
                cycles = t[i] * f_bp[w]
                bins[i] = int(math.floor((cycles - math.floor(cycles)) * FOLD_BINS)) % FOLD_BINS
            # a bin's samples come in runs (~fs / (f_bp FOLD_BINS) of them): each run is
            # added to the bin's total in a register, in the samples' order (the same sums as
            # one sample at a time into the array, ~3x faster)
            i = 0
            while i < n:
                b, run, total = bins[i], 0, sums[w, bins[i]]
                while i < n and bins[i] == b:
                    total += det[w, i]
                    run += 1
                    i += 1
                sums[w, b] = total
                counts[w, b] += run
    return values, counts, sums


def _row_statistics(
    detrended: np.ndarray,
    residual: np.ndarray,
    fs: float,
    f_bp,
    residual_mad: bool = True,
    fold: bool = True,
) -> list[dict]:
    """The statistics of whole rows that the level, noise and ripple features read (medians
    and quartiles from one sort per row, moments, the trace folded at f_bp into
    :data:`FOLD_BINS` phase bins), one dict per row: :func:`_statistics_pass` over the rows
    and their sorted copies (numpy's vectorised sort is several times a compiled one's speed).
    Without ``residual_mad`` the residual is not sorted (its MAD NaN); without ``fold`` it is
    not folded (``fold_counts`` None: :func:`analyse_windows`)."""
    rows, n = detrended.shape
    f = np.asarray(f_bp, float)
    values, counts, sums = _statistics_pass(
        detrended,
        residual,
        np.sort(detrended, axis=1),
        np.sort(residual, axis=1) if residual_mad else np.empty((rows, 0)),
        _sample_times(n, fs)[0],
        f,
        fold,
    )
    out = [dict(zip(STATISTICS, map(float, values[w]), strict=True)) for w in range(rows)]
    if n >= FOLD_BINS:
        for w in range(rows):
            if not fold:
                out[w]["fold_counts"] = out[w]["fold_sums"] = None
            elif f[w] > 0:
                out[w]["fold_counts"], out[w]["fold_sums"] = counts[w], sums[w]
    return out


def analyse_windows(
    windows,
    sample_rate_hz: float,
    omega_rad_s,
    *,
    n_harmonics: int = N_HARMONICS,
    bearing: Bearing | None = None,
    search_rel: float = SEARCH_REL,
    passes_per_segment: int = PASSES_PER_SEGMENT,
    residual_mad: bool = True,
    fold: bool = True,
) -> list[TraceAnalysis]:
    """:func:`analyse_trace` of each row of ``windows`` (rows of equal length, each at its own
    ``omega_rad_s``), computed together: one transform over all rows for each spectrum, the
    least-squares products of all rows at once. Equal to the analyses of the rows one by one
    (the same code, which :func:`analyse_trace` runs on one row).

    What one feature alone reads is computed only if asked for
    (:func:`~signatelec.estimation.features.analysis_options` says which for a set of
    features): ``residual_mad``, the residual's median absolute deviation (a sort of each
    row's residual, ~15 % of a 0.2 s window's analysis), else NaN; ``fold``, the trace folded
    at f_bp (~4 %), else its ``statistics["fold_counts"]`` and ``["fold_sums"]`` are None."""
    x = np.asarray(windows, dtype=float)
    if x.ndim != 2 or x.shape[1] == 0:
        raise ValueError("windows: a 2-D array of rows with at least one sample each")
    if not np.all(np.isfinite(x)):
        raise ValueError("trace holds NaN or infinite values; repair it first")
    fs = float(sample_rate_hz)
    if not fs > 0.0 or not math.isfinite(fs):
        raise ValueError(f"sample_rate_hz = {sample_rate_hz!r}: must be a finite rate > 0")
    omega = np.broadcast_to(np.asarray(omega_rad_s, dtype=float), (x.shape[0],))
    if x.shape[0] == 0:
        return []
    return _analyse(
        x, fs, omega, n_harmonics, bearing, search_rel, passes_per_segment, residual_mad, fold
    )


def _analyse(
    x, fs, omega, n_harmonics, bearing, search_rel, passes_per_segment, residual_mad=True, fold=True
):
    rows, n = x.shape
    duration = n / fs
    _, tc, tcc, denom = _sample_times(n, fs)
    if np.all(omega == omega[0]):  # a block's windows share one speed
        speeds, at = omega[:1], np.zeros(rows, dtype=int)
    else:
        speeds, at = np.unique(omega, return_inverse=True)
    f_exp = np.array([expected_ball_pass_hz(float(o), bearing) for o in speeds])[at]
    level0, slope0 = _line_fit(x, tcc, denom if n >= 2 and denom > 0 else 0.0)
    f_bp, peak_ratio = f_exp.copy(), np.ones(rows)
    if n >= 4:
        line = (level0, slope0, tc)
        f_bp, peak_ratio = find_ball_pass(x, line, fs, f_exp, n_harmonics, search_rel)
    for ks, idx in _by_harmonics(f_bp, n_harmonics, fs).items():
        if ks and n >= 8 * (2 + 4 * len(ks)):
            f_bp[idx] = refine_frequency(
                take_rows(x, idx), tc, f_bp[idx], list(ks), 0.5 / duration, fs
            )
    level, slope = np.zeros(rows), np.zeros(rows)
    coefficients = np.zeros((rows, n_harmonics), dtype=complex)
    residual = np.empty_like(x)
    n_fitted = np.zeros(rows, dtype=int)
    for ks, idx in _by_harmonics(f_bp, n_harmonics, fs).items():
        sol, r = None, take_rows(x, idx)
        if n >= 4 * (2 + 2 * len(ks)):
            factors = phasor_factors(tc, f_bp[idx])
            eqs = harmonic_equations(tc, f_bp[idx], list(ks), r, False, fs, factors)
            sol = None if eqs is None else solve_normal(*eqs)
        if sol is None:
            design = harmonic_design(tc, f_bp[idx], list(ks), derivative=False)
            sol = solve_rows(design, r)[0]
            part = r - apply_design(design, sol)
        else:
            part = harmonic_residual(r, tc, f_bp[idx], list(ks), sol, factors)
        if idx.size == rows:
            residual = part
        else:
            residual[idx] = part
        level[idx], slope[idx] = sol[:, 0], sol[:, 1]
        for j, k in enumerate(ks):
            coefficients[idx, k - 1] = sol[:, 2 + 2 * j] - 1j * sol[:, 3 + 2 * j]
        n_fitted[idx] = len(ks)
    detrended = _detrend(x, level, slope, tc)
    psd_f, psd, residual_psd = [None] * rows, [None] * rows, [None] * rows
    residual_power = np.empty(rows)
    noise_density = np.empty((rows, n_harmonics))
    half = np.arange(1, n_harmonics + 1) - 0.5  # the band of harmonic k: (k -+ 0.5) f_bp
    top = 2 * n_harmonics + 1  # f_bp: above the features' highest band (TraceAnalysis)
    for idx, freq, (p, p_res), (_, power) in welch_rows(
        (detrended, residual), fs, f_bp, passes_per_segment, top
    ):
        lo, hi = half * f_bp[idx, None], (half + 1.0) * f_bp[idx, None]
        start = np.arange(len(idx) + 1) * freq.size  # the rows share one grid
        noise_density[idx] = band_means(np.tile(freq, len(idx)), p_res.ravel(), start, lo, hi)
        residual_power[idx] = power
        for i, w in enumerate(idx):
            psd_f[w], psd[w], residual_psd[w] = freq, p[i], p_res[i]
    for w, j in np.argwhere(np.isnan(noise_density)):  # bands without a bin
        k = j + 1
        noise_density[w, j] = band_mean(
            psd_f[w], residual_psd[w], (k - 0.5) * f_bp[w], (k + 0.5) * f_bp[w]
        )
    stats = _row_statistics(detrended, residual, fs, f_bp, residual_mad, fold)
    out = []
    for w in range(rows):
        out.append(
            TraceAnalysis(
                sample_rate_hz=fs,
                omega_rad_s=float(omega[w]),
                n_samples=n,
                duration_s=duration,
                level_ohm=float(level[w]),
                drift_ohm_per_s=float(slope[w]),
                expected_hz=float(f_exp[w]),
                ball_pass_hz=float(f_bp[w]),
                search_peak_ratio=float(peak_ratio[w]),
                coefficients=coefficients[w],
                noise_density=noise_density[w],
                residual=residual[w],
                detrended=detrended[w],
                psd_freq_hz=psd_f[w],
                psd=psd[w],
                residual_psd=residual_psd[w],
                residual_power_ohm2=float(residual_power[w]),
                n_fitted=int(n_fitted[w]),
                statistics=stats[w],
            )
        )
    return out


def debiased_amplitudes(a: TraceAnalysis) -> np.ndarray:
    """|c_k| with the noise bias taken out: E|c|^2 = |c|^2 + 2 S / T (S the one-sided noise
    density at the harmonic, T the duration); 0 where the noise explains it all."""
    raw2 = np.abs(a.coefficients) ** 2
    bias = 2.0 * a.noise_density / a.duration_s
    return np.sqrt(np.maximum(raw2 - bias, 0.0))


def analysis_of(
    resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis
) -> TraceAnalysis:
    """``analysis`` when given, else the analysis of the trace (the feature functions' inputs)."""
    if analysis is not None:
        return analysis
    if sample_rate_hz is None or omega_rad_s is None:
        raise TypeError("give sample_rate_hz and omega_rad_s (or a precomputed analysis)")
    return analyse_trace(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics=n_harmonics)
