"""Features of a bearing-resistance trace for load-state estimation (issue 6).

A trace is the bearing's resistance ``r[n]`` (ohm) sampled uniformly at ``sample_rate_hz`` while
the inner ring turns at ``omega_rad_s``. Its physics (seed sections 3-4):

- the level falls with the radial load as F_r^(-4/3) (Hertz) and a little with epsilon;
- each ball entering or leaving the load zone changes the Kirchhoff network, so the resistance
  ripples at the ball-pass frequency f_bp = Z omega_c / 2 pi
  (:meth:`~signatelec.config.bearing.Bearing.ball_pass_frequency_hz`) and its harmonics; the
  ripple's
  size and shape, relative to the level, follow the load zone (epsilon), hardly the load: at
  zero clearance the first harmonic is 0.123-0.126 % of the level from 0.1 to 0.4 C_r
  (quasi-static tier), while it swings between ~0 and 0.22 % as epsilon goes from 0.3 to 0.6
  (a comb: it vanishes each time the load-zone edge has moved by about one ball);
- what is left after the harmonics is the measurement noise and the DEM's own dynamics (impacts
  and rattling of unloaded balls, more of it at large clearance).

Every feature is dimensionless or in SI units and, for a given continuous signal, does not depend
on the sampling rate or the trace length beyond what physics implies:

- frequencies are tied to f_bp: the Welch segment spans ``passes_per_segment`` ball passes, band
  powers integrate over bands in multiples of f_bp, the harmonics are fitted by least squares at
  k f_bp over the whole trace (expected amplitude independent of its length);
- harmonic amplitudes are debiased for the noise (E|c|^2 = |c|^2 + 2 S / T, S the one-sided noise
  density at the harmonic, T the duration), so they do not shrink towards the truth as T grows;
- noise is reported both per sample (std, MAD: fixed per-sample noise at any rate) and as a
  density relative to the level and f_bp (fixed density at any rate); which one is invariant
  depends on the instrument, both are given;
- by design a few features measure how well the trace determines the others and so grow with
  the length: ``harmonic_snr`` (~ T), ``duration_ball_passes`` and ``ball_pass_peak_ratio`` (in
  :data:`LENGTH_DEPENDENT`).

Each transformer has a plain-function twin returning a ``dict`` for one trace of any length:

=========================  ===========================  =========================================
transformer                function                     features
=========================  ===========================  =========================================
:class:`LevelFeatures`     :func:`level_features`       mean, median, MAD, IQR, drift
:class:`SpectrumFeatures`  :func:`spectrum_features`    Welch band powers around the harmonics
:class:`BallPassFeatures`  :func:`ball_pass_features`   f_bp expected and found, slip, SNR
:class:`HarmonicFeatures`  :func:`harmonic_features`    amplitudes at k f_bp, phase invariants
:class:`NoiseFeatures`     :func:`noise_features`       what remains after the harmonics
:class:`RippleFeatures`    :func:`ripple_features`      waveform of one ball pass: shape stats
:class:`TraceFeatures`     :func:`trace_features`       all of the above (one analysis)
=========================  ===========================  =========================================

The transformers take ``X`` of shape ``(n_traces, n_samples)``, one trace per row, all sampled at
``sample_rate_hz`` with the shaft at ``omega_rad_s`` (scikit-learn's contract fixes the number
of samples between ``fit`` and ``transform``; the functions take any length).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from signatelec.config.bearing import Bearing
from signatelec.measurement.traces import N_HARMONICS, SEARCH_REL
from signatelec.physics.kinematics import expected_ball_pass_hz

#: Ball passes per Welch segment: resolution f_bp / 4, bins at multiples of f_bp / 4.
PASSES_PER_SEGMENT = 4
#: Points of the synthesised ripple waveform over one ball pass.
WAVEFORM_POINTS = 64
#: Phase bins of the folded raw trace.
FOLD_BINS = 16
#: Features that measure how well the trace determines the others and so grow with its length.
LENGTH_DEPENDENT = ("harmonic_snr", "duration_ball_passes", "ball_pass_peak_ratio")

_MAD_TO_SIGMA = 1.4826
_IQR_TO_SIGMA = 1.0 / 1.349


# --- one analysis per trace -------------------------------------------------------------------


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
    """f_bp maximising the summed power of its harmonics in a zero-padded Hann spectrum.

    Returns (frequency, peak-to-median ratio of the harmonic sum over the search band). The sum
    over harmonics keeps the search on f_bp where the first harmonic vanishes (comb zeros).
    """
    n = x.size
    if n < 4 or f_exp <= 0.0:
        return f_exp, 1.0
    n_fft = sfft.next_fast_len(4 * n, real=True)
    spec = np.abs(sfft.rfft(x * np.hanning(n), n_fft)) ** 2
    df = fs / n_fft
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


def _band_mean(f: np.ndarray, p: np.ndarray, lo: float, hi: float) -> float:
    sel = (f >= lo) & (f < hi)
    if np.any(sel):
        return float(p[sel].mean())
    if f.size == 0:
        return 0.0
    return float(np.interp(0.5 * (lo + hi), f, p))


def _band_power(f: np.ndarray, p: np.ndarray, lo: float, hi: float) -> float:
    """Integral of a one-sided PSD over [lo, hi): mean density times width."""
    hi = min(hi, f[-1] if f.size else hi)
    if hi <= lo:
        return 0.0
    return _band_mean(f, p, lo, hi) * (hi - lo)


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
            _band_mean(psd_f, res_psd, (k - 0.5) * f_bp, (k + 0.5) * f_bp)
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


def _debiased_amplitudes(a: TraceAnalysis) -> np.ndarray:
    raw2 = np.abs(a.coefficients) ** 2
    bias = 2.0 * a.noise_density / a.duration_s
    return np.sqrt(np.maximum(raw2 - bias, 0.0))


def _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis):
    if analysis is not None:
        return analysis
    if sample_rate_hz is None or omega_rad_s is None:
        raise TypeError("give sample_rate_hz and omega_rad_s (or a precomputed analysis)")
    return analyse_trace(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics=n_harmonics)


# --- feature groups (plain functions) ---------------------------------------------------------


def level_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [
        "level_mean_ohm",
        "level_median_ohm",
        "level_mad_ohm",
        "level_iqr_ohm",
        "level_mad_rel",
        "level_iqr_rel",
        "level_drift_rel_per_s",
    ]


def level_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """Level and robust spread of a trace.

    Mean and median of the samples; spread as sigma-equivalents of the median absolute
    deviation (1.4826 MAD) and of the interquartile range (IQR / 1.349) of the detrended trace,
    in ohm and relative to the mean; the linear drift relative to the level, per second.
    """
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    r = a.detrended
    mean = a.level_ohm
    med = float(np.median(r)) + mean
    mad = _MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r))))
    q75, q25 = np.percentile(r, [75.0, 25.0])
    iqr = _IQR_TO_SIGMA * float(q75 - q25)
    s = a.level_scale
    return {
        "level_mean_ohm": mean,
        "level_median_ohm": med,
        "level_mad_ohm": mad,
        "level_iqr_ohm": iqr,
        "level_mad_rel": mad / s,
        "level_iqr_rel": iqr / s,
        "level_drift_rel_per_s": a.drift_ohm_per_s / s,
    }


def spectrum_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return (
        ["psd_sub_rel"]
        + [f"psd_h{k}_rel" for k in range(1, n_harmonics + 1)]
        + ["psd_high_rel", "psd_total_rel"]
    )


def spectrum_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """Welch band powers of the detrended trace, as log10 of (band rms / level)^2.

    Segments span ``PASSES_PER_SEGMENT`` ball passes (Hann, density scaling). Bands, in units of
    the found f_bp: sub-synchronous [0.125, 0.5) (slow dynamics of the ring, drift left over),
    harmonic k [k - 0.5, k + 0.5), high [K + 0.5, 2 K + 0.5), total [0.125, 2 K + 0.5).
    A band beyond the Nyquist frequency is cut there.
    """
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    f, p, fb = a.psd_freq_hz, a.psd, a.ball_pass_hz
    s2 = a.level_scale**2
    tiny = 1e-30

    def band(lo: float, hi: float) -> float:
        return math.log10(_band_power(f, p, lo * fb, hi * fb) / s2 + tiny)

    out = {"psd_sub_rel": band(0.125, 0.5)}
    for k in range(1, n_harmonics + 1):
        out[f"psd_h{k}_rel"] = band(k - 0.5, k + 0.5)
    out["psd_high_rel"] = band(n_harmonics + 0.5, 2 * n_harmonics + 0.5)
    out["psd_total_rel"] = band(0.125, 2 * n_harmonics + 0.5)
    return out


def ball_pass_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [
        "omega_rad_s",
        "ball_pass_expected_hz",
        "ball_pass_found_hz",
        "ball_pass_slip",
        "ball_pass_peak_ratio",
        "harmonic_snr",
        "duration_ball_passes",
    ]


def ball_pass_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """The ball-pass frequency from geometry and omega, and the one found in the spectrum.

    ``ball_pass_slip`` = found / expected - 1 (cage slip; the DEM's is -0.2 % to 0 %);
    ``ball_pass_peak_ratio``: the harmonic-sum peak over its median in the +-1 % search band
    (~1-3 when nothing periodic is there); ``harmonic_snr``: fitted harmonic power over its
    noise variance 2 S / T (grows with the duration T); ``duration_ball_passes`` = T f_bp.
    """
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    raw2 = np.abs(a.coefficients) ** 2
    var = 2.0 * a.noise_density / a.duration_s
    snr = float(raw2.sum() / var.sum()) if var.sum() > 0 else 0.0
    return {
        "omega_rad_s": a.omega_rad_s,
        "ball_pass_expected_hz": a.expected_hz,
        "ball_pass_found_hz": a.ball_pass_hz,
        "ball_pass_slip": a.ball_pass_hz / a.expected_hz - 1.0 if a.expected_hz > 0 else 0.0,
        "ball_pass_peak_ratio": a.search_peak_ratio,
        "harmonic_snr": snr,
        "duration_ball_passes": a.duration_s * a.ball_pass_hz,
    }


def harmonic_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    ks = range(1, n_harmonics + 1)
    return (
        [f"h{k}_amp_ohm" for k in ks]
        + [f"h{k}_rel" for k in ks]
        + [f"h{k}_frac" for k in ks]
        + [f"h{k}_{part}_rel" for k in range(2, n_harmonics + 1) for part in ("even", "odd")]
    )


def harmonic_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """Amplitudes at the harmonics of the found ball-pass frequency, and their relative phases.

    ``h{k}_amp_ohm``: |c_k| debiased for the noise (ohm; independent of an offset on the level);
    ``h{k}_rel``: the same over the level; ``h{k}_frac``: |c_k|^2 / sum_j |c_j|^2 (shape only);
    ``h{k}_even_rel``, ``h{k}_odd_rel`` (k >= 2): the debiased |c_k| cos and sin of
    phi_k - k phi_1, over the level: harmonic k with the time origin where harmonic 1 peaks,
    which a time shift leaves unchanged. The load zone is symmetric about the load direction,
    so the waveform is nearly even about that origin and its signed even part carries the
    shape (peaks or dips where a ball enters the zone); the odd part is small (friction, slip).
    Harmonics above 0.45 fs are 0.
    """
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    amp = _debiased_amplitudes(a)
    s = a.level_scale
    power = float((amp**2).sum())
    frac = amp**2 / power if power > 0 else np.zeros_like(amp)
    out: dict[str, float] = {}
    for k in range(1, n_harmonics + 1):
        out[f"h{k}_amp_ohm"] = float(amp[k - 1])
    for k in range(1, n_harmonics + 1):
        out[f"h{k}_rel"] = float(amp[k - 1] / s)
    for k in range(1, n_harmonics + 1):
        out[f"h{k}_frac"] = float(frac[k - 1])
    c1 = a.coefficients[0]
    for k in range(2, n_harmonics + 1):
        ck = a.coefficients[k - 1]
        rel = float(np.angle(ck) - k * np.angle(c1)) if abs(c1) > 0 and abs(ck) > 0 else 0.0
        out[f"h{k}_even_rel"] = float(amp[k - 1] * math.cos(rel) / s)
        out[f"h{k}_odd_rel"] = float(amp[k - 1] * math.sin(rel) / s)
    return out


def noise_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [
        "noise_rms_rel",
        "noise_mad_rel",
        "noise_white_rel",
        "noise_colour",
        "noise_density_rel",
        "noise_sub_fraction",
        "noise_kurtosis",
    ]


def noise_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """What remains after removing level, drift and the ball-pass harmonics.

    Per sample, relative to the level: ``noise_rms_rel`` (std), ``noise_mad_rel``
    (1.4826 MAD), ``noise_white_rel`` (std of first differences / sqrt 2: the white part);
    ``noise_colour`` = rms / white (1 for white noise, > 1 with slow dynamics);
    ``noise_density_rel`` = log10(S f_bp / level^2), S the mean residual density around the
    harmonics (what sets the harmonics' uncertainty); ``noise_sub_fraction``: share of the
    residual power below f_bp / 2; ``noise_kurtosis``: excess kurtosis (impacts, quantisation).
    """
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    e = a.residual
    s = a.level_scale
    rms = float(e.std())
    mad = _MAD_TO_SIGMA * float(np.median(np.abs(e - np.median(e))))
    white = float(np.diff(e).std() / math.sqrt(2.0)) if e.size > 2 else rms
    f, p, fb = a.psd_freq_hz, a.residual_psd, a.ball_pass_hz
    total = _band_power(f, p, 0.0, f[-1] + 1.0) if f.size > 1 else 0.0
    sub = _band_power(f, p, 0.0, 0.5 * fb) if f.size > 1 else 0.0
    dens = float(a.noise_density.mean())
    var = float(np.mean(e**2))
    kurt = float(np.mean(e**4) / var**2 - 3.0) if var > 0 else 0.0
    return {
        "noise_rms_rel": rms / s,
        "noise_mad_rel": mad / s,
        "noise_white_rel": white / s,
        "noise_colour": rms / white if white > 0 else 1.0,
        "noise_density_rel": math.log10(dens * fb / s**2 + 1e-30),
        "noise_sub_fraction": sub / total if total > 0 else 0.0,
        "noise_kurtosis": kurt,
    }


def ripple_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [
        "ripple_rms_rel",
        "ripple_p2p_rel",
        "ripple_crest",
        "ripple_skew",
        "ripple_kurtosis",
        "ripple_asymmetry",
        "fold_p2p_rel",
        "fold_skew",
        "raw_skew",
        "raw_kurtosis",
    ]


def _shape_stats(w: np.ndarray) -> tuple[float, float, float, float]:
    """(crest, skewness, excess kurtosis, asymmetry) of a zero-mean waveform."""
    w2 = w * w
    var = float(w2.mean())
    if var <= 0.0:
        return 1.0, 0.0, 0.0, 0.0
    sd = math.sqrt(var)
    wmax, wmin = float(w.max()), float(w.min())
    crest = max(wmax, -wmin) / sd
    skew = float((w2 * w).mean() / sd**3)
    kurt = float((w2 * w2).mean() / var**2 - 3.0)
    asym = (wmax + wmin) / (wmax - wmin) if wmax > wmin else 0.0
    return crest, skew, kurt, asym


def ripple_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """Shape of the ripple over one ball pass.

    The waveform synthesised from the debiased harmonics (``WAVEFORM_POINTS`` points over one
    pass): rms and peak-to-peak relative to the level, crest factor, skewness, excess kurtosis
    and asymmetry (max + min) / (max - min) (> 0: peaks, < 0: dips). The raw trace folded at
    the found f_bp into ``FOLD_BINS`` phase bins: peak-to-peak of the bin means over the level
    and their skewness. The detrended raw samples: skewness and excess kurtosis (noise-led).
    """
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    s = a.level_scale
    amp = _debiased_amplitudes(a)
    raw = np.abs(a.coefficients)
    scale = np.divide(amp, raw, out=np.zeros_like(amp), where=raw > 0)
    c = a.coefficients * scale
    phi = 2.0 * math.pi * np.arange(WAVEFORM_POINTS) / WAVEFORM_POINTS
    k = np.arange(1, n_harmonics + 1)
    w = np.real(np.exp(1j * np.outer(phi, k)) @ c)
    crest, skew, kurt, asym = _shape_stats(w)
    # folded raw trace
    x = a.detrended
    fold_p2p, fold_skew = 0.0, 0.0
    if a.ball_pass_hz > 0 and x.size >= FOLD_BINS:
        t = np.arange(x.size) / a.sample_rate_hz
        b = np.floor((t * a.ball_pass_hz % 1.0) * FOLD_BINS).astype(int) % FOLD_BINS
        counts = np.bincount(b, minlength=FOLD_BINS)
        sums = np.bincount(b, weights=x, minlength=FOLD_BINS)
        ok = counts > 0
        means = sums[ok] / counts[ok]
        means = means - means.mean()
        fold_p2p = float(np.ptp(means) / s) if means.size else 0.0
        _, fold_skew, _, _ = _shape_stats(means)
    _, raw_skew, raw_kurt, _ = _shape_stats(x - x.mean())
    return {
        "ripple_rms_rel": float(math.sqrt(0.5 * float((amp**2).sum())) / s),
        "ripple_p2p_rel": float(np.ptp(w) / s),
        "ripple_crest": crest,
        "ripple_skew": skew,
        "ripple_kurtosis": kurt,
        "ripple_asymmetry": asym,
        "fold_p2p_rel": fold_p2p,
        "fold_skew": fold_skew,
        "raw_skew": raw_skew,
        "raw_kurtosis": raw_kurt,
    }


_GROUPS = (
    (level_feature_names, level_features),
    (spectrum_feature_names, spectrum_features),
    (ball_pass_feature_names, ball_pass_features),
    (harmonic_feature_names, harmonic_features),
    (noise_feature_names, noise_features),
    (ripple_feature_names, ripple_features),
)


def trace_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [name for names, _ in _GROUPS for name in names(n_harmonics)]


def trace_features(
    resistance_ohm,
    sample_rate_hz: float | None = None,
    omega_rad_s: float | None = None,
    *,
    n_harmonics: int = N_HARMONICS,
    analysis: TraceAnalysis | None = None,
) -> dict[str, float]:
    """Every feature of :data:`_GROUPS` from one analysis of the trace (names in that order)."""
    a = _analysis(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
    out: dict[str, float] = {}
    for _, function in _GROUPS:
        out.update(function(None, n_harmonics=n_harmonics, analysis=a))
    return out


# --- scikit-learn transformers ----------------------------------------------------------------


class _TraceTransformer(TransformerMixin, BaseEstimator):
    """Rows of ``X`` are traces sampled at ``sample_rate_hz``, shaft at ``omega_rad_s``.

    Stateless: ``fit`` only records the number of samples per trace.
    """

    _names = staticmethod(trace_feature_names)
    _function = staticmethod(trace_features)

    def __init__(
        self,
        sample_rate_hz: float = 20000.0,
        omega_rad_s: float = 500.0,
        n_harmonics: int = N_HARMONICS,
    ):
        self.sample_rate_hz = sample_rate_hz
        self.omega_rad_s = omega_rad_s
        self.n_harmonics = n_harmonics

    def fit(self, X, y=None):
        validate_data(self, X, dtype=np.float64)
        if not (isinstance(self.n_harmonics, int | np.integer) and self.n_harmonics >= 1):
            raise ValueError(f"n_harmonics = {self.n_harmonics!r}: must be an integer >= 1")
        return self

    def transform(self, X):
        check_is_fitted(self, "n_features_in_")
        X = validate_data(self, X, dtype=np.float64, reset=False)
        names = self._names(self.n_harmonics)
        out = np.empty((X.shape[0], len(names)))
        for i, row in enumerate(X):
            a = analyse_trace(
                row, self.sample_rate_hz, self.omega_rad_s, n_harmonics=self.n_harmonics
            )
            d = type(self)._function(None, n_harmonics=self.n_harmonics, analysis=a)
            out[i] = [d[n] for n in names]
        return out

    def get_feature_names_out(self, input_features=None):
        check_is_fitted(self, "n_features_in_")
        return np.asarray(self._names(self.n_harmonics), dtype=object)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = True
        return tags


class LevelFeatures(_TraceTransformer):
    """Transformer twin of :func:`level_features`."""

    _names = staticmethod(level_feature_names)
    _function = staticmethod(level_features)


class SpectrumFeatures(_TraceTransformer):
    """Transformer twin of :func:`spectrum_features`."""

    _names = staticmethod(spectrum_feature_names)
    _function = staticmethod(spectrum_features)


class BallPassFeatures(_TraceTransformer):
    """Transformer twin of :func:`ball_pass_features`."""

    _names = staticmethod(ball_pass_feature_names)
    _function = staticmethod(ball_pass_features)


class HarmonicFeatures(_TraceTransformer):
    """Transformer twin of :func:`harmonic_features`."""

    _names = staticmethod(harmonic_feature_names)
    _function = staticmethod(harmonic_features)


class NoiseFeatures(_TraceTransformer):
    """Transformer twin of :func:`noise_features`."""

    _names = staticmethod(noise_feature_names)
    _function = staticmethod(noise_features)


class RippleFeatures(_TraceTransformer):
    """Transformer twin of :func:`ripple_features`."""

    _names = staticmethod(ripple_feature_names)
    _function = staticmethod(ripple_features)


class TraceFeatures(_TraceTransformer):
    """Transformer twin of :func:`trace_features`: every feature group from one analysis."""


TRANSFORMERS = (
    LevelFeatures,
    SpectrumFeatures,
    BallPassFeatures,
    HarmonicFeatures,
    NoiseFeatures,
    RippleFeatures,
    TraceFeatures,
)
