"""A measured resistance trace: read it, repair what is safe, refuse what is not.

:func:`~signatelec.measurement.files.read_trace` reads a CSV or Parquet table with a time column
(s) and a resistance column (ohm); :func:`prepare_trace` turns the two columns into a uniformly
sampled, finite trace fit for
:mod:`signatelec.estimation.features`, or raises :class:`TraceError` with one line saying what is
wrong.

Repaired (each repair is listed in :attr:`Trace.repairs`):

- a simulation's set-up (``signatelec simulate``'s ``signals.parquet`` has a ``phase`` column:
  clearance, load, spin-up, steady): only the steady phase is kept;
- missing resistance samples (NaN, empty cells) and isolated open-circuit samples (``inf``,
  <= 0 or above ``OPEN_CIRCUIT_OHM``: no ball touching both rings, a contact lost by the
  meter) in gaps of at most ``MAX_GAP_BALL_PASSES`` of a ball pass, and at most
  ``MAX_BAD_FRACTION`` of the samples in all: linear interpolation between the neighbours; at
  the ends: cut off;
- rows with a missing time: dropped (at most ``MAX_BAD_FRACTION``);
- non-uniform sampling (jitter above ``JITTER_TOLERANCE`` of the median step, or dropped
  samples): linear interpolation onto a uniform grid at the median rate (gaps as above); times
  whose steps spread by no more than their rounding to doubles (an epoch clock's) are one
  clock's, uniform at the mean step.

Refused:

- a time column that does not increase strictly (repeated or backward times);
- more than ``MAX_BAD_FRACTION`` of the samples missing, or a gap longer than
  ``MAX_GAP_BALL_PASSES`` of a ball pass (the ripple cannot be filled in);
- open circuit (infinite, non-positive or above ``OPEN_CIRCUIT_OHM``) beyond
  ``MAX_OPEN_FRACTION``;
- a median resistance below ``MIN_LEVEL_OHM`` (a column in another unit);
- a trace shorter than ``MIN_BALL_PASSES`` ball passes at the given omega, or sampled below
  :func:`minimum_sample_rate_hz` (the harmonics would alias); the refusal asks whether the
  speed was given in Hz or rpm (:data:`SPEED_UNITS`) when read so it would pass and the
  trace shows its ripple there;
- omega not a finite speed > 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from signatelec.config.bearing import Bearing
from signatelec.engines.results import PHASES
from signatelec.measurement.band import MIN_BALL_PASSES, N_HARMONICS, SEARCH_REL, SPEED_UNITS
from signatelec.physics.kinematics import expected_ball_pass_hz


def minimum_sample_rate_hz(
    omega_rad_s: float, n_harmonics: int = N_HARMONICS, bearing: Bearing | None = None
) -> float:
    """Lowest sampling rate whose Nyquist band holds the bands of
    :func:`signatelec.estimation.features.spectrum_features`.

    The top band ends at (2 K + 0.5) f_bp (K harmonics); with the search margin
    (:data:`SEARCH_REL`) that asks for fs >= 2 (2 K + 0.5) f_bp (1 + SEARCH_REL).
    """
    return (
        2.0
        * (2 * n_harmonics + 0.5)
        * expected_ball_pass_hz(omega_rad_s, bearing)
        * (1.0 + SEARCH_REL)
    )


def unit_hint(r: np.ndarray, fs: float, omega_rad_s: float, bearing, passes) -> str:
    """A question naming the first unit of :data:`SPEED_UNITS` the speed would pass a check
    in (``passes(omega_rad_s)`` true) and at whose speed the trace ``r`` (uniform at ``fs``,
    its missing samples left out) shows its ripple
    (:func:`~signatelec.measurement.ripple.ripple_in_unit`), for a refusal: '' if none."""
    from signatelec.measurement.ripple import ripple_in_unit

    x = r[np.isfinite(r)]
    for unit, rad_s in SPEED_UNITS.items():
        alt = omega_rad_s * rad_s
        if passes(alt) and ripple_in_unit(x, fs, omega_rad_s, unit, bearing=bearing) is not None:
            return f"; was the speed given in {unit}? ({omega_rad_s:g} {unit} is {alt:.4g} rad/s)"
    return ""


#: Largest share of samples that may be missing (NaN, no time) and filled in.
MAX_BAD_FRACTION = 0.05
#: Largest share of open-circuit samples (inf or <= 0 ohm) that may be filled in.
MAX_OPEN_FRACTION = 0.01
#: Readings above this are open circuit, not a bearing's resistance: metallic contacts give
#: milliohms (seed section 3), and a meter out of range reports its overflow value (9.9e37 for
#: SCPI instruments) rather than inf. Beyond it the features' powers of R could also overflow.
OPEN_CIRCUIT_OHM = 1e6
#: Smallest median resistance accepted: a bearing's contact resistance is of the order of a
#: milliohm (seed section 3) and the finest ohmmeters resolve about a nano-ohm; a far smaller
#: level is a column in another unit, and the fourth powers of its ripple (the kurtosis
#: features) would underflow.
MIN_LEVEL_OHM = 1e-9
#: Longest gap filled in, in ball passes.
MAX_GAP_BALL_PASSES = 0.25
#: Relative jitter of the time step below which the sampling counts as uniform.
JITTER_TOLERANCE = 1e-3
#: Spread of the time steps (largest less smallest, relative) within which, beside the times'
#: rounding to doubles, they are one clock's step (:func:`rounded_uniform`).
UNIFORM_STEPS = 1e-6


class TraceError(ValueError):
    """A trace that cannot be used; the message is one line naming the trace and the rule."""


@dataclass(frozen=True)
class Trace:
    """A uniformly sampled, finite resistance trace (time from 0)."""

    time_s: np.ndarray
    resistance_ohm: np.ndarray
    sample_rate_hz: float
    source: str = "trace"
    repairs: tuple[str, ...] = field(default=())

    @property
    def duration_s(self) -> float:
        return self.resistance_ohm.size / self.sample_rate_hz


#: The phase of a simulation's output that is a running bearing's trace.
STEADY_PHASE = PHASES[-1]


def daylight_saving(jump_s: float) -> str:
    """For a message on a time that jumps by ``jump_s``: a clause naming a local clock's change
    for daylight saving when the jump is an hour, or a time of day past midnight when it goes
    back a day, to within a second (timestamps without a zone are read as UTC), else ''."""
    if abs(jump_s + 86400.0) <= 1.0:
        return " (the time goes back a day: a time of day past midnight? give dates too)"
    if abs(abs(jump_s) - 3600.0) > 1.0:
        return ""
    return (
        f" (the time {'goes back' if jump_s < 0 else 'jumps'} an hour: a local clock changed "
        "for daylight saving? give its timestamps with their UTC offset)"
    )


def short_of(value: float, needed: float) -> tuple[str, str]:
    """``value`` and the larger ``needed`` written with the fewest significant digits (3 at
    least) that still show the first below the second: a shortfall is not rounded up to the
    requirement (4.9996 of 5 ball passes is "4.9996", not "5")."""
    for digits in range(3, 17):
        have, need = f"{value:.{digits}g}", f"{needed:.{digits}g}"
        if float(have) < float(need):
            return have, need
    return repr(value), repr(needed)


def time_text(t_s: float) -> str:
    """A time in seconds as messages give it: to the microsecond, trailing zeros dropped (a
    logger's clock may read 1.7e9 s, where 6 significant digits say nothing)."""
    return f"{t_s:.6f}".rstrip("0").rstrip(".") if math.isfinite(t_s) else str(t_s)


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of each run of True in ``mask``."""
    if not mask.any():
        return []
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))


def rounded_uniform(t: np.ndarray, dt_min: float, dt_max: float) -> bool:
    """Whether increasing times ``t`` (steps from ``dt_min`` to ``dt_max``) are one clock's:
    their steps spread by no more than the times' rounding to doubles explains (2 ulp of the
    largest |t|: 4.8e-7 s at a logger's epoch time of 1.7e9 s, 2.4 % of a step at 50 kHz, and
    ~1e-12 s over an hour from 0) or :data:`UNIFORM_STEPS`. (A dropped sample passes for
    rounding only where a step is below 2 ulp: above ~2 MHz at epoch times.)"""
    rounding = 2.0 * float(np.spacing(max(abs(float(t[0])), abs(float(t[-1])))))
    return dt_max - dt_min <= rounding + UNIFORM_STEPS * dt_min


def sampling_step(t: np.ndarray, dt: np.ndarray, dt_min: float, dt_max: float) -> float:
    """The sampling step of increasing times ``t`` (steps ``dt``, their extremes): one clock's
    (:func:`rounded_uniform`): the span over the steps, where rounding spreads them (the median
    step of epoch times at 50 kHz was 0.14 % off); else their median (robust to a few dropped
    samples; ~0.4 ms for the 100000 steps of a monitored block, ~10x the span's). ``dt`` is
    reordered (its extremes are read before; a gap's row is found from ``t``)."""
    if rounded_uniform(t, dt_min, dt_max):
        return (float(t[-1]) - float(t[0])) / dt.size
    return float(np.median(dt, overwrite_input=True))


def prepare_trace(
    time_s,
    resistance_ohm,
    omega_rad_s: float,
    source: str = "trace",
    min_ball_passes: float = MIN_BALL_PASSES,
    phase=None,
    bearing: Bearing | None = None,
) -> Trace:
    """Check, repair and resample a trace for estimation; TraceError when it cannot be used.

    ``phase``: the simulation phase of each row (:attr:`TraceColumns.phase`); only the
    steady rows are kept. ``bearing``: its geometry (default: the seed's), whose ball pass
    sets the gaps filled in, the rate needed and the length needed."""
    where = source
    if not (isinstance(omega_rad_s, int | float) and math.isfinite(omega_rad_s)):
        raise TraceError(f"--omega {omega_rad_s!r}: must be a finite speed in rad/s")
    if omega_rad_s <= 0.0:
        raise TraceError(
            f"--omega {omega_rad_s:g}: must be > 0 rad/s (the ball-pass ripple needs a turning "
            "shaft)"
        )
    t = np.asarray(time_s, dtype=float).ravel()
    r = np.asarray(resistance_ohm, dtype=float).ravel()
    repairs: list[str] = []
    if phase is not None:
        phase = np.asarray(phase).astype(str).ravel()
        steady = phase == STEADY_PHASE
        if not steady.any():
            raise TraceError(
                f"{where}: no row of the {STEADY_PHASE!r} phase (phases: "
                f"{', '.join(dict.fromkeys(phase)) or 'none'}); the set-up is no bearing trace"
            )
        if not steady.all():
            dropped = list(dict.fromkeys(phase[~steady]))
            repairs.append(
                f"kept the {STEADY_PHASE} phase: dropped {int((~steady).sum())} set-up samples "
                f"({', '.join(dropped)})"
            )
            t, r = t[steady], r[steady]
    n0 = r.size
    if n0 < 4:
        raise TraceError(f"{where}: {n0} samples; a trace needs at least 4")

    if not np.isfinite(t).all():
        bad_t = ~np.isfinite(t)
        if bad_t.mean() > MAX_BAD_FRACTION:
            raise TraceError(
                f"{where}: time missing or not finite in {bad_t.mean():.1%} of the rows "
                f"(at most {MAX_BAD_FRACTION:.0%} can be dropped)"
            )
        t, r = t[~bad_t], r[~bad_t]
        repairs.append(f"dropped {int(bad_t.sum())} rows without a time")
    dt = np.diff(t)
    # the extremes of the steps, read again below: increasing means the smallest is > 0
    dt_min, dt_max = float(dt.min()), float(dt.max())
    if not dt_min > 0.0:
        i = int(np.flatnonzero(dt <= 0.0)[0])
        raise TraceError(
            f"{where}: time does not increase at row {i + 1} (t = {t[i]:.9g} s, then "
            f"{t[i + 1]:.9g} s); sort the trace or remove repeated times"
            f"{daylight_saving(t[i + 1] - t[i])}"
        )
    step = sampling_step(t, dt, dt_min, dt_max)
    fs = 1.0 / step
    f_bp = expected_ball_pass_hz(omega_rad_s, bearing)
    max_gap_s = MAX_GAP_BALL_PASSES / f_bp
    # before the gaps: at a speed too high for the rate every step is a gap of the ripple
    fs_min = minimum_sample_rate_hz(omega_rad_s, bearing=bearing)
    if fs < fs_min:
        hint = unit_hint(
            r,
            fs,
            omega_rad_s,
            bearing,
            lambda om: fs >= minimum_sample_rate_hz(om, bearing=bearing),
        )
        raise TraceError(
            f"{where}: sampled at {fs:.6g} Hz, below the {fs_min:.4g} Hz needed at "
            f"{omega_rad_s:g} rad/s (the ball-pass harmonics the estimate reads would "
            f"alias){hint}"
        )

    # every sample a resistance in range (nearly every block of a record): the extremes say so
    # without the masks below (a NaN makes them NaN and the test fail)
    r_checked = r
    r_lo, r_hi = float(r.min()), float(r.max())
    cut = False
    if not (r_lo > 0.0 and r_hi <= OPEN_CIRCUIT_OHM):
        is_open = np.isinf(r) | (r <= 0.0) | (r > OPEN_CIRCUIT_OHM)
        is_nan = np.isnan(r)
        # shares as counts over the size: np.mean's numbers, without its float sum
        open_share = np.count_nonzero(is_open) / r.size
        if open_share > MAX_OPEN_FRACTION:
            raise TraceError(
                f"{where}: open circuit (resistance infinite, <= 0 or above "
                f"{OPEN_CIRCUIT_OHM:g} ohm) in {open_share:.1%} of the samples (at most "
                f"{MAX_OPEN_FRACTION:.0%} can be filled in); no ball touched both rings, or the "
                "meter lost contact"
            )
        bad = is_open | is_nan
        bad_share = np.count_nonzero(bad) / r.size
        if bad_share > MAX_BAD_FRACTION:
            raise TraceError(
                f"{where}: {bad_share:.1%} of the resistance samples are missing or not finite "
                f"(at most {MAX_BAD_FRACTION:.0%} can be filled in)"
            )
        if bad.all():
            raise TraceError(f"{where}: no finite resistance sample")
        # cut missing ends, then check the inner gaps
        good = ~bad
        lo, hi = int(np.argmax(good)), r.size - int(np.argmax(good[::-1]))
        cut = lo > 0 or hi < r.size
        if cut:
            repairs.append(f"cut {lo + r.size - hi} missing samples at the ends")
            t, r, bad = t[lo:hi], r[lo:hi], bad[lo:hi]
        for a, b in true_runs(bad):
            gap = t[b] - t[a - 1]
            if gap > max_gap_s:
                raise TraceError(
                    f"{where}: {b - a} missing samples from t = {time_text(t[a])} s "
                    f"({gap * 1e3:.3g} ms): longer than {MAX_GAP_BALL_PASSES:g} of a ball pass "
                    f"({max_gap_s * 1e3:.3g} ms at {omega_rad_s:g} rad/s); cut the trace there"
                )
        if bad.any():
            n_open = int((is_open[lo:hi]).sum())
            r = r.copy()
            r[bad] = np.interp(t[bad], t[~bad], r[~bad])
            what = (
                f"{int(bad.sum())} missing samples"
                if not n_open
                else (f"{int(bad.sum()) - n_open} missing and {n_open} open-circuit samples")
            )
            repairs.append(f"interpolated {what}")
    # uniform sampling (the time steps and their step change only if the ends were cut)
    if cut:
        dt = np.diff(t)
        dt_min, dt_max = float(dt.min()), float(dt.max())
        step = sampling_step(t, dt, dt_min, dt_max)
        fs = 1.0 / step
    if dt_max > max_gap_s:
        i = int(np.flatnonzero(np.diff(t) > max_gap_s)[0])
        raise TraceError(
            f"{where}: no sample between t = {time_text(t[i])} s and {time_text(t[i + 1])} s: a "
            f"gap longer than {MAX_GAP_BALL_PASSES:g} of a ball pass ({max_gap_s * 1e3:.3g} ms); "
            "cut the trace there"
        )
    # max |dt - step| from the extremes (a rounded difference is monotonic: the same number)
    jitter = max(dt_max - step, step - dt_min) / step
    if jitter > JITTER_TOLERANCE and not rounded_uniform(t, dt_min, dt_max):
        n = int(math.floor((t[-1] - t[0]) * fs + 1e-9)) + 1
        grid = t[0] + np.arange(n) * step
        r = np.interp(grid, t, r)
        t = grid
        repairs.append(
            f"resampled to a uniform {fs:.6g} Hz (time steps varied by up to {jitter:.1%})"
        )
    duration = r.size / fs
    passes = duration * f_bp
    if passes < min_ball_passes:
        hint = unit_hint(
            r,
            fs,
            omega_rad_s,
            bearing,
            lambda om: (
                duration * expected_ball_pass_hz(om, bearing) >= min_ball_passes
                and fs >= minimum_sample_rate_hz(om, bearing=bearing)
            ),
        )
        have_ms, need_ms = short_of(duration * 1e3, min_ball_passes / f_bp * 1e3)
        have, need = short_of(passes, min_ball_passes)
        raise TraceError(
            f"{where}: too short: {have_ms} ms is {have} ball passes at "
            f"{omega_rad_s:g} rad/s; at least {need} ({need_ms} ms) are needed{hint}"
        )
    # the median is below the floor only if at least half the samples are (a count is cheaper
    # than a median of a long block; the median itself is taken for the message)
    # (none below it when the samples checked above are kept as they were and their least is not)
    below = 0 if r is r_checked and r_lo >= MIN_LEVEL_OHM else np.count_nonzero(r < MIN_LEVEL_OHM)
    if 2 * below >= r.size - 1 and (level := float(np.median(r))) < MIN_LEVEL_OHM:
        raise TraceError(
            f"{where}: median resistance {level:.3g} ohm: below {MIN_LEVEL_OHM:g} ohm, smaller "
            "than any bearing's contact resistance; give the column in ohm"
        )
    return Trace(
        time_s=t - t[0],
        resistance_ohm=r,
        sample_rate_hz=fs,
        source=source,
        repairs=tuple(repairs),
    )
