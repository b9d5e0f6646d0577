"""The trace sanity layer: is this the steady trace of a running bearing at the given speed?

:func:`screen_trace` runs, on a :class:`~signatelec.measurement.traces.Trace` that
:func:`~signatelec.measurement.traces.prepare_trace` made uniform and finite (each step refuses
with one line, :class:`~signatelec.measurement.traces.TraceError`):

1. :func:`~signatelec.measurement.settling.trim_transient`: a set-up transient (a measured
   start-up, a load step) is cut off, said in one line, or the trace is refused; never
   averaged in. The level is read per ball pass (block means over one kinematic period,
   where the ripple averages out); the steady level is the median of the last half's blocks;
   a block departs from it when it is off by more than
   :data:`~signatelec.measurement.settling.STEP_SIGMAS` times the block-to-block noise
   (robust, from the first differences of the last half's blocks: a settling that spans half
   a short trace's blocks had inflated the noise read over all of them, and kept ball passes
   1-2 % off) and more than :data:`~signatelec.measurement.settling.DRIFT_ALLOWANCE` of the
   level (five times the largest drift of the training traces, a random walk of 0.1 % at the
   end of the window). The steady part starts after the last departing block and must span
   :data:`~signatelec.measurement.band.MIN_BALL_PASSES` (a trend moves the early blocks off
   the final level: it is cut off or refused alike). With a condition model
   (``defect_lines``), departures that recur through the trace (in
   :data:`~signatelec.measurement.settling.RECURRENT_GROUPS` or more groups, not from its
   start, into its second half) are a defect's events, a spall on a ball most (once per cage
   revolution), and the trace is kept whole. A simulation's set-up (the ``phase`` column of
   ``signatelec simulate``'s ``signals.parquet``) is dropped earlier, by
   :func:`~signatelec.measurement.traces.prepare_trace`;
2. :func:`check_level`, given the model's trained level range: a mean resistance outside it by
   more than :data:`LEVEL_MARGIN` is refused, naming the unit mix-up when a factor of 1000
   (or 10^6) brings it inside ("level 2.5 Ohm is 1000x the trained range 1.1-9.79 mOhm: is
   the column in mOhm?", the default model's range); within the margin it is a note;
3. :func:`~signatelec.measurement.ripple.find_ripple`: the ball-pass line in the data, with its
   significance, near the frequency the speed predicts. A line elsewhere (a wrong ``--omega``)
   and a constant trace are refused here, but not a line that is no ripple of another speed
   (a harmonic of a stronger line below it: a clearance's ball-set oscillation) beside a
   ripple that stands out where the speed puts it (the ripple module's rule 4); a trace
   without any line is passed on with the finding, for the model's domain to judge
   (:mod:`signatelec.estimation.estimate`): a running bearing whose load zone's edge sits on
   a zero of the ripple's first harmonic shows no line at 0.2 % noise over 50 ms in 17 % of
   held-out windows, so that alone cannot refuse a trace.
   A spall on the inner race or a ball, or an unbalance, puts its own line in the trace
   (BPFI, 2 BSF and their sidebands, the shaft's harmonics), which may outgrow the ripple: when
   the caller has a condition model, a line on one of those is named, not refused, and the
   caller refuses it unless the condition model calls that condition confidently. A spall's
   impacts also put lines at no harmonic of f_bp (a seed-bearing outer-race spall: above the
   ripple at 1.8-4.0 f_bp in 17 of 100 fast-DEM traces over the condition model's training
   design): a line that the ripple still stands beside where the speed puts it (its
   fundamental below a false-alarm probability of 1e-6, nothing stronger below it) is named
   for any fault the condition model calls confidently (:func:`fault_line`). On 100 such
   traces each of outer, inner and ball spalls (0.2 s, 0.2 % noise) this kept 10 more at
   their speed, and 2 of their 1200 reads at 0.5, 0.8, 1.2 and 2 times it (the healthy
   traces' reads unchanged).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from signatelec.config.constraints import HEALTHY
from signatelec.measurement.lines import defect_line_of
from signatelec.measurement.ripple import Ripple, find_ripple
from signatelec.measurement.settling import trim_transient
from signatelec.measurement.traces import Trace, TraceError

#: A level within this factor of the trained range is extrapolated with a note (R ~
#: F_r^(-4/3), seed section 3: 1.25 in R is 1.18 in F_r, along Hertz's law).
LEVEL_MARGIN = 1.25
#: Unit mix-ups recognised in the level: factor -> the unit the column then holds.
UNIT_FACTORS = {1e3: "mOhm", 1e-3: "kOhm", 1e6: "uOhm", 1e-6: "MOhm"}


@dataclass(frozen=True)
class Screening:
    """A trace that passed the sanity layer: the trace to estimate from (maybe trimmed), the
    ripple found in it and the notes to print (one line each). ``defect_line``: when the
    strongest line is not the ball-pass ripple but lies on a defect's line (and the caller
    allowed it), (the condition it would be, the line's name); the caller must confirm that
    condition or refuse with ``ripple.problem()``."""

    trace: Trace
    ripple: Ripple
    notes: tuple[str, ...] = ()
    defect_line: tuple[str, str] | None = None


def _ohm(value: float, unit: str | None = None) -> str:
    """A resistance in a readable unit (or in ``unit``)."""
    scales = {"MOhm": 1e6, "kOhm": 1e3, "Ohm": 1.0, "mOhm": 1e-3, "uOhm": 1e-6}
    if unit is None:
        unit = next((u for u, s in scales.items() if abs(value) >= s), "uOhm")
    return f"{value / scales[unit]:.3g} {unit}"


def _load_beyond(level_ohm: float, range_ohm: tuple[float, float]) -> str:
    """The load a level beyond the training traces' range ``range_ohm`` would take, against
    theirs (R ~ F_r^(-4/3), seed section 3: a level x above the highest is a load x^(3/4)
    lighter than the lightest)."""
    lo, hi = range_ohm
    above = level_ohm > hi
    factor = (level_ohm / hi if above else lo / level_ohm) ** 0.75
    side = "lighter than the lightest" if above else "heavier than the heaviest"
    return f"a load ~{factor:.2g} times {side} the model learnt (R ~ F_r^(-4/3))"


def check_level(level_ohm: float, range_ohm: tuple[float, float], where: str) -> str | None:
    """None when the level is inside the trained range, a note within :data:`LEVEL_MARGIN`
    of it; TraceError beyond, naming the unit mix-up when a factor of :data:`UNIT_FACTORS`
    brings the level into the range."""
    lo, hi = range_ohm
    unit = "mOhm" if 1e-3 <= hi < 1.0 else None
    trained = f"the trained range {_ohm(lo, unit).split()[0]}-{_ohm(hi, unit)}"
    if lo <= level_ohm <= hi:
        return None
    if lo / LEVEL_MARGIN <= level_ohm <= hi * LEVEL_MARGIN:
        return f"level {_ohm(level_ohm)} is just outside {trained}: extrapolating"
    for factor, name in UNIT_FACTORS.items():
        if lo / LEVEL_MARGIN <= level_ohm / factor <= hi * LEVEL_MARGIN:
            times = f"{factor:g}x" if factor > 1 else f"1/{1 / factor:g} of"
            raise TraceError(
                f"{where}: level {_ohm(level_ohm)} is {times} {trained}: is the column in "
                f"{name}? give the resistance in ohm"
            )
    raise TraceError(
        f"{where}: level {_ohm(level_ohm)} is outside {trained} (beyond x{LEVEL_MARGIN:g}): "
        f"{_load_beyond(level_ohm, range_ohm)}, not this bearing, or not a resistance in ohm"
    )


#: The condition of :func:`fault_line`'s line that any fault a condition model calls explains.
ANY_FAULT = "any fault"


def fault_line(
    ripple: Ripple, omega_rad_s: float, duration_s: float, bearing=None
) -> tuple[str, str] | None:
    """What a line away from the ball-pass frequency (``ripple``, ``"elsewhere"``) may be if
    the bearing is faulty, for a condition model to confirm: (:data:`ANY_FAULT`, ...) when the
    ball-pass ripple stands where the speed puts it all the same (``ripple.near``): a spall's
    impacts put lines at no harmonic of it (a seed-bearing outer-race spall, the fast DEM
    over the condition model's training design, 0.2 s at 0.2 % noise: at 1.8-4.0 f_bp, above
    the ripple, in 17 of 100 traces); else (the condition, the line's name) of the defect
    line it lies on (:func:`~signatelec.measurement.lines.defect_line_of`); None otherwise
    (a wrong speed)."""
    line = defect_line_of(ripple.frequency_hz, omega_rad_s, duration_s, bearing)
    if ripple.near is None:
        return line
    what = "none the speed explains" if line is None else f"near the {line[1]} line"
    name = (
        f"{ripple.frequency_hz / ripple.expected_hz:.2f} f_bp, {what}, beside the ball-pass "
        f"ripple found at {ripple.near.frequency_hz:.1f} Hz"
    )
    return ANY_FAULT, name


def explains(kind: str, condition: str | None) -> bool:
    """Whether a condition called (confidently, the caller checks) explains a
    :func:`fault_line` of ``kind``."""
    return condition not in (None, HEALTHY) and kind in (ANY_FAULT, condition)


def screen_trace(
    trace: Trace,
    omega_rad_s: float,
    level_range_ohm: tuple[float, float] | None = None,
    *,
    defect_lines: bool = False,
    bearing=None,
) -> Screening:
    """The sanity layer (module docstring): trimmed trace, ripple and notes, or TraceError.
    ``level_range_ohm``: the model's trained level range, checked after the trimming. With
    ``defect_lines``, a line away from the ball-pass frequency that lies on a defect's line
    (:func:`defect_line_of`) is not refused here: the screening names it for the caller to
    confirm (a condition model) or refuse. ``bearing``: its geometry, which places the
    ball-pass and the defects' lines (default: the seed's)."""
    trace = trim_transient(trace, omega_rad_s, events=defect_lines, bearing=bearing)
    notes = []
    if level_range_ohm is not None:
        level = float(np.mean(trace.resistance_ohm))
        note = check_level(level, level_range_ohm, trace.source)
        if note:
            notes.append(note)
    ripple = find_ripple(trace.resistance_ohm, trace.sample_rate_hz, omega_rad_s, bearing=bearing)
    if ripple.status == "elsewhere" and defect_lines:
        line = fault_line(ripple, omega_rad_s, trace.duration_s, bearing)
        if line is not None:
            return Screening(trace=trace, ripple=ripple, notes=tuple(notes), defect_line=line)
    if ripple.status in ("elsewhere", "constant"):
        raise TraceError(f"{trace.source}: {ripple.problem()}")
    if ripple.beside is not None:
        f_hz = ripple.beside.frequency_hz
        notes.append(
            f"a stronger line at {f_hz:.1f} Hz ({f_hz / ripple.expected_hz:.3f} f_bp), a harmonic "
            "of a stronger one below it (with a clearance, the ball set's oscillation), is not "
            "the ball-pass ripple: read past"
        )
    if ripple.status == "harmonic":
        k = ripple.harmonic
        notes.append(
            f"ball-pass ripple found at its harmonic {k} only ({ripple.frequency_hz:.1f} Hz): "
            "the load zone's edge may sit on a zero of the first harmonic, or --omega is "
            f"1/{k} of the speed (then about {ripple.implied_omega_rad_s:.0f} rad/s)"
        )
    return Screening(trace=trace, ripple=ripple, notes=tuple(notes))
