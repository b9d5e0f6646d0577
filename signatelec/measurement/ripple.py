"""Is the ball-pass ripple in the trace, and at the frequency ``--omega`` predicts?

Each ball entering or leaving the load zone changes the Kirchhoff network (seed sections 3-4), so
a running bearing's resistance ripples at the ball-pass frequency f_bp
(:func:`signatelec.physics.kinematics.expected_ball_pass_hz`) and its harmonics. An estimate
read at the wrong frequency is no estimate: :func:`find_ripple` looks for the line in the data
and states its significance.

**Statistic.** The detrended trace's Hann-windowed periodogram, zero-padded :data:`PAD` times
(:func:`padded_power`), over its local noise floor (the median of the independent bins within
+-:data:`FLOOR_HALF_WIDTH` f_bp, / ln 2): ``z(f)``. On noise alone ``z`` is exponential of
mean 1 (the power of a complex Gaussian) and a sum of K harmonics' Gamma(K, 1); the floor being
itself a median of m cells makes them F(2, 2m) and K F(2K, 2m). The false-alarm probability of
the largest of M independent frequencies is 1 - (1 - p)^M (Scargle 1982, ApJ 263, 835, eq. 14;
Horne & Baliunas 1986, ApJ 302, 757). Two searches:

- the **strongest line** of the wide band :data:`WIDE_BAND` x f_bp (a ``--omega`` up to 4x
  off): the largest single ``z``, M = :data:`LINE_TRIALS_PER_CELL` x band x T (T the duration);
- **near f_bp**, within +-``SEARCH_REL`` (the estimator's band): the largest ``z`` of the
  fundamental alone (most of the ripple, mostly) and the largest sum of ``z(k f)``, k = 1..K
  below 0.45 fs (where the fundamental vanishes), each with half the false-alarm budget;
  M = 2 SEARCH_REL f_bp T, times K for the sum (the K-th harmonic moves K times as far).

A search *finds* a line below the false-alarm probability :data:`FALSE_ALARM`. On white noise
(10 000 traces of 250 and of 1000 samples) a line is reported for 0.14-0.18 % of them, against
the nominal 0.2 % of the two searches.

**Rules** (:class:`Ripple` ``.status``):

1. ``"constant"``: the trace does not vary;
2. the strongest line, when found, within the tolerance of f_bp: ``"found"``;
3. at a harmonic k f_bp (k = 2..K) within the tolerance: ``"found"`` if the fundamental is
   there too (its height read at f_bp, where the periodogram peaks within half a Fourier
   cell: the skirt of a line beside it is none; a 6204 given a third of its speed, whose
   ball-set line 1.6 cells below f_exp reached the threshold there, had been accepted), or
   a harmonic j f_bp whose order shares no divisor with k (its period is then
   1 / f_bp, which a ``--omega`` 1/k of the speed does not give: an outer-race spall of a
   6208, whose BPFO is its ball-pass frequency, puts its impulses' 3rd and 4th harmonics
   above a fundamental lost in their broadband floor), unless Z j / k is whole (then j f_bp
   is the cage's (Z j / k)-th harmonic at k times the speed: a 9-ball bearing given a third
   of its speed shows its cage's 6th harmonic at 2 f_bp); else ``"harmonic"`` (where the load
   zone's edge sits on a zero of the first harmonic the second carries the ripple), unless
   its amplitude exceeds :data:`HARMONIC_ONLY_MAX_REL` of the level by three standard
   errors: no DEM run shows a
   harmonic that large without its fundamental, a ``--omega`` 1/k of the speed does
   (``"elsewhere"``);
4. anywhere else, with an amplitude of at least :data:`ELSEWHERE_MIN_REL` of the level:
   ``"elsewhere"``, a wrong ``--omega`` (the line is read as the fundamental, which it is on
   nearly all traces), refused naming both frequencies and the speed the line implies.
   Unless the ripple stands out where the speed puts it (the search of rule 5 finds it within
   the tolerance) and the line is not the ripple of another speed: then ``"found"`` there,
   the line kept as ``beside``. Such a line is the k-th harmonic (k = 2..K) of a stronger line
   below it (:func:`_overtone`: a ripple has nothing below its fundamental); where its own
   k-th harmonic falls on the ripple found (:func:`_harmonic_at`: as a ``--omega`` k times the
   speed puts the ripple's k-th harmonic there), that stronger line must be the cage
   frequency FTF (:func:`_at_cage`: the ball set's rotation, whose Z-th harmonic is f_bp); and
   it is no defect's own line (BPFI's or 2 BSF's family,
   :func:`~signatelec.measurement.lines.defect_own`; the cage's
   and the shaft's harmonics, :data:`~signatelec.measurement.lines.HEALTHY_LINES`, are a
   healthy bearing's too). With a
   clearance the few loaded balls let the ball set's speed oscillate, at 0.11-0.16 f_bp (a
   6208 at epsilon 0.34, 670 rad/s: the DEM's cage speed wanders over 47-60 Hz, f_bp 378 Hz),
   or its rotation show at FTF = f_bp / Z; the resistance carries that line, below the wide
   band, and its harmonics, the second or third of which (0.22-0.34 f_bp) outgrows the ripple:
   8 of the 40 clearance traces of a 6208 dataset (epsilon 0.33-0.38) had been refused as a
   speed about 3.3 times lower. The one case left ambiguous: a bearing whose Z has a divisor
   k <= K (the 6208's 9 balls, k = 3) given a ``--omega`` k times the speed, where a line
   near FTF at the speed given outgrows the ripple (1 of its 120 traces at 3x the speed).
   Nor a ``--omega`` twice the speed of a trace whose 2nd harmonic outgrows its fundamental
   (few loaded balls: 65 of 600 such reads of 300 fast-DEM traces of six bearings): its odd
   harmonics at 3/2, 5/2, 7/2 f_exp cannot refuse it, as outer-race spalls show lines there
   at their own speed (4 of 80 fast-DEM traces at epsilon 0.23-0.47);
5. otherwise the search near f_bp: ``"found"``, or ``"elsewhere"`` outside the tolerance, or
   ``"none"`` (the model's domain decides: :mod:`signatelec.estimation.estimate`);
6. a trace answering ``"elsewhere"`` or ``"none"``, or found beside a stronger line (rule 4),
   is searched again at the speed read in the
   units a speed is most often given in by mistake (:data:`SPEED_UNITS`: a frequency in Hz,
   2 pi times smaller; rpm, 60 / (2 pi) times larger), which lie beyond the wide band (a
   speed in rpm puts the line at 0.105 f_bp, and its third harmonic inside the band, read as
   a line elsewhere at three times the speed): a ripple ``"found"`` there below
   :data:`UNIT_FALSE_ALARM` with no stronger line beside it, and not at a mains hum's or the
   shaft's harmonic (:func:`_interference`), is ``"elsewhere"``, naming the unit (``unit``).

**Tolerance** on found / expected - 1: the cage slip the model knows, :data:`SLIP_RANGE` (DEM
training runs), widened by :data:`OMEGA_TOLERANCE` (a tachometer's error on ``--omega``) and by
:data:`FREQUENCY_SIGMAS` standard errors of the found frequency, :data:`SIGMA_FACTOR` sqrt(6 /
z) / (2 pi T) (the Cramer-Rao bound of a sinusoid's frequency, z its peak power over the noise:
Rife & Boorstyn 1974, IEEE Trans. Inf. Theory 20, 591; the factor measured for this
estimator). A --omega off by 20 % or more lies outside it from 5 ball passes on, wherever the
line is found.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import fft as sfft
from scipy import stats

from signatelec.config.bearing import seed_bearing
from signatelec.measurement.band import MIN_BALL_PASSES, N_HARMONICS, SEARCH_REL, SPEED_UNITS
from signatelec.measurement.lines import defect_own
from signatelec.physics.kinematics import characteristic_frequencies_hz, expected_ball_pass_hz

#: Zero padding of the periodogram (frequency grid 1 / (PAD T)).
PAD = 4
#: Half-width of the noise floor's window, in expected f_bp (at least FLOOR_MIN_CELLS / T).
FLOOR_HALF_WIDTH = 2.0
FLOOR_MIN_CELLS = 16
#: The median of n exponentials is as precise as the mean of (ln 2)^2 n of them (its relative
#: standard error is 1 / (ln 2 sqrt(n))).
MEDIAN_EFFICIENCY = math.log(2.0) ** 2
#: The wide search, in multiples of the expected f_bp.
WIDE_BAND = (0.25, 4.0)
#: Independent trials per 1 / T of the wide band: the largest of a padded spectrum over a
#: continuous band exceeds the largest of its independent bins (measured on white noise).
LINE_TRIALS_PER_CELL = 2.0
#: False-alarm probability below which a search finds a line.
FALSE_ALARM = 1e-3
#: Cage slip over the DEM's training runs: f_bp found / kinematic - 1.
SLIP_RANGE = (-0.003, 0.001)
#: How far --omega may be off the true speed (a tachometer's reading), relative.
OMEGA_TOLERANCE = 0.002
#: Standard errors of the found frequency added to the tolerance.
FREQUENCY_SIGMAS = 4.0
#: The padded Hann peak's frequency scatters SIGMA_FACTOR times the Cramer-Rao bound written
#: with its own z (measured on sinusoids in white noise, z 16-1500: 1.25-1.74).
SIGMA_FACTOR = 1.5
#: Largest harmonic k >= 2 (relative to the level) that the DEM shows where the fundamental is
#: below 0.03 %: 0.04 % (h2, 300 held-out runs of datasets/load_state.toml's design; 0.06 %
#: over all of them), with a margin.
HARMONIC_ONLY_MAX_REL = 6e-4
#: Smallest line away from the ball-pass harmonics read as a ball-pass ripple (a wrong
#: --omega), relative to the level: the DEM's other content stays below 0.013 % (the strongest
#: line away from k f_bp +- 3 / T in 300 held-out runs of 0.2 s, at 0.27-0.30 f_bp); beyond
#: it, a clearance's ball-set oscillation (module rule 4, its exception).
ELSEWHERE_MIN_REL = 3e-4
#: False-alarm probability below which a ripple at the speed read in another unit names that
#: unit: stricter than FALSE_ALARM, as it refuses a trace the speed given finds no line in (a
#: speed given in the wrong unit shows its line at false-alarm probabilities of 1e-20 and
#: below on 0.1 s at 0.2 % noise).
UNIT_FALSE_ALARM = 1e-6
#: Mains frequencies, Hz: a line at one of their first :data:`INTERFERENCE_HARMONICS`
#: harmonics, or at the shaft's (an unbalance), names no unit (a hum of 0.02 % at 50 Hz, in a
#: trace at 582.7 rad/s whose ripple lies on a zero, sat where the speed read in rpm puts the
#: ripple, and had been read as a speed in rpm).
MAINS_HZ = (50.0, 60.0)
INTERFERENCE_HARMONICS = 8
#: How close a line is to an interference's line to be taken for it, relative (a grid's
#: frequency wanders by ~0.1 %), widened by :data:`FREQUENCY_SIGMAS` standard errors of the
#: line's frequency (the tolerance's rule).
INTERFERENCE_REL = 0.005


@functools.lru_cache(maxsize=4)
def hann(n: int) -> np.ndarray:
    """np.hanning(n), kept for the next trace or block of the same length (read-only): ~0.3 ms
    at 25000 points, on every screened block of a monitored trace."""
    window = np.hanning(n)
    window.flags.writeable = False
    return window


def padded_power(x: np.ndarray, fs: float, pad: int = PAD) -> tuple[np.ndarray, float]:
    """|rfft(x hann, n_fft)|^2 with n_fft >= pad n, and its bin width (Hz)."""
    n = x.size
    n_fft = sfft.next_fast_len(pad * n, real=True)
    return np.abs(sfft.rfft(x * hann(n), n_fft)) ** 2, fs / n_fft


def _detrended(r: np.ndarray) -> np.ndarray:
    """The trace less its mean and linear trend (sums, not BLAS products: a threaded dot of
    two long vectors is ~30x slower on busy cores)."""
    t = np.arange(r.size) - 0.5 * (r.size - 1)
    x = r - r.mean()
    slope = float(np.sum(t * x)) / float(np.sum(t * t)) if r.size > 1 else 0.0
    return x - slope * t


def _floor(
    power: np.ndarray, df: float, half_width_hz: float, pad: int = PAD, bins: int | None = None
) -> np.ndarray:
    """Noise floor per bin: the median over +-half_width_hz / ln 2, of every ``pad``-th bin
    (the independent ones), on a coarse grid, interpolated (a median at every bin of a 1 s,
    50 kHz trace would take seconds). ``bins``: only the floor of the first so many bins (the
    searches read up to a few f_bp: the medians of the grid beyond are not taken); each bin's
    floor is the same as that of the whole spectrum."""
    n = power.size
    half = max(int(half_width_hz / df), 1)
    centres = np.arange(0, n, max(half // 4, 1))
    bins = n if bins is None else min(bins, n)
    # the grid's points up to the first at or past the last bin asked for
    centres = centres[: int(np.searchsorted(centres, bins - 1)) + 1]
    med = np.empty(centres.size)
    # the windows inside the spectrum: equal lengths, their medians in one call
    inner = (centres >= half) & (centres + half + 1 <= n)
    if inner.any():
        at = centres[inner, None] - half + np.arange(0, 2 * half + 1, pad)
        med[inner] = np.median(power[at], axis=1, overwrite_input=True)  # a gathered copy
    for i in np.flatnonzero(~inner):
        c = centres[i]
        med[i] = np.median(power[max(0, c - half) : c + half + 1 : pad])
    return np.interp(np.arange(bins), centres, med) / math.log(2.0)


def _vertex(x: np.ndarray, y: np.ndarray, i: int) -> float:
    """Abscissa of the vertex of the parabola through the peak ``i`` and its neighbours."""
    if 0 < i < x.size - 1:
        a, b, c = y[i - 1], y[i], y[i + 1]
        den = a - 2.0 * b + c
        if den < 0.0:
            return float(x[i] + (x[1] - x[0]) * np.clip(0.5 * (a - c) / den, -0.5, 0.5))
    return float(x[i])


def _false_alarm(survival: float, trials: float) -> float:
    """1 - (1 - p)^M, accurate for small p."""
    p = min(max(survival, 0.0), 1.0 - 1e-16)
    return float(-math.expm1(max(trials, 1.0) * math.log1p(-p)))


@dataclass(frozen=True)
class Ripple:
    """The ball-pass ripple as found in a trace (frequencies in Hz).

    ``status``: ``"found"``, ``"harmonic"`` (only a harmonic ``harmonic`` of f_bp),
    ``"elsewhere"`` (a line away from f_bp: wrong --omega), ``"none"`` or ``"constant"``.
    ``frequency_hz``: the line's frequency (found, harmonic, elsewhere), ``false_alarm`` its
    false-alarm probability, ``statistic`` its normalised power (a comb: the sum over
    harmonics), ``tolerance`` the accepted range of found / expected - 1; ``bearings``: the
    catalogue bearings whose ball-pass line it is at the speed given (``"elsewhere"``).
    ``beside``: a stronger line away from f_bp that is not the ripple of another speed (rule
    4's exception), as the ``"elsewhere"`` it would have been. ``near``: of an ``"elsewhere"``
    rule 4 does not explain, the ripple found where the speed puts it all the same (rule 5),
    its fundamental below :data:`UNIT_FALSE_ALARM`, nothing stronger below it: a condition
    model may read the line past (:func:`signatelec.measurement.sanity.fault_line`)."""

    status: str
    omega_rad_s: float
    expected_hz: float
    frequency_hz: float = math.nan
    false_alarm: float = 1.0
    statistic: float = 0.0
    harmonic: int = 1
    tolerance: tuple[float, float] = (math.nan, math.nan)
    how: str = "line"
    unit: str | None = None
    beside: Ripple | None = None
    bearings: tuple[str, ...] = ()
    near: Ripple | None = None

    @property
    def implied_omega_rad_s(self) -> float:
        """The speed at which the line would be the kinematic ball-pass fundamental."""
        return self.omega_rad_s * self.frequency_hz / self.expected_hz

    def problem(self, speed: str | None = None) -> str | None:
        """The one-line reason to refuse the trace, or None when the ripple is there;
        ``speed``: what the user gave for the speed (default ``--omega`` and its value)."""
        om = speed or f"--omega {self.omega_rad_s:g}"
        if self.status == "elsewhere":
            unit = ""
            if self.unit is not None:
                rad_s = self.omega_rad_s * SPEED_UNITS[self.unit]
                unit = (
                    f"; was the speed given in {self.unit}? ({self.omega_rad_s:g} {self.unit} "
                    f"is {rad_s:.4g} rad/s)"
                )
            other = ""
            if self.bearings and self.unit is None:
                names = " or ".join(f"--bearing {b}" for b in self.bearings)
                other = (
                    f"; or is it another bearing? the line is the ball-pass frequency of "
                    f"{names} at {om}"
                )
            return (
                f"ripple at {self.frequency_hz:.1f} Hz (false-alarm probability "
                f"{self.false_alarm:.1g}), expected {self.expected_hz:.1f} Hz for {om}: the "
                f"trace's speed is about {self.implied_omega_rad_s:.0f} rad/s{unit}{other}"
            )
        if self.status == "constant":
            return (
                f"no ball-pass ripple found near {self.expected_hz:.1f} Hz: the trace is "
                "constant, not a running bearing"
            )
        if self.status == "none":
            return (
                f"no ball-pass ripple found near {self.expected_hz:.1f} Hz: wrong "
                f"{'--omega' if speed is None else speed}, or not a running bearing"
            )
        return None


def find_ripple(
    resistance_ohm,
    sample_rate_hz: float,
    omega_rad_s: float,
    n_harmonics: int = N_HARMONICS,
    *,
    bearing=None,
    units: bool = True,
) -> Ripple:
    """Search a uniformly sampled, finite trace for the ball-pass ripple (module rules) of
    ``bearing`` (default: the seed's); ``units``: rule 6 too (a record's later blocks, whose
    speed is given as its first's was, skip it: two more searches, ~4 ms on 0.5 s at
    50 kHz)."""
    ripple = _search(resistance_ohm, sample_rate_hz, omega_rad_s, n_harmonics, bearing)
    if ripple.status == "elsewhere":
        duration = np.asarray(resistance_ohm).size / sample_rate_hz
        ripple = replace(ripple, bearings=_bearings_at(ripple, duration))
    if not units or (ripple.status not in ("elsewhere", "none") and ripple.beside is None):
        return ripple
    for unit in SPEED_UNITS:
        there = ripple_in_unit(resistance_ohm, sample_rate_hz, omega_rad_s, unit, bearing=bearing)
        if there is not None:
            return Ripple(
                "elsewhere",
                omega_rad_s=ripple.omega_rad_s,
                expected_hz=ripple.expected_hz,
                frequency_hz=there.frequency_hz,
                false_alarm=there.false_alarm,
                statistic=there.statistic,
                how=there.how,
                unit=unit,
            )
    return ripple


def _bearings_at(line: Ripple, duration_s: float) -> tuple[str, ...]:
    """The catalogue bearings, other than the one the line was searched for, whose ball-pass
    frequency at the speed given is the line's, within the tolerance of a line found there
    (the cage slip, the tachometer and the line's frequency error): a trace of another bearing
    read as the seed's (the 6208's line, 0.689 times the seed's at a speed, had been read as a
    speed of 344 rad/s for 500)."""
    from signatelec.config.catalogue import CATALOGUE, catalogue_bearing

    out = []
    for designation in CATALOGUE:
        f_bp = expected_ball_pass_hz(line.omega_rad_s, catalogue_bearing(designation))
        if abs(f_bp / line.expected_hz - 1.0) < 1e-9:
            continue  # the bearing searched for
        lo, hi = _tolerance(line.statistic, duration_s, f_bp)
        if lo <= line.frequency_hz / f_bp - 1.0 <= hi:
            out.append(designation)
    return tuple(out)


def ripple_in_unit(
    resistance_ohm,
    sample_rate_hz: float,
    omega_rad_s: float,
    unit: str,
    n_harmonics: int = N_HARMONICS,
    bearing=None,
) -> Ripple | None:
    """The ripple at the speed ``omega_rad_s`` read in ``unit`` (:data:`SPEED_UNITS`) when
    found there below :data:`UNIT_FALSE_ALARM`, with no stronger line beside it (rule 4's
    exception is the speed given's: a spall's line read there at another speed is its own
    business), and at no interference's line
    (:func:`_interference`), else None (also when the trace spans fewer than
    :data:`MIN_BALL_PASSES` ball passes at that speed). Module rule 6."""
    r = np.asarray(resistance_ohm, dtype=float)
    duration = r.size / float(sample_rate_hz)
    omega = omega_rad_s * SPEED_UNITS[unit]
    if duration * expected_ball_pass_hz(omega, bearing) < MIN_BALL_PASSES:
        return None
    there = _search(r, sample_rate_hz, omega, n_harmonics, bearing)
    if (
        there.status == "found"
        and there.beside is None  # (no stronger line elsewhere: rule 4's exception is not read)
        and there.false_alarm < UNIT_FALSE_ALARM
        and not _interference(there, omega_rad_s, duration)
    ):
        return there
    return None


def _interference(line: Ripple, omega_rad_s: float, duration_s: float) -> bool:
    """Whether a ``line`` found may be a mains hum's or the shaft's (at ``omega_rad_s``)
    harmonic (:data:`MAINS_HZ`, :data:`INTERFERENCE_HARMONICS`, :data:`INTERFERENCE_REL`)."""
    f_hz = line.frequency_hz
    sigma = _sigma_hz(line.statistic, duration_s)
    for base in (*MAINS_HZ, omega_rad_s / (2.0 * math.pi)):
        k = max(1, min(INTERFERENCE_HARMONICS, round(f_hz / base)))
        if abs(f_hz - k * base) <= INTERFERENCE_REL * k * base + FREQUENCY_SIGMAS * sigma:
            return True
    return False


def _peak_near(
    z: np.ndarray,
    df: float,
    f_hz: float,
    statistic: float,
    duration_s: float,
    ratio: float,
    cells: float = 1.0,
) -> tuple[float, float]:
    """(normalised power, frequency) of the line at ``ratio`` times that of a line at ``f_hz``
    (normalised power ``statistic``): the largest ``z`` (on a grid of ``df`` Hz) within
    ``cells`` Fourier cells 1 / T of ratio f, widened by :data:`FREQUENCY_SIGMAS` standard
    errors of the line's frequency times ratio, when it is a spectral peak whose vertex
    (:func:`_vertex`) lies in that window (a line's own, not the skirt of one beside it);
    (0, nan) otherwise."""
    sigma = _sigma_hz(statistic, duration_s)
    width = cells / duration_s + FREQUENCY_SIGMAS * sigma * ratio
    lo = max(int(math.floor((ratio * f_hz - width) / df)), 1)
    hi = min(int(math.ceil((ratio * f_hz + width) / df)), z.size - 2)
    if hi < lo:
        return 0.0, math.nan
    i = lo + int(np.argmax(z[lo : hi + 1]))
    if z[i] >= z[i - 1] and z[i] >= z[i + 1]:
        f_peak = _vertex(np.arange(i - 1, i + 2) * df, z[i - 1 : i + 2], 1)
        if abs(f_peak - ratio * f_hz) <= width:
            return float(z[i]), f_peak
    return 0.0, math.nan


def _overtone(
    z: np.ndarray, df: float, f_hz: float, statistic: float, duration_s: float, n_harmonics: int
) -> float | None:
    """The frequency of a stronger line of which the line at ``f_hz`` (normalised power
    ``statistic``) is the k-th harmonic (k = 2..``n_harmonics``), or None: a line of larger
    normalised power at f / k (:func:`_peak_near`). A ball-pass ripple has nothing below its
    fundamental (module rule 4)."""
    for k in range(2, n_harmonics + 1):
        z_k, f_k = _peak_near(z, df, f_hz, statistic, duration_s, 1.0 / k)
        if z_k > statistic:
            return f_k
    return None


def _harmonic_at(
    f_hz: float, statistic: float, found_hz: float, duration_s: float, n_harmonics: int
) -> bool:
    """Whether a harmonic k = 2..``n_harmonics`` of the line at ``f_hz`` falls on the ripple
    found at ``found_hz``: within :data:`SEARCH_REL` of it, widened by k
    :data:`FREQUENCY_SIGMAS` standard errors of the line's frequency. A --omega k times the
    speed puts the ripple's own k-th harmonic there (module rule 4)."""
    k = round(found_hz / f_hz)
    width = SEARCH_REL * found_hz + k * FREQUENCY_SIGMAS * _sigma_hz(statistic, duration_s)
    return 2 <= k <= n_harmonics and abs(k * f_hz - found_hz) <= width


def _at_cage(f_hz: float, omega_rad_s: float, duration_s: float, bearing) -> bool:
    """Whether ``f_hz`` is the cage frequency FTF at ``omega_rad_s`` (within :data:`SEARCH_REL`
    and one Fourier cell 1 / T): the ball set's rotation, whose harmonics j FTF include the
    ball-pass frequency Z FTF."""
    f_cage = characteristic_frequencies_hz(omega_rad_s, bearing)["ftf"]
    return abs(f_hz - f_cage) <= SEARCH_REL * f_cage + 1.0 / duration_s


def _tolerance(statistic: float, duration_s: float, f_hz: float) -> tuple[float, float]:
    """The accepted range of found / expected - 1 of a line of normalised power ``statistic``
    expected at ``f_hz`` (module docstring, Tolerance)."""
    extra = OMEGA_TOLERANCE + FREQUENCY_SIGMAS * _sigma_hz(statistic, duration_s) / f_hz
    return SLIP_RANGE[0] - extra, SLIP_RANGE[1] + extra


def _sigma_hz(statistic: float, duration_s: float) -> float:
    """Standard error of a found line's frequency: :data:`SIGMA_FACTOR` times the Cramer-Rao
    bound sqrt(6 / z) / (2 pi T) (module docstring, Tolerance)."""
    return SIGMA_FACTOR * math.sqrt(6.0 / max(statistic, 1e-12)) / (2.0 * math.pi * duration_s)


def _search(
    resistance_ohm, sample_rate_hz: float, omega_rad_s: float, n_harmonics: int, bearing
) -> Ripple:
    """Rules 1-5 of the module docstring."""
    r = np.asarray(resistance_ohm, dtype=float)
    fs = float(sample_rate_hz)
    duration = r.size / fs
    f_exp = expected_ball_pass_hz(omega_rad_s, bearing)
    n_balls = (bearing or seed_bearing()).n_balls
    base = {"omega_rad_s": float(omega_rad_s), "expected_hz": f_exp}
    x = _detrended(r)
    level = abs(float(r.mean())) if r.size else 0.0
    if r.size < 4 or not float(np.max(np.abs(x))) > 1e-12 * max(level, 1e-300):
        return Ripple("constant", **base)
    power, df = padded_power(x, fs)
    f_max = 0.45 * fs
    # the searches: the wide band, and the comb of harmonics near the expected frequency
    lo_hz, hi_hz = WIDE_BAND[0] * f_exp, min(WIDE_BAND[1] * f_exp, f_max)
    ks = [k for k in range(1, n_harmonics + 1) if k * f_exp * (1 + SEARCH_REL) < f_max]
    # no harmonic below Nyquist: no comb (and no grid, whose step would not follow the trace)
    step = 1.0 / (8.0 * duration * ks[-1]) if ks else math.inf
    cand = (
        np.arange(f_exp * (1 - SEARCH_REL), f_exp * (1 + SEARCH_REL) + step, step) if ks else None
    )
    # z is read up to the highest of them (and the next bin, for interpolation and vertex)
    reach = max(hi_hz, ks[-1] * float(cand[-1]) if ks else 0.0)
    half_width = max(FLOOR_HALF_WIDTH * f_exp, FLOOR_MIN_CELLS / duration)
    floor = np.maximum(_floor(power, df, half_width, bins=int(reach / df) + 3), 1e-300)
    power = power[: floor.size]
    z = power / floor
    m = max(MEDIAN_EFFICIENCY * 2.0 * half_width * duration, 1.0)
    bins = np.arange(z.size)

    def at(freqs) -> np.ndarray:
        return np.interp(np.asarray(freqs) / df, bins, z)

    def within(f: float, statistic: float, k: int = 1) -> tuple[bool, tuple[float, float]]:
        lo, hi = _tolerance(statistic, duration, k * f_exp)
        return lo <= f / (k * f_exp) - 1.0 <= hi, (lo, hi)

    def side(f: float, statistic: float, ratio: float) -> float:
        """Normalised power at ``ratio`` times a line at ``f``, where a spectral peak lies
        within half a Fourier cell (:func:`_peak_near`; not the skirt of a line farther
        off), else 0 (also beyond the bins read)."""
        if ratio * f > (z.size - 2) * df:
            return 0.0
        if _peak_near(z, df, f, statistic, duration, ratio, cells=0.5)[0] <= 0.0:
            return 0.0
        return float(at(ratio * f))

    def comb() -> Ripple:
        """Rule 5: the search near the expected frequency."""
        if not ks:
            return Ripple("none", **base)
        band = 2.0 * SEARCH_REL * f_exp * duration
        # the fundamental alone (most of the ripple, mostly) and the sum over the harmonics
        # (where the fundamental vanishes), each with half the false-alarm budget
        first = at(cand)
        total = sum(at(k * cand) for k in ks)
        tests = []
        for stat, dof, trials in ((first, 1, band), (total, len(ks), band * ks[-1])):
            i = int(np.argmax(stat))
            p = float(stats.f.sf(stat[i] / dof, 2 * dof, 2 * m))
            tests.append((2.0 * _false_alarm(p, trials), _vertex(cand, stat, i), float(stat[i])))
        fa, f_comb, c = min(tests)
        if fa >= FALSE_ALARM:
            return Ripple("none", false_alarm=min(fa, 1.0), **base)
        found = {"frequency_hz": f_comb, "false_alarm": fa, "statistic": c, "how": "comb"}
        ok, tol = within(f_comb, c)
        return Ripple("found" if ok else "elsewhere", tolerance=tol, **found, **base)

    # the strongest line of the wide band
    sel = np.flatnonzero((bins * df >= lo_hz) & (bins * df <= hi_hz))
    if sel.size:
        j = int(sel[np.argmax(z[sel])])
        f_line, z_line = _vertex(bins * df, z, j), float(z[j])
        trials = LINE_TRIALS_PER_CELL * (hi_hz - lo_hz) * duration
        fa = _false_alarm(float(stats.f.sf(z_line, 2, 2 * m)), trials)
        # amplitude of a sinusoid from a Hann periodogram (|X| = A N / 4), and its noise
        amp = 4.0 * math.sqrt(max(power[j] - floor[j], 0.0)) / r.size
        amp_se = 4.0 * math.sqrt(0.5 * floor[j]) / r.size
        line = {"frequency_hz": f_line, "false_alarm": fa, "statistic": z_line}
        if fa < FALSE_ALARM:
            ok, tol = within(f_line, z_line)
            if ok:
                return Ripple("found", tolerance=tol, **line, **base)
            for k in range(2, n_harmonics + 1):
                ok, tol = within(f_line, z_line, k)
                if not ok:
                    continue
                if any(
                    stats.f.sf(side(f_line, z_line, j / k), 2, 2 * m) < FALSE_ALARM
                    for j in range(1, k)
                    if j == 1 or (math.gcd(j, k) == 1 and n_balls * j % k)
                ):
                    # the fundamental is there too, weaker than this harmonic, or a harmonic
                    # whose order shares no divisor with k: the period is 1 / f_bp (unless
                    # it is a cage harmonic at k times the speed: Z j / k whole)
                    return Ripple(
                        "found", tolerance=tol, **{**line, "frequency_hz": f_line / k}, **base
                    )
                if amp - 3.0 * amp_se <= HARMONIC_ONLY_MAX_REL * level:
                    return Ripple("harmonic", harmonic=k, tolerance=tol, **line, **base)
                break
            if amp >= ELSEWHERE_MIN_REL * level:
                # rule 4's exception: the ripple stands out where the speed puts it, and the
                # line is not its fundamental at a speed k times lower, nor a defect's own
                near = comb()
                under = _overtone(z, df, f_line, z_line, duration, n_harmonics)
                if (
                    near.status == "found"
                    and under is not None
                    and not defect_own(f_line, omega_rad_s, duration, bearing)
                    and (
                        not _harmonic_at(f_line, z_line, near.frequency_hz, duration, n_harmonics)
                        or _at_cage(under, omega_rad_s, duration, bearing)
                    )
                ):
                    return replace(near, beside=Ripple("elsewhere", **line, **base))
                # the ripple where the speed puts it all the same, for a condition model to
                # read the line past: its fundamental itself stands out, nothing stronger below
                z_near = float(at(near.frequency_hz)) if near.status == "found" else 0.0
                if (
                    stats.f.sf(z_near, 2, 2 * m) >= UNIT_FALSE_ALARM
                    or _overtone(z, df, near.frequency_hz, z_near, duration, n_harmonics)
                    is not None
                ):
                    near = None
                return Ripple("elsewhere", **line, **base, near=near)
    return comb()
