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

:func:`window_features` gives :func:`trace_features` of many analyses as the rows of one table:
the same values, computed for all of them together (a monitor's block of windows).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from numba import njit

from signatelec.estimation.analysis import (
    FOLD_BINS,
    STATISTICS,
    TraceAnalysis,
    analysis_of,
    band_means,
    band_power,
    debiased_amplitudes,
)
from signatelec.estimation.harmonic_fit import pairwise_sum
from signatelec.measurement.band import N_HARMONICS

#: Bumped whenever a feature changes meaning: models trained on other features are refused.
FEATURE_SET_VERSION = 1
#: Points of the synthesised ripple waveform over one ball pass.
WAVEFORM_POINTS = 64
#: Features that measure how well the trace determines the others and so grow with its length.
LENGTH_DEPENDENT = ("harmonic_snr", "duration_ball_passes", "ball_pass_peak_ratio")

_MAD_TO_SIGMA = 1.4826
_IQR_TO_SIGMA = 1.0 / 1.349


@njit(cache=True, error_model="numpy")
def shape_stats(w: np.ndarray) -> tuple[float, float, float, float]:
    """(crest, skewness, excess kurtosis, asymmetry) of a zero-mean contiguous waveform; (1, 0,
    0, 0) for a flat one. Compiled (the numpy expression cost ~17 us on 64 points, mostly
    calls), numpy's sums kept (:func:`pairwise_sum`)."""
    n = w.size
    w2 = w * w
    var = pairwise_sum(w2) / n
    flat = var <= 0.0
    var_s = 1.0 if flat else var
    sd = math.sqrt(var_s)
    wmax, wmin = w.max(), w.min()
    crest = 1.0 if flat else max(wmax, -wmin) / sd
    skew = 0.0 if flat else pairwise_sum(w2 * w) / n / sd**3.0
    kurt = 0.0 if flat else pairwise_sum(w2 * w2) / n / var_s**2.0 - 3.0
    span = wmax - wmin if wmax > wmin else 1.0
    asym = 0.0 if (flat or wmax <= wmin) else (wmax + wmin) / span
    return crest, skew, kurt, asym


@njit(cache=True, error_model="numpy")
def _shapes(waveforms, fold_counts, fold_sums) -> np.ndarray:
    """Per row: :func:`shape_stats` of the waveform and its peak-to-peak; of the fold's bin
    means (bins holding samples, less their mean) the peak-to-peak and skewness (0, 0 when no
    bin holds any)."""
    rows = waveforms.shape[0]
    out = np.empty((rows, 7))
    for r in range(rows):
        w = waveforms[r]
        crest, skew, kurt, asym = shape_stats(w)
        ok = fold_counts[r] > 0
        means = fold_sums[r][ok] / fold_counts[r][ok]
        fold_p2p, fold_skew = 0.0, 0.0
        if means.size:
            means = means - pairwise_sum(means) / means.size
            fold_p2p = means.max() - means.min()
            fold_skew = shape_stats(means)[1]
        out[r] = crest, skew, kurt, asym, w.max() - w.min(), fold_p2p, fold_skew
    return out


class _Batch:
    """The analyses of one or more traces as columns, one row per trace: what the feature
    groups read. Its ``coefficients``, ``noise_density`` and ``duration_s`` (a column) are
    those :func:`~signatelec.estimation.analysis.debiased_amplitudes` reads."""

    def __init__(self, analyses):
        a = list(analyses)
        ks = {x.n_harmonics for x in a}
        if len(ks) != 1:
            raise ValueError(
                f"analyses of {sorted(ks)} harmonics: give at least one, all of one number"
            )
        self.n_harmonics = ks.pop()

        def column(name: str) -> np.ndarray:
            return np.array([getattr(x, name) for x in a], dtype=float)

        self.level = column("level_ohm")
        self.scale = column("level_scale")
        self.drift = column("drift_ohm_per_s")
        self.ball_pass_hz = column("ball_pass_hz")
        self.expected_hz = column("expected_hz")
        self.omega = column("omega_rad_s")
        self.peak_ratio = column("search_peak_ratio")
        self.duration_s = column("duration_s")[:, None]
        self.coefficients = np.array([x.coefficients for x in a], dtype=complex)
        self.noise_density = np.array([x.noise_density for x in a], dtype=float)
        self.stats = {k: np.array([x.statistics[k] for x in a]) for k in STATISTICS}
        fold = [x.statistics.get("fold_counts") for x in a]
        self.fold_counts = np.zeros((len(a), FOLD_BINS))
        self.fold_sums = np.zeros((len(a), FOLD_BINS))
        # (a fold of None: not asked for, the fold features NaN; none: no line to fold at or
        # too few samples, the fold features 0)
        self.folded = np.array(
            [
                f is not None or "fold_counts" not in x.statistics
                for x, f in zip(a, fold, strict=True)
            ]
        )
        for w, x in enumerate(a):
            if fold[w] is not None:
                self.fold_counts[w] = fold[w]
                self.fold_sums[w] = x.statistics["fold_sums"]
        self.start = np.concatenate([[0], np.cumsum([x.psd_freq_hz.size for x in a])])
        self.freq = np.concatenate([x.psd_freq_hz for x in a])
        self.psd = np.concatenate([x.psd for x in a])
        self.residual_psd = np.concatenate([x.residual_psd for x in a])
        self.residual_power = column("residual_power_ohm2")
        self.amplitude = debiased_amplitudes(self)
        self.power = np.add.reduce(self.amplitude**2, axis=1)

    def band_powers(self, p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """:func:`~signatelec.estimation.analysis.band_power` of each row's spectrum ``p``
        (:attr:`psd` or :attr:`residual_psd`) over the bands [lo, hi) (Hz, rows x bands)."""
        hi = np.minimum(hi, self.freq[self.start[1:] - 1][:, None])
        mean = band_means(self.freq, p, self.start, lo, hi)
        power = np.where(hi > lo, mean * (hi - lo), 0.0)
        for w, b in zip(*np.nonzero(np.isnan(power)), strict=True):
            # no bin in the band: its centre interpolated
            at = slice(self.start[w], self.start[w + 1])
            power[w, b] = band_power(self.freq[at], p[at], lo[w, b], hi[w, b])
        return power


def _log10(values: np.ndarray) -> np.ndarray:
    """math.log10 of each value (numpy's vectorised log10 may differ from it in the last bit,
    and the models were trained on math.log10's)."""
    return np.array([math.log10(v) for v in values.tolist()])


def _squares(values: np.ndarray) -> np.ndarray:
    """v**2 of each value as Python computes it (pow, not numpy's v * v: they may differ in
    the last bit, and the models were trained on Python's)."""
    return np.array([v**2 for v in values.tolist()])


def _group(names: Callable[[int], list[str]]):
    """Make ``columns(batch) -> [array per feature]`` a feature function of one trace (or of
    its analysis) that carries its names, ``function.feature_names(n_harmonics)``, and its
    columns (``function.columns``, what :func:`window_features` reads)."""

    def wrap(columns: Callable[[_Batch], list[np.ndarray]]):
        def function(
            resistance_ohm,
            sample_rate_hz: float | None = None,
            omega_rad_s: float | None = None,
            *,
            n_harmonics: int = N_HARMONICS,
            analysis: TraceAnalysis | None = None,
        ) -> dict[str, float]:
            a = analysis_of(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, analysis)
            values = np.array(columns(_Batch([a])))[:, 0].tolist()
            return dict(zip(names(a.n_harmonics), values, strict=True))

        for attr in ("__module__", "__name__", "__qualname__", "__doc__"):
            setattr(function, attr, getattr(columns, attr))
        function.feature_names = names
        function.columns = columns
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
def level_features(b: _Batch) -> list[np.ndarray]:
    """Level and robust spread of a trace.

    Mean and median of the samples; spread as sigma-equivalents of the median absolute
    deviation (1.4826 MAD) and of the interquartile range (IQR / 1.349) of the detrended trace,
    in ohm and relative to the mean; the linear drift relative to the level, per second.
    """
    st = b.stats
    mad = _MAD_TO_SIGMA * st["mad"]
    iqr = _IQR_TO_SIGMA * (st["q75"] - st["q25"])
    s = b.scale
    return [b.level, st["median"] + b.level, mad, iqr, mad / s, iqr / s, b.drift / s]


def spectrum_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return (
        ["psd_sub_rel"]
        + [f"psd_h{k}_rel" for k in range(1, n_harmonics + 1)]
        + ["psd_high_rel", "psd_total_rel"]
    )


@_group(spectrum_feature_names)
def spectrum_features(b: _Batch) -> list[np.ndarray]:
    """Welch band powers of the detrended trace, as log10 of (band rms / level)^2.

    Segments span ``PASSES_PER_SEGMENT`` ball passes (Hann, density scaling). Bands, in units of
    the found f_bp: sub-synchronous [0.125, 0.5) (slow dynamics of the ring, drift left over),
    harmonic k [k - 0.5, k + 0.5), high [K + 0.5, 2 K + 0.5), total [0.125, 2 K + 0.5).
    A band beyond the Nyquist frequency is cut there.
    """
    k = b.n_harmonics
    edges = [(0.125, 0.5), *((j - 0.5, j + 0.5) for j in range(1, k + 1))]
    edges += [(k + 0.5, 2 * k + 0.5), (0.125, 2 * k + 0.5)]
    lo, hi = (np.array(e)[None, :] * b.ball_pass_hz[:, None] for e in zip(*edges, strict=True))
    power = b.band_powers(b.psd, lo, hi) / _squares(b.scale)[:, None]
    return [_log10(band + 1e-30) for band in power.T]


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
def ball_pass_features(b: _Batch) -> list[np.ndarray]:
    """The ball-pass frequency from geometry and omega, and the one found in the spectrum.

    ``ball_pass_slip`` = found / expected - 1 (cage slip; the DEM's is -0.2 % to 0 %);
    ``ball_pass_peak_ratio``: the harmonic-sum peak over its median in the +-1 % search band
    (~1-3 when nothing periodic is there); ``harmonic_snr``: fitted harmonic power over its
    noise variance 2 S / T (grows with the duration T); ``duration_ball_passes`` = T f_bp.
    """
    var = 2.0 * b.noise_density / b.duration_s
    var_sum = np.add.reduce(var, axis=1)
    raw2 = np.add.reduce(np.abs(b.coefficients) ** 2, axis=1)
    snr = np.divide(raw2, var_sum, out=np.zeros_like(var_sum), where=var_sum > 0)
    fb, f_exp = b.ball_pass_hz, b.expected_hz
    slip = np.divide(fb, f_exp, out=np.ones_like(fb), where=f_exp > 0) - 1.0
    return [b.omega, f_exp, fb, slip, b.peak_ratio, snr, b.duration_s[:, 0] * fb]


def harmonic_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    ks = range(1, n_harmonics + 1)
    return (
        [f"h{k}_amp_ohm" for k in ks]
        + [f"h{k}_rel" for k in ks]
        + [f"h{k}_frac" for k in ks]
        + [f"h{k}_{part}_rel" for k in range(2, n_harmonics + 1) for part in ("even", "odd")]
    )


@_group(harmonic_feature_names)
def harmonic_features(b: _Batch) -> list[np.ndarray]:
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
    amp, c = b.amplitude, b.coefficients
    s = b.scale[:, None]
    power = b.power[:, None]
    frac = np.divide(amp**2, power, out=np.zeros_like(amp), where=power > 0)
    phase = np.angle(c)
    ks = np.arange(2, b.n_harmonics + 1)
    nonzero = (np.abs(c[:, :1]) > 0) & (np.abs(c[:, 1:]) > 0)
    rel = np.where(nonzero, phase[:, 1:] - ks * phase[:, :1], 0.0)
    even = amp[:, 1:] * np.cos(rel) / s
    odd = amp[:, 1:] * np.sin(rel) / s
    parts = np.stack([even, odd], axis=2).reshape(len(amp), -1)
    return [*amp.T, *(amp / s).T, *frac.T, *parts.T]


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
def noise_features(b: _Batch) -> list[np.ndarray]:
    """What remains after removing level, drift and the ball-pass harmonics.

    Per sample, relative to the level: ``noise_rms_rel`` (std), ``noise_mad_rel``
    (1.4826 MAD), ``noise_white_rel`` (std of first differences / sqrt 2: the white part);
    ``noise_colour`` = rms / white (1 for white noise, > 1 with slow dynamics);
    ``noise_density_rel`` = log10(S f_bp / level^2), S the mean residual density around the
    harmonics (what sets the harmonics' uncertainty); ``noise_sub_fraction``: share of the
    residual power below f_bp / 2; ``noise_kurtosis``: excess kurtosis (impacts, quantisation).
    """
    st = b.stats
    s = b.scale
    rms, white = st["residual_std"], st["residual_white"]
    fb = b.ball_pass_hz
    total = b.residual_power
    sub = b.band_powers(b.residual_psd, np.zeros((len(s), 1)), 0.5 * fb[:, None])[:, 0]
    dens = np.add.reduce(b.noise_density, axis=1) / b.n_harmonics
    var = st["residual_var"]
    kurt = np.divide(st["residual_m4"], _squares(var), out=np.full_like(var, 3.0), where=var > 0)
    return [
        rms / s,
        _MAD_TO_SIGMA * st["residual_mad"] / s,
        white / s,
        np.divide(rms, white, out=np.ones_like(rms), where=white > 0),
        _log10(dens * fb / _squares(s) + 1e-30),
        np.divide(sub, total, out=np.zeros_like(sub), where=total > 0),
        kurt - 3.0,
    ]


#: The features of the trace folded at f_bp (``analyse_windows(..., fold=)``).
FOLDED = ("fold_p2p_rel", "fold_skew")


def ripple_feature_names(n_harmonics: int = N_HARMONICS) -> list[str]:
    return [
        "ripple_rms_rel",
        "ripple_p2p_rel",
        "ripple_crest",
        "ripple_skew",
        "ripple_kurtosis",
        "ripple_asymmetry",
        *FOLDED,
        "raw_skew",
        "raw_kurtosis",
    ]


@_group(ripple_feature_names)
def ripple_features(b: _Batch) -> list[np.ndarray]:
    """Shape of the ripple over one ball pass.

    The waveform synthesised from the debiased harmonics (``WAVEFORM_POINTS`` points over one
    pass): rms and peak-to-peak relative to the level, crest factor, skewness, excess kurtosis
    and asymmetry (max + min) / (max - min) (> 0: peaks, < 0: dips). The raw trace folded at
    the found f_bp into :data:`~signatelec.estimation.analysis.FOLD_BINS` phase bins:
    peak-to-peak of the bin means over the level and their skewness. The detrended raw
    samples: skewness and excess kurtosis (noise-led).
    """
    amp, c = b.amplitude, b.coefficients
    raw = np.abs(c)
    c = c * np.divide(amp, raw, out=np.zeros_like(amp), where=raw > 0)
    phasors = _waveform_phasors(b.n_harmonics)
    waveforms = np.empty((len(c), WAVEFORM_POINTS))
    for w, cw in enumerate(c):  # one product per trace, as a trace alone has it
        waveforms[w] = np.real(phasors @ cw)
    shapes = _shapes(waveforms, b.fold_counts, b.fold_sums).T
    shapes[5:, ~b.folded] = np.nan  # (not folded: analyse_windows' fold)
    s = b.scale
    return [
        np.sqrt(0.5 * b.power) / s,
        shapes[4] / s,
        *shapes[:4],
        shapes[5] / s,
        shapes[6],
        b.stats["raw_skew"],
        b.stats["raw_kurtosis"],
    ]


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
def trace_features(b: _Batch) -> list[np.ndarray]:
    """Every feature of :data:`FEATURE_GROUPS` from one analysis of the trace (in that order)."""
    return [column for group in FEATURE_GROUPS for column in group.columns(b)]


def analysis_options(names) -> dict:
    """The options of :func:`~signatelec.estimation.analysis.analyse_windows` that compute what
    only some features read, set for the features ``names`` (the others' values are then NaN)."""
    names = set(names)
    return {"residual_mad": "noise_mad_rel" in names, "fold": not names.isdisjoint(FOLDED)}


def window_features(analyses) -> np.ndarray:
    """:func:`trace_features` of each analysis (of traces of one number of harmonics) as a row
    of a table whose columns are :func:`trace_feature_names`: the same values, computed for
    all traces at once (a monitor's batch of windows: ~10 us a window against ~80 us one by
    one)."""
    return np.array(trace_features.columns(_Batch(analyses))).T
