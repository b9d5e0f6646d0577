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

import math
from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft

from signatelec.config.bearing import Bearing
from signatelec.measurement.ripple import padded_power
from signatelec.measurement.traces import N_HARMONICS, SEARCH_REL
from signatelec.physics.kinematics import expected_ball_pass_hz

#: Ball passes per Welch segment: resolution f_bp / 4, bins at multiples of f_bp / 4.
PASSES_PER_SEGMENT = 4


@dataclass(frozen=True)
class TraceAnalysis:
    """What every feature group reads: the fit of level, drift and harmonics, and spectra.

    ``coefficients[k - 1]`` is the complex amplitude c_k of harmonic k, the trace being
    ``level + drift t + Re(sum_k c_k exp(2 pi i k f_bp t))`` (t from the middle of the trace);
    ``noise_density[k - 1]``
    the one-sided density (ohm^2/Hz) of the residual around k f_bp.
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
    n_fitted: int

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


def _linear_fit(r: np.ndarray, t: np.ndarray) -> tuple[float, float]:
    if r.size < 2:
        return float(r.mean()), 0.0
    tc = t - t.mean()
    denom = float(np.sum(tc * tc))
    slope = float(np.sum(tc * (r - r.mean()))) / denom if denom > 0 else 0.0
    return float(r.mean()), slope


def _find_ball_pass(
    x: np.ndarray, fs: float, f_exp: float, n_harmonics: int, search_rel: float
) -> tuple[float, float]:
    """f_bp maximising the summed power of its harmonics in the zero-padded Hann spectrum
    (:func:`~signatelec.measurement.ripple.padded_power`, the sanity layer's).

    Returns (frequency, peak-to-median ratio of the harmonic sum over the search band). The sum
    over harmonics keeps the search on f_bp where the first harmonic vanishes (comb zeros).
    """
    n = x.size
    if n < 4 or f_exp <= 0.0:
        return f_exp, 1.0
    spec, df = padded_power(x, fs)
    duration = n / fs
    step = min(1.0 / (8.0 * duration * n_harmonics), 1e-3 * f_exp)
    lo, hi = f_exp * (1.0 - search_rel), f_exp * (1.0 + search_rel)
    cand = np.arange(lo, hi + step, step)
    total = np.zeros_like(cand)
    bins = np.arange(spec.size)
    for k in range(1, n_harmonics + 1):
        fk = k * cand
        ok = fk < 0.5 * fs
        total[ok] += np.interp(fk[ok] / df, bins, spec)
    i = int(np.argmax(total))
    f = float(cand[i])
    if 0 < i < cand.size - 1:
        a, b, c = total[i - 1], total[i], total[i + 1]
        den = a - 2.0 * b + c
        if den < 0.0:
            f += step * float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    med = float(np.median(total))
    return f, float(total[i] / med) if med > 0 else 1.0


def _welch(x: np.ndarray, fs: float, f_bp: float, passes: int) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch density (Hann, half overlap), segments of ``passes`` ball passes.

    The same estimate as ``scipy.signal.welch(..., detrend=False)``, with the segments
    transformed in one batch (a 1 s trace at 50 kHz has ~200 of them).
    """
    nper = int(round(passes * fs / f_bp)) if f_bp > 0 else x.size
    nper = max(1, min(nper, x.size))
    step = max(nper // 2, 1)
    win = np.hanning(nper + 1)[:-1] if nper > 1 else np.ones(1)  # periodic Hann
    seg = np.lib.stride_tricks.sliding_window_view(x, nper)[::step] * win
    p = np.mean(np.abs(sfft.rfft(seg, axis=1)) ** 2, axis=0) / (fs * float(win @ win))
    p[1 : (None if nper % 2 else -1)] *= 2.0
    return sfft.rfftfreq(nper, 1.0 / fs), p


def band_mean(f: np.ndarray, p: np.ndarray, lo: float, hi: float) -> float:
    sel = (f >= lo) & (f < hi)
    if np.any(sel):
        return float(p[sel].mean())
    if f.size == 0:
        return 0.0
    return float(np.interp(0.5 * (lo + hi), f, p))


def band_power(f: np.ndarray, p: np.ndarray, lo: float, hi: float) -> float:
    """Integral of a one-sided PSD over [lo, hi): mean density times width."""
    hi = min(hi, f[-1] if f.size else hi)
    if hi <= lo:
        return 0.0
    return band_mean(f, p, lo, hi) * (hi - lo)


#: Rows per block of the least-squares products: below the size at which OpenBLAS spreads a
#: product over threads, which on busy cores makes it ~30x slower, not faster.
_BLOCK = 1024


def _normal_equations(design: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """design' design and design' r, summed over blocks of rows."""
    m = design.shape[1]
    gram, rhs = np.zeros((m, m)), np.zeros(m)
    for i in range(0, design.shape[0], _BLOCK):
        d = design[i : i + _BLOCK]
        gram += d.T @ d
        rhs += d.T @ r[i : i + _BLOCK]
    return gram, rhs


def _apply(design: np.ndarray, sol: np.ndarray) -> np.ndarray:
    """design @ sol, column by column (no threaded BLAS either)."""
    out = np.zeros(design.shape[0])
    for j, c in enumerate(sol):
        if c != 0.0:
            out += c * design[:, j]
    return out


def _solve(design: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Least squares by the normal equations (columns nearly orthogonal over many periods);
    lstsq when the trace is too short for that."""
    n, m = design.shape
    if n >= 4 * m:
        gram, rhs = _normal_equations(design, r)
        try:
            return np.linalg.solve(gram + 1e-12 * np.trace(gram) / m * np.eye(m), rhs)
        except np.linalg.LinAlgError:
            pass
    if n < m:
        sol = np.linalg.lstsq(design[:, :n], r, rcond=None)[0]
        return np.concatenate([sol, np.zeros(m - n)])
    return np.linalg.lstsq(design, r, rcond=None)[0]


def _harmonic_design(tc: np.ndarray, f: float, ks: list[int], derivative: bool) -> np.ndarray:
    """Columns 1, tc, cos and sin of 2 pi k f tc for k in ks [, tc cos, tc sin]."""
    z1 = np.exp(2j * math.pi * f * tc)
    per = 4 if derivative else 2
    design = np.empty((tc.size, 2 + per * len(ks)), order="F")
    design[:, 0] = 1.0
    design[:, 1] = tc
    zk = np.ones_like(z1)
    k_prev = 0
    for j, k in enumerate(ks):
        zk = zk * z1 ** (k - k_prev)
        k_prev = k
        c = 2 + per * j
        design[:, c] = zk.real
        design[:, c + 1] = zk.imag
        if derivative:
            np.multiply(tc, zk.real, out=design[:, c + 2])
            np.multiply(tc, zk.imag, out=design[:, c + 3])
    return design


def _refine_frequency(
    r: np.ndarray, tc: np.ndarray, f: float, ks: list[int], span: float, iterations: int = 1
) -> float:
    """Gauss-Newton steps on the frequency of the harmonic fit (at most ``span`` from ``f``).

    With cos(k(w + d)t) ~ cos(kwt) - k d t sin(kwt), the fitted t cos, t sin terms of harmonic k
    are (k d b_k, -k d a_k); d is their least-squares ratio, weighted by k^2 |c_k|^2. One step
    takes the spectrum's estimate (within ~1e-3 f_bp, inside the ~1 / T basin) to ~1e-6 f_bp on
    a noise-free trace. Under noise the step is shrunk by d^2 / (d^2 + se^2), se its standard
    error (24 sigma^2 / (N T^2 sum k^2 |c_k|^2))^(1/2): a step the noise could have made moves
    little, so weak ripples keep the starting frequency instead of the noise's.
    """
    f0 = f
    n = r.size
    t_var = float(np.mean(tc * tc))
    for _ in range(iterations):
        design = _harmonic_design(tc, f, ks, derivative=True)
        sol = _solve(design, r)
        num = den = 0.0
        for j, k in enumerate(ks):
            a, b, p, q = sol[2 + 4 * j : 6 + 4 * j]
            num += k * (p * b - q * a)
            den += k * k * (a * a + b * b)
        if den <= 0.0 or t_var <= 0.0:
            break
        resid = r - _apply(design, sol)
        sigma2 = float(np.sum(resid * resid)) / max(n - design.shape[1], 1)
        d = num / den
        se2 = 2.0 * sigma2 / (n * t_var * den)
        d *= d * d / (d * d + se2)
        step = d / (2.0 * math.pi)
        f = float(np.clip(f + step, f0 - span, f0 + span))
        if abs(step) < 1e-6 * f:
            break
    return f


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
    return _analyse(r, fs, omega_rad_s, n_harmonics, bearing, search_rel, passes_per_segment)


def _analyse(r, fs, omega_rad_s, n_harmonics, bearing, search_rel, passes_per_segment):
    n = r.size
    duration = n / fs
    tc = (np.arange(n) - 0.5 * (n - 1)) / fs  # time from the middle of the trace
    f_exp = expected_ball_pass_hz(omega_rad_s, bearing)
    level0, slope0 = _linear_fit(r, tc)
    f_bp, peak_ratio = _find_ball_pass(r - level0 - slope0 * tc, fs, f_exp, n_harmonics, search_rel)
    ks = [k for k in range(1, n_harmonics + 1) if k * f_bp < 0.45 * fs]
    if ks and n >= 8 * (2 + 4 * len(ks)):
        f_bp = _refine_frequency(r, tc, f_bp, ks, span=0.5 / duration)
        ks = [k for k in ks if k * f_bp < 0.45 * fs]
    design = _harmonic_design(tc, f_bp, ks, derivative=False)
    sol = _solve(design, r)
    level, slope = float(sol[0]), float(sol[1])
    coefficients = np.zeros(n_harmonics, dtype=complex)
    for j, k in enumerate(ks):
        coefficients[k - 1] = sol[2 + 2 * j] - 1j * sol[3 + 2 * j]
    residual = r - _apply(design, sol)
    detrended = r - level - slope * tc
    psd_f, psd = _welch(detrended, fs, f_bp, passes_per_segment)
    _, res_psd = _welch(residual, fs, f_bp, passes_per_segment)
    noise_density = np.array(
        [
            band_mean(psd_f, res_psd, (k - 0.5) * f_bp, (k + 0.5) * f_bp)
            for k in range(1, n_harmonics + 1)
        ]
    )
    return TraceAnalysis(
        sample_rate_hz=fs,
        omega_rad_s=float(omega_rad_s),
        n_samples=n,
        duration_s=duration,
        level_ohm=level,
        drift_ohm_per_s=slope,
        expected_hz=f_exp,
        ball_pass_hz=f_bp,
        search_peak_ratio=peak_ratio,
        coefficients=coefficients,
        noise_density=noise_density,
        residual=residual,
        detrended=detrended,
        psd_freq_hz=psd_f,
        psd=psd,
        residual_psd=res_psd,
        n_fitted=len(ks),
    )


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
