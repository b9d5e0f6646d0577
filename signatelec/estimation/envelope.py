"""Envelope analysis of a bearing-resistance trace: the lines a defect or a rotating load adds.

What a condition does to the resistance (the electrical signature of a defect, Bourbatache et
al., MSSP 2013; the seed's conclusion): a ball over a spall loses part or all of a contact, the
Kirchhoff network loses that ball's conductance and the resistance jumps for the time of the
passage, one short pulse per passage. The pulses repeat at the defect's characteristic frequency
(:func:`signatelec.physics.kinematics.characteristic_frequencies_hz`):

- an outer-race spall (fixed in the load zone): BPFO;
- an inner-race spall: BPFI; it enters the load zone once per shaft revolution, so the pulse
  height is modulated at f_s: sidebands at BPFI -+ f_s;
- a spall on a ball: 2 BSF (it meets both races once per spin revolution); the ball is in the
  load zone once per cage revolution: sidebands at 2 BSF -+ FTF and a line at FTF;
- an unbalance turns a load at the shaft frequency: the load zone breathes at f_s (a line at
  f_s and sidebands f_s around BPFO).

The healthy bearing itself ripples at BPFO and its harmonics (the load zone gains and loses a
ball each ball pass, seed section 4), so an outer-race spall is told by what it adds: short
pulses with energy far above the ripple's harmonics, which the envelope shows.

Steps (Randall and Antoni, "Rolling element bearing diagnostics: a tutorial", MSSP 25 (2011)
485-520, section 3):

1. **Band.** The STFT kurtogram (Antoni, "The spectral kurtosis: a useful tool for characterising
   non-stationary signals", MSSP 20 (2006) 282-307; Antoni and Randall, MSSP 20 (2006)
   308-331, eq. 8): for Hann windows of N_w = 2^3 ... 2^8 samples (75 % overlap) the spectral
   kurtosis SK(f) = <|X(t, f)|^4> / <|X(t, f)|^2>^2 - 2, zero for stationary Gaussian noise,
   -1 for a steady sinusoid (the healthy ripple), large where impulses dominate. The band is
   [f - fs / N_w, f + fs / N_w] of the largest SK among the bands that start above
   :data:`RIPPLE_HARMONICS` f_bp (above the healthy ripple's strong harmonics) and are at least
   :data:`BAND_LINES` times the highest characteristic line wide (so that the envelope carries
   that line and its sidebands). This is a simpler search than the fast kurtogram's filter
   bank (Antoni, MSSP 21 (2007) 108-124), with the same estimator of SK. Where no band
   qualifies (a low sampling rate) the band is [:data:`RIPPLE_HARMONICS` f_bp, 0.45 fs].
2. **Envelope.** The squared modulus of the band's analytic signal (Hilbert), taken as the
   inverse FFT of the band's one-sided spectrum (a zero-phase brick-wall filter): the squared
   envelope, whose spectrum Randall and Antoni (2011, section 3.3) recommend over the
   envelope's (no spurious harmonics from the square root).
3. **Spectra.** The amplitude spectra (Hann window, zero padded x4, scaled so that a sinusoid of
   amplitude A reads A) of the envelope less its mean and of the trace (less its level and
   drift); the amplitude of a line is the largest within +-:data:`SEARCH_REL` of its expected
   frequency (the DEM's cage slips by -0.3 to +0.1 %, a ball's spin more), widened to one
   frequency bin 1 / T of a short trace (the seed's 2 BSF and BPFO lie 3.5 % apart, 14 Hz at
   500 rad/s: wider windows would read one line for the other over 0.2 s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft

from signatelec.config.bearing import Bearing
from signatelec.physics.kinematics import characteristic_frequencies_hz

#: The characteristic lines read, in feature order.
LINES = ("shaft", "ftf", "bpfo", "bpfi", "ball_defect")
#: Harmonics of each line read.
LINE_HARMONICS = 3
#: Relative half-width of the search around a line.
SEARCH_REL = 0.01
#: Relative half-width of the neighbourhood whose median is a line's floor.
FLOOR_REL = 0.15
#: The band starts above this many ball-pass harmonics (the healthy ripple's strong ones).
RIPPLE_HARMONICS = 3.5
#: The band is at least this many times the highest characteristic line wide.
BAND_LINES = 2.5
#: Window lengths of the kurtogram, samples.
KURTOGRAM_WINDOWS = (8, 16, 32, 64, 128, 256)
#: Zero padding of the amplitude spectra.
PAD = 4
#: A trace for the condition must span this many cage revolutions: a ball's spall is in the load
#: zone once per cage revolution, and the lines 2 BSF -+ FTF need that resolution.
MIN_CAGE_REVOLUTIONS = 3.0


def spectral_kurtosis(x: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    """STFT spectral kurtosis of ``x`` with a Hann window of ``window`` samples, 75 % overlap:
    (bin index 0 .. window / 2, SK per bin) (Antoni and Randall 2006, eq. 8)."""
    step = max(window // 4, 1)
    if x.size < window:
        return np.arange(window // 2 + 1), np.zeros(window // 2 + 1)
    seg = np.lib.stride_tricks.sliding_window_view(x, window)[::step]
    spec = np.abs(sfft.rfft((seg - seg.mean(axis=1, keepdims=True)) * np.hanning(window), axis=1))
    p2 = np.mean(spec**2, axis=0)
    p4 = np.mean(spec**4, axis=0)
    sk = np.where(p2 > 0.0, p4 / np.maximum(p2, 1e-300) ** 2 - 2.0, 0.0)
    return np.arange(sk.size), sk


@dataclass(frozen=True)
class Band:
    """The demodulation band, Hz, and the spectral kurtosis that chose it (NaN: the rule)."""

    low_hz: float
    high_hz: float
    kurtosis: float
    window: int


def choose_band(x: np.ndarray, fs: float, ball_pass_hz: float, highest_line_hz: float) -> Band:
    """The band of largest spectral kurtosis (module docstring, step 1)."""
    floor = RIPPLE_HARMONICS * ball_pass_hz
    best = Band(floor, 0.45 * fs, math.nan, 0)
    for window in KURTOGRAM_WINDOWS:
        half = fs / window
        if 2.0 * half < BAND_LINES * highest_line_hz or window > x.size // 4:
            continue
        bins, sk = spectral_kurtosis(x, window)
        centre = bins * fs / window
        ok = (centre - half >= floor) & (centre + half <= 0.5 * fs)
        if not ok.any():
            continue
        j = int(np.flatnonzero(ok)[np.argmax(sk[ok])])
        if not sk[j] <= best.kurtosis:  # NaN compares False: the first candidate wins
            best = Band(centre[j] - half, centre[j] + half, float(sk[j]), window)
    return best


def band_envelope(x: np.ndarray, fs: float, band: Band) -> tuple[np.ndarray, np.ndarray]:
    """(band-passed signal, its squared Hilbert envelope), by one FFT of ``x``."""
    n = x.size
    spec = sfft.fft(x)
    f = np.abs(sfft.fftfreq(n, 1.0 / fs))
    keep = (f >= band.low_hz) & (f <= band.high_hz)
    one_sided = np.where(keep & (sfft.fftfreq(n) > 0), 2.0 * spec, 0.0)
    analytic = sfft.ifft(one_sided)
    return analytic.real, np.abs(analytic) ** 2


def amplitude_spectrum(x: np.ndarray, fs: float) -> tuple[np.ndarray, float]:
    """Amplitudes of ``x`` less its mean (Hann, zero-padded x :data:`PAD`), and the bin width;
    a sinusoid of amplitude A on a bin reads A."""
    n = x.size
    w = np.hanning(n)
    n_fft = sfft.next_fast_len(PAD * n, real=True)
    return 2.0 * np.abs(sfft.rfft((x - x.mean()) * w, n_fft)) / max(w.sum(), 1e-300), fs / n_fft


@dataclass(frozen=True)
class Spectrum:
    """An amplitude spectrum with the reading of lines in it."""

    amplitude: np.ndarray
    df_hz: float
    duration_s: float

    def _window(self, lo_hz: float, hi_hz: float) -> np.ndarray:
        i0 = max(int(math.floor(lo_hz / self.df_hz)), 0)
        i1 = min(int(math.ceil(hi_hz / self.df_hz)) + 1, self.amplitude.size)
        return self.amplitude[i0:i1]

    def line(self, f_hz: float) -> float:
        """Largest amplitude within +-SEARCH_REL of ``f_hz`` (at least +-1 / T, the bin width
        of the trace); 0 beyond Nyquist."""
        half = max(SEARCH_REL * f_hz, 1.0 / self.duration_s)
        a = self._window(f_hz - half, f_hz + half)
        return float(a.max()) if a.size and f_hz + half < self.df_hz * self.amplitude.size else 0.0

    def peak_hz(self, f_hz: float) -> float:
        """Frequency of the amplitude :meth:`line` reads (NaN beyond Nyquist): where the line
        expected at ``f_hz`` was found."""
        half = max(SEARCH_REL * f_hz, 1.0 / self.duration_s)
        a = self._window(f_hz - half, f_hz + half)
        if not a.size or f_hz + half >= self.df_hz * self.amplitude.size:
            return float("nan")
        i0 = max(int(math.floor((f_hz - half) / self.df_hz)), 0)
        return float((i0 + int(np.argmax(a))) * self.df_hz)

    def floor(self, f_hz: float) -> float:
        """Median amplitude within +-FLOOR_REL of ``f_hz`` (at least +-10 / T), the line's own
        window (+-SEARCH_REL, at least +-3 / T: the Hann main lobe) left out: what noise alone
        reads there."""
        inner = max(SEARCH_REL * f_hz, 3.0 / self.duration_s)
        outer = max(FLOOR_REL * f_hz, 10.0 / self.duration_s)
        a = np.concatenate(
            [self._window(f_hz - outer, f_hz - inner), self._window(f_hz + inner, f_hz + outer)]
        )
        return float(np.median(a)) if a.size else 0.0


@dataclass(frozen=True)
class EnvelopeAnalysis:
    """What the condition features read (see the module docstring)."""

    sample_rate_hz: float
    duration_s: float
    level_ohm: float
    lines_hz: dict
    band: Band
    raw: Spectrum
    envelope: Spectrum
    envelope_mean: float
    residual: np.ndarray
    band_signal: np.ndarray

    @property
    def cage_revolutions(self) -> float:
        return self.duration_s * self.lines_hz["ftf"]


def analyse_envelope(
    resistance_ohm,
    sample_rate_hz: float,
    omega_rad_s: float,
    *,
    bearing: Bearing | None = None,
    analysis=None,
) -> EnvelopeAnalysis:
    """The envelope analysis of one trace (module docstring). The trace's level, drift and
    ball-pass ripple come from :func:`~signatelec.estimation.analysis.analyse_trace` (or
    ``analysis``, the trace's own, already made); the band and the envelope are taken on what
    the ripple leaves, the raw lines on the trace less its level and drift."""
    from signatelec.estimation.analysis import analyse_trace

    a = analysis or analyse_trace(resistance_ohm, sample_rate_hz, omega_rad_s, bearing=bearing)
    fs = a.sample_rate_hz
    lines = characteristic_frequencies_hz(omega_rad_s, bearing)
    highest = max(lines[n] for n in LINES) + lines["shaft"]
    band = choose_band(a.residual, fs, a.ball_pass_hz, highest)
    band_signal, env = band_envelope(a.residual, fs, band)
    raw, df = amplitude_spectrum(a.detrended, fs)
    env_amp, env_df = amplitude_spectrum(env, fs)
    return EnvelopeAnalysis(
        sample_rate_hz=fs,
        duration_s=a.duration_s,
        level_ohm=a.level_ohm,
        lines_hz=lines,
        band=band,
        raw=Spectrum(raw, df, a.duration_s),
        envelope=Spectrum(env_amp, env_df, a.duration_s),
        envelope_mean=float(env.mean()),
        residual=a.residual,
        band_signal=band_signal,
    )
