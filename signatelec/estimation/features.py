"""Features of a bearing-resistance trace for load-state estimation.

A trace is the bearing's resistance ``r[n]`` (ohm) sampled uniformly at ``sample_rate_hz`` while
the inner ring turns at ``omega_rad_s``. Its physics (seed sections 3-4):

- the level falls with the radial load as F_r^(-4/3) (Hertz) and a little with epsilon;
- each ball entering or leaving the load zone changes the Kirchhoff network, so the resistance
  ripples at the ball-pass frequency f_bp = Z omega_c / 2 pi
  (:meth:`~signatelec.config.bearing.Bearing.ball_pass_frequency_hz`) and its harmonics; the
  ripple's size and shape, relative to the level, follow the load zone (epsilon), hardly the
  load: at zero clearance the first harmonic is 0.123-0.126 % of the level from 0.1 to 0.4 C_r
  (quasi-static tier), while it swings between ~0 and 0.22 % as epsilon goes from 0.3 to 0.6
  (a comb: it vanishes each time the load-zone edge has moved by about one ball);
- what is left after the harmonics is the measurement noise and the DEM's own dynamics (impacts
  and rattling of unloaded balls, more of it at large clearance).

Every feature is dimensionless or in SI units and, for a given continuous signal, does not depend
on the sampling rate or the trace length beyond what physics implies:

- frequencies are tied to f_bp: the Welch segment spans
  :data:`~signatelec.estimation.analysis.PASSES_PER_SEGMENT` ball passes, band
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

Each feature function takes one trace ``(resistance_ohm, sample_rate_hz, omega_rad_s)`` of any
length, or ``analysis=`` its :class:`~signatelec.estimation.analysis.TraceAnalysis` (one analysis
serves every group), and returns a ``dict`` whose keys are ``function.feature_names(K)`` in that
order (K = ``n_harmonics``). Each has a scikit-learn transformer twin in
:mod:`signatelec.estimation.transformers`:

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
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from numba import njit

from signatelec.estimation.analysis import (
    TraceAnalysis,
    analysis_of,
    band_power,
    debiased_amplitudes,
)
from signatelec.measurement.traces import N_HARMONICS

#: Bumped whenever a feature changes meaning: models trained on other features are refused.
FEATURE_SET_VERSION = 1
#: Points of the synthesised ripple waveform over one ball pass.
WAVEFORM_POINTS = 64
#: Features that measure how well the trace determines the others and so grow with its length.
LENGTH_DEPENDENT = ("harmonic_snr", "duration_ball_passes", "ball_pass_peak_ratio")

_MAD_TO_SIGMA = 1.4826
_IQR_TO_SIGMA = 1.0 / 1.349


def _mean(x: np.ndarray) -> float:
    """x.mean() of a short 1-D float array, the same sum and division without np.mean's
    dispatch (~1 us against ~4 us, several times per window)."""
    return float(np.add.reduce(x) / x.size)


@njit(cache=True, error_model="numpy")
def _pairwise_sum(a: np.ndarray) -> float:
    """np.sum of a contiguous 1-D array of at most 128 values, as numpy adds them (eight
    running sums, then pairwise; the same bits)."""
    n = a.size
    if n < 8:
        s = 0.0
        for i in range(n):
            s += a[i]
        return s
    r = a[:8].copy()
    i = 8
    while i < n - n % 8:
        for j in range(8):
            r[j] += a[i + j]
        i += 8
    s = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        s += a[i]
        i += 1
    return s


@njit(cache=True, error_model="numpy")
def shape_stats(w: np.ndarray) -> tuple[float, float, float, float]:
    """(crest, skewness, excess kurtosis, asymmetry) of a zero-mean waveform of at most 128
    points; (1, 0, 0, 0) for a flat one. Compiled (the numpy expression cost ~17 us on 64
    points, mostly calls), numpy's sums kept (:func:`_pairwise_sum`)."""
    n = w.size
    w2 = w * w
    var = _pairwise_sum(w2) / n
    flat = var <= 0.0
    var_s = 1.0 if flat else var
    sd = math.sqrt(var_s)
    wmax, wmin = w.max(), w.min()
    crest = 1.0 if flat else max(wmax, -wmin) / sd
    skew = 0.0 if flat else _pairwise_sum(w2 * w) / n / sd**3.0
    kurt = 0.0 if flat else _pairwise_sum(w2 * w2) / n / var_s**2.0 - 3.0
    span = wmax - wmin if wmax > wmin else 1.0
    asym = 0.0 if (flat or wmax <= wmin) else (wmax + wmin) / span
    return crest, skew, kurt, asym


def _group(names: Callable[[int], list[str]]):
    """Make ``compute(analysis) -> dict`` a feature function of one trace (or of its analysis)
    that carries its names: ``function.feature_names(n_harmonics)``."""

    def wrap(compute: Callable[[TraceAnalysis], dict[str, float]]):
        def function(
            resistance_ohm,
            sample_rate_hz: float | None = None,
            omega_rad_s: float | None = None,
            *,
            n_harmonics: int = N_HARMONICS,
            analysis: TraceAnalysis | None = None,
        ) -> dict[str, float]:
            a = analysis_of(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
            return compute(a)

        for attr in ("__module__", "__name__", "__qualname__", "__doc__"):
            setattr(function, attr, getattr(compute, attr))
        function.feature_names = names
        return function

    return wrap


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


@_group(level_feature_names)
def level_features(a: TraceAnalysis) -> dict[str, float]:
    """Level and robust spread of a trace.

    Mean and median of the samples; spread as sigma-equivalents of the median absolute
    deviation (1.4826 MAD) and of the interquartile range (IQR / 1.349) of the detrended trace,
    in ohm and relative to the mean; the linear drift relative to the level, per second.
    """
    st = a.statistics
    mean = a.level_ohm
    med = st["median"] + mean
    mad = _MAD_TO_SIGMA * st["mad"]
    iqr = _IQR_TO_SIGMA * (st["q75"] - st["q25"])
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


@_group(spectrum_feature_names)
def spectrum_features(a: TraceAnalysis) -> dict[str, float]:
    """Welch band powers of the detrended trace, as log10 of (band rms / level)^2.

    Segments span ``PASSES_PER_SEGMENT`` ball passes (Hann, density scaling). Bands, in units of
    the found f_bp: sub-synchronous [0.125, 0.5) (slow dynamics of the ring, drift left over),
    harmonic k [k - 0.5, k + 0.5), high [K + 0.5, 2 K + 0.5), total [0.125, 2 K + 0.5).
    A band beyond the Nyquist frequency is cut there.
    """
    n_harmonics = a.n_harmonics
    f, p, fb = a.psd_freq_hz, a.psd, a.ball_pass_hz
    s2 = a.level_scale**2
    tiny = 1e-30

    def band(lo: float, hi: float) -> float:
        return math.log10(band_power(f, p, lo * fb, hi * fb) / s2 + tiny)

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


@_group(ball_pass_feature_names)
def ball_pass_features(a: TraceAnalysis) -> dict[str, float]:
    """The ball-pass frequency from geometry and omega, and the one found in the spectrum.

    ``ball_pass_slip`` = found / expected - 1 (cage slip; the DEM's is -0.2 % to 0 %);
    ``ball_pass_peak_ratio``: the harmonic-sum peak over its median in the +-1 % search band
    (~1-3 when nothing periodic is there); ``harmonic_snr``: fitted harmonic power over its
    noise variance 2 S / T (grows with the duration T); ``duration_ball_passes`` = T f_bp.
    """
    raw2 = np.abs(a.coefficients) ** 2
    var = 2.0 * a.noise_density / a.duration_s
    var_sum = var.sum()
    snr = float(raw2.sum() / var_sum) if var_sum > 0 else 0.0
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


@_group(harmonic_feature_names)
def harmonic_features(a: TraceAnalysis) -> dict[str, float]:
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
    n_harmonics = a.n_harmonics
    amp = debiased_amplitudes(a)
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
    phase = np.angle(a.coefficients)
    for k in range(2, n_harmonics + 1):
        ck = a.coefficients[k - 1]
        rel = float(phase[k - 1] - k * phase[0]) if abs(c1) > 0 and abs(ck) > 0 else 0.0
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


@_group(noise_feature_names)
def noise_features(a: TraceAnalysis) -> dict[str, float]:
    """What remains after removing level, drift and the ball-pass harmonics.

    Per sample, relative to the level: ``noise_rms_rel`` (std), ``noise_mad_rel``
    (1.4826 MAD), ``noise_white_rel`` (std of first differences / sqrt 2: the white part);
    ``noise_colour`` = rms / white (1 for white noise, > 1 with slow dynamics);
    ``noise_density_rel`` = log10(S f_bp / level^2), S the mean residual density around the
    harmonics (what sets the harmonics' uncertainty); ``noise_sub_fraction``: share of the
    residual power below f_bp / 2; ``noise_kurtosis``: excess kurtosis (impacts, quantisation).
    """
    st = a.statistics
    s = a.level_scale
    rms = st["residual_std"]
    mad = _MAD_TO_SIGMA * st["residual_mad"]
    white = st["residual_white"]
    f, p, fb = a.psd_freq_hz, a.residual_psd, a.ball_pass_hz
    total = band_power(f, p, 0.0, f[-1] + 1.0) if f.size > 1 else 0.0
    sub = band_power(f, p, 0.0, 0.5 * fb) if f.size > 1 else 0.0
    dens = _mean(a.noise_density)
    var = st["residual_var"]
    kurt = st["residual_m4"] / var**2 - 3.0 if var > 0 else 0.0
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


@_group(ripple_feature_names)
def ripple_features(a: TraceAnalysis) -> dict[str, float]:
    """Shape of the ripple over one ball pass.

    The waveform synthesised from the debiased harmonics (``WAVEFORM_POINTS`` points over one
    pass): rms and peak-to-peak relative to the level, crest factor, skewness, excess kurtosis
    and asymmetry (max + min) / (max - min) (> 0: peaks, < 0: dips). The raw trace folded at
    the found f_bp into :data:`~signatelec.estimation.analysis.FOLD_BINS` phase bins:
    peak-to-peak of the bin means over the level and their skewness. The detrended raw
    samples: skewness and excess kurtosis (noise-led).
    """
    n_harmonics = a.n_harmonics
    s = a.level_scale
    amp = debiased_amplitudes(a)
    raw = np.abs(a.coefficients)
    scale = np.divide(amp, raw, out=np.zeros_like(amp), where=raw > 0)
    c = a.coefficients * scale
    # contiguous: shape_stats then has one compiled version (each loaded from numba's cache
    # costs some ms of a process's start)
    w = np.ascontiguousarray(np.real(_waveform_phasors(n_harmonics) @ c))
    crest, skew, kurt, asym = shape_stats(w)
    # folded raw trace
    st = a.statistics
    fold_p2p, fold_skew = 0.0, 0.0
    if "fold_counts" in st:
        counts, sums = st["fold_counts"], st["fold_sums"]
        ok = counts > 0
        means = sums[ok] / counts[ok]
        means = means - _mean(means)
        fold_p2p = float((means.max() - means.min()) / s) if means.size else 0.0
        fold_skew = shape_stats(means)[1]
    raw_skew, raw_kurt = st["raw_skew"], st["raw_kurtosis"]
    return {
        "ripple_rms_rel": float(math.sqrt(0.5 * float((amp**2).sum())) / s),
        "ripple_p2p_rel": float((w.max() - w.min()) / s),
        "ripple_crest": crest,
        "ripple_skew": skew,
        "ripple_kurtosis": kurt,
        "ripple_asymmetry": asym,
        "fold_p2p_rel": fold_p2p,
        "fold_skew": fold_skew,
        "raw_skew": raw_skew,
        "raw_kurtosis": raw_kurt,
    }


@functools.cache
def _waveform_phasors(n_harmonics: int) -> np.ndarray:
    """exp(i k phi) at the :data:`WAVEFORM_POINTS` phases of one ball pass, k = 1..K."""
    phi = 2.0 * math.pi * np.arange(WAVEFORM_POINTS) / WAVEFORM_POINTS
    out = np.exp(1j * np.outer(phi, np.arange(1, n_harmonics + 1)))
    out.flags.writeable = False
    return out


#: The feature groups, in the order of :func:`trace_features`.
FEATURE_GROUPS = (
    level_features,
    spectrum_features,
    ball_pass_features,
    harmonic_features,
    noise_features,
    ripple_features,
)


def trace_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [name for group in FEATURE_GROUPS for name in group.feature_names(n_harmonics)]


@_group(trace_feature_names)
def trace_features(a: TraceAnalysis) -> dict[str, float]:
    """Every feature of :data:`FEATURE_GROUPS` from one analysis of the trace (in that order)."""
    out: dict[str, float] = {}
    for group in FEATURE_GROUPS:
        out.update(group(None, analysis=a))
    return out
