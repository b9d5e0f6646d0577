"""What :func:`~signatelec.estimation.monitor.monitor_trace` does with a trace: the window, hop,
speed, columns, reading, condition cadence and bearing (:class:`MonitorSettings`), checked
before any trace is read; the speed a block or a window is read at (:func:`omega_of`)."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from signatelec.config.bearing import Bearing, same_bearing
from signatelec.estimation.diagnose import least_cage_revolutions
from signatelec.estimation.health import CONDITION_EVERY_S
from signatelec.measurement.band import MIN_BALL_PASSES
from signatelec.measurement.stream import CHUNK_ROWS, is_standard_input
from signatelec.measurement.traces import TraceError, daylight_saving, time_text
from signatelec.physics.kinematics import characteristic_frequencies_hz, expected_ball_pass_hz

#: Default window and hop, s: 200 ms windows are the longest of the training windows
#: (docs/load_state: 88 % regime accuracy per window there, against 79 % at 50 ms).
WINDOW_S = 0.2

#: Most windows a sample may belong to (--window / --hop): a block's windows are analysed
#: together, so its memory grows with this ratio: peak 0.46, 0.62, 0.91 GB at 1, 20, 50 on a
#: 100 kHz trace (8 s, 0.2 s windows); a hop of one sample at 20 kHz was killed for lack of memory.
MAX_OVERLAP = 50

#: Smallest harmonic SNR (fitted harmonic power over its noise variance) of a window whose
#: ball-pass frequency sets the tracked speed: a 5-sigma ripple.
TRACK_MIN_SNR = 25.0
#: Most windows a gap in the record takes: a longer one (a clock jump) ends the reading there (a
#: day at a hop of 0.2 s is 432000 windows, ~0.5 GB of the run's memory).
MAX_GAP_WINDOWS = 1_000_000
#: Mean cage slip of the training runs (found / kinematic f_bp - 1), for speed tracking.
TYPICAL_SLIP = -0.001
#: Largest move of the ball-pass line from the tracked speed's, at a ripple screen, that the
#: tracked speed follows (a run-up between screens, a step of the drive; further is refused as
#: a wrong speed): the windows' own search spans +-1 %, a screen's finds the line anywhere. A
#: ball spall's line 2 BSF lies 10.6 % below the seed's ball pass: it is not followed.
TRACK_JUMP = 0.05
#: Change of a speed column's speed across the record's first block, between the medians of
#: its two screens' spans, beyond which a failed screen of that block does not refuse the
#: record: the next block is screened first instead (a run-up from rest smears the line: 0 to
#: 25 rad/s in the first half second; 300 to 700 rad/s in a minute is 2.3 % a block).
STEADY_SPEED = 0.1
#: Relative change of a block's sample rate from the first block's that the notes report (a
#: jittered clock's blocks differ by ~0.1-1 %; a logger that changes its rate, by a factor).
RATE_CHANGE = 0.05


@dataclass
class MonitorSettings:
    """What :func:`~signatelec.estimation.monitor.monitor_trace` does with a trace (its
    module docstring)."""

    omega_rad_s: float | None = None
    speed_column: str | None = None
    track_speed: bool = False
    window_s: float = WINDOW_S
    hop_s: float | None = None
    time_column: str = "time_s"
    resistance_column: str = "resistance_ohm"
    follow: bool = False
    follow_idle_s: float | None = None
    chunk_rows: int = CHUNK_ROWS
    condition_every_s: float | None = CONDITION_EVERY_S
    #: The bearing's geometry, which places the ball-pass and the defects' lines (None: the one
    #: the model learnt, :meth:`for_model`). Another bearing than the model's has no load
    #: state here: its windows carry their condition alone (:attr:`load_state`), as
    #: ``estimate --bearing`` answers.
    bearing: Bearing | None = None
    #: The bearing the load-state model learnt, whose ball-pass line the windows' features are
    #: read at (None: the seed's; set by :meth:`for_model`).
    learnt: Bearing | None = None

    @property
    def hop(self) -> float:
        return self.window_s if self.hop_s is None else self.hop_s

    def for_model(self, model) -> MonitorSettings:
        """The settings with the bearing the ``model`` learnt (``model.bearing``): the bearing
        read when none is given."""
        learnt = getattr(model, "bearing", None)
        return replace(
            self, bearing=learnt if self.bearing is None else self.bearing, learnt=learnt
        )

    @property
    def load_state(self) -> bool:
        """Whether the windows' load state is estimated: the model learnt the bearing."""
        return same_bearing(self.bearing, self.learnt)

    @property
    def known(self) -> str:
        """The bearing whose load state the model learnt, as the notes name it."""
        return "the seed's bearing" if self.learnt is None else f"the {self.learnt.name}"

    @property
    def window_status(self) -> str:
        """The status of a window read as asked: ``ok``, or why another bearing's carries no
        load state."""
        if self.load_state:
            return "ok"
        return (
            f"no load state: the load-state model learnt {self.known} only, not the "
            f"{self.bearing.name}"
        )

    def check_speed(self) -> None:
        """TraceError for a speed tracked from a ripple that is not read: that of another
        bearing than the one the model learnt (:attr:`learnt`: the seed's, the default model's,
        before :meth:`for_model`)."""
        if self.track_speed and not self.load_state:
            raise TraceError(
                f"--track-speed: tracks the ball-pass line of {self.known} only, not this "
                f"{self.bearing.name}'s (--bearing); give --omega or --speed-column"
            )

    def check_model(self, model) -> None:
        """TraceError when ``model`` (:meth:`for_model`'s) has nothing to say of the bearing:
        another bearing than the one it learnt with no condition assessed, windows too short
        for the condition, or a speed tracked from a ripple not read."""
        self.check_speed()
        if self.load_state:
            return
        name = self.bearing.name
        if getattr(model, "condition", None) is None:
            raise TraceError(
                f"--bearing: the model knows the load state of {self.known} only, and no "
                f"condition model is there to assess this {name}"
            )
        if self.condition_every_s is None:
            raise TraceError(
                f"--condition-every 0: no condition assessed, and the load state is known for "
                f"{self.known} only, not this {name} (--bearing); give a cadence in s"
            )
        least, _ = least_cage_revolutions(model.condition)
        if self.omega_rad_s is not None:  # (a speed column's windows are told one by one)
            f_cage = characteristic_frequencies_hz(self.omega_rad_s, self.bearing)["ftf"]
            if self.window_s * f_cage < least:
                raise TraceError(
                    f"--window {self.window_s:g}: {self.window_s * f_cage:.3g} cage revolutions "
                    f"of this {name} at {self.omega_rad_s:g} rad/s; its condition needs "
                    f"{least:.2g} (>= {least / f_cage:.3g} s)"
                )

    def for_trace(self, path) -> MonitorSettings:
        """The settings a trace at ``path`` is read with: standard input (``-``) is followed
        to its end (TraceError for ``follow_idle_s``, which ends a file that stopped
        growing)."""
        if not is_standard_input(path):
            return self
        if self.follow_idle_s is not None:
            raise TraceError(
                f"--idle {self.follow_idle_s!r}: ends a file that stopped growing; standard "
                "input is read to its end (or Ctrl-C)"
            )
        return replace(self, follow=True)

    def check(self) -> None:
        """TraceError (a ValueError: one line naming the option, its value and what is
        allowed) for settings no trace can be monitored with."""
        s = self
        if s.track_speed and s.speed_column is not None:
            raise TraceError(
                f"--track-speed with --speed-column {s.speed_column!r}: the speed comes from the "
                "column, or is tracked from --omega RAD_S; give one of them"
            )
        if (s.omega_rad_s is None) == (s.speed_column is None):
            raise TraceError("give the speed one way: --omega RAD_S or --speed-column NAME")
        if s.track_speed and s.omega_rad_s is None:
            raise TraceError("--track-speed starts from --omega RAD_S; give it")
        if s.follow_idle_s is not None and not 0 < s.follow_idle_s < math.inf:
            # an infinite idle time would follow for ever: that is --follow without --idle
            raise TraceError(
                f"--idle {s.follow_idle_s!r}: must be a finite duration > 0 s (without --idle, "
                "--follow reads until Ctrl-C)"
            )
        if s.follow_idle_s is not None and not s.follow:
            raise TraceError(f"--idle {s.follow_idle_s!r}: ends --follow; give --follow too")
        for name, value in (("--window", s.window_s), ("--hop", s.hop)):
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise TraceError(f"{name} {value!r}: must be a duration > 0 s")
        every = s.condition_every_s
        if every is not None and not (
            isinstance(every, int | float)
            and not isinstance(every, bool)
            and math.isfinite(every)
            and every >= s.hop
        ):
            raise TraceError(
                f"--condition-every {every!r}: must be a duration >= --hop ({s.hop:g} s), or 0 "
                "for no condition (None in Python)"
            )
        if s.hop > s.window_s:
            raise TraceError(
                f"--hop {s.hop:g}: longer than --window {s.window_s:g}; samples would be skipped"
            )
        if s.window_s > MAX_OVERLAP * s.hop:
            raise TraceError(
                f"--hop {s.hop:g}: shorter than --window {s.window_s:g} / {MAX_OVERLAP}; each "
                f"sample would be analysed more than {MAX_OVERLAP} times"
            )
        if s.omega_rad_s is not None and not (
            isinstance(s.omega_rad_s, int | float)
            and math.isfinite(s.omega_rad_s)
            and s.omega_rad_s > 0
        ):
            raise TraceError(f"--omega {s.omega_rad_s!r}: must be a finite speed > 0 rad/s")
        if s.omega_rad_s is not None and (
            short := window_too_short(s.window_s, s.omega_rad_s, s.bearing)
        ):
            raise TraceError(short)


def window_too_short(window_s: float, omega: float, bearing: Bearing | None = None) -> str | None:
    """Why a window of ``window_s`` at ``omega`` is too short for an estimate (fewer ball
    passes of ``bearing``, default the seed's, than ``estimate`` needs), or None."""
    passes = window_s * expected_ball_pass_hz(omega, bearing)
    if passes >= MIN_BALL_PASSES:
        return None
    return (
        f"--window {window_s:g}: {passes:.3g} ball passes at {omega:g} rad/s; a window needs at "
        f"least {MIN_BALL_PASSES:g} (>= {window_s * MIN_BALL_PASSES / passes:.3g} s)"
    )


def turning(omega: float) -> bool:
    """Whether ``omega`` is a speed the bearing turns at: finite and > 0 (a speed column's
    NaN, where it has no sample, and 0 at rest are not)."""
    return math.isfinite(omega) and omega > 0


def speed_refusal(omega: float, settings: MonitorSettings) -> str | None:
    """Why a window at the speed ``omega`` (a speed column's, :func:`speed_of`) carries no
    estimate, or None: a speed that is not finite and > 0, or too slow for the window
    (:func:`window_too_short`)."""
    if not turning(omega):
        return f"speed {omega:g} rad/s; must be finite and > 0"
    return window_too_short(settings.window_s, omega, settings.bearing)


def speed_of(speed: np.ndarray) -> float:
    """The median of the speed samples that are not missing (a glitch of a few samples does
    not move it, where it moved the mean: 5 samples at 1e6 rad/s in a window of 10000 read
    1000 rad/s); NaN (without numpy's warning on stderr) when all are missing."""
    given = speed[~np.isnan(speed)]
    return float(np.median(given)) if given.size else math.nan


def omega_of(settings: MonitorSettings, speed: np.ndarray | None, tracked: float | None):
    """A block's speed: the speed column's (:func:`speed_of`), the speed tracked from the
    ball-pass line, or --omega."""
    if speed is not None:
        return speed_of(speed)
    if settings.track_speed and tracked is not None:
        return tracked
    return float(settings.omega_rad_s)


def screen_speeds(speed: np.ndarray | None, n: int, omega: float) -> tuple[float, float]:
    """The speeds a block's screens read its first and last ``n`` samples at: a speed column's
    median over each (a run-up's speed differs between a block's ends by more than a screen's
    tolerance: 300 to 700 rad/s in a minute is 2.3 % a block), else the block's ``omega``. A
    first span at rest (no speed finite and > 0) is NaN when the last is not: the block starts
    at rest, and its end is screened (:func:`~signatelec.estimation.monitor_answers.
    screen_block`); a last span at rest takes ``omega``."""
    if speed is None:
        return omega, omega
    first, last = speed_of(speed[:n]), speed_of(speed[-n:])
    if not turning(last):
        return (first if turning(first) else omega), omega
    return (first if turning(first) else math.nan), last


def followed(at: float, omega: float, found: float) -> str:
    """The note of the first move of the tracked speed, from ``omega`` to the speed ``found`` by
    the screen at ``at`` (rad/s)."""
    return (
        f"at t = {time_text(at)} s the ball-pass line lies {found / omega - 1.0:+.1%} from the "
        f"tracked speed's: the speed tracked follows it ({found:.6g} rad/s at the line's "
        "kinematics; later such moves are not noted)"
    )


def speed_given(settings: MonitorSettings, omega: float, start_s: float, end_s: float, first):
    """How a refusal names the speed ``omega`` of the trace ``start_s``-``end_s``: what the user
    gave (the speed column's median there, the speed tracked from the ball-pass line), or None
    for --omega (:meth:`~signatelec.measurement.ripple.Ripple.problem`'s own words)."""
    if settings.speed_column is not None:
        return (
            f"--speed-column {settings.speed_column!r} (its median {omega:g} rad/s over "
            f"{time_text(start_s)}-{time_text(end_s)} s)"
        )
    if settings.track_speed and not first:
        return f"the speed tracked from the ball-pass line, {omega:g} rad/s (--track-speed)"
    return None


def windows_in_gaps(times, limit_s: float, start_s: float, settings, fs: float, n_per: int):
    """(first, end, (last time before, first time after)) of the windows (counted from the one
    starting at ``start_s``; ``settings``' length and hop) that each gap in ``times`` takes, a
    gap being no sample for longer than ``limit_s`` (what ``prepare_trace`` fills in: a
    quarter of a ball pass): from the first window whose last sample is due after the gap's
    start to the last starting before its end; none when the gaps outnumber the ``n_per``
    windows (a rate too low for the speed, which ``prepare_trace`` refuses)."""
    big = np.flatnonzero(np.diff(times) > limit_s)
    if big.size > n_per:
        return []
    taken, half, hop = [], 0.5 / fs, settings.hop
    for a, b in zip(times[big].tolist(), times[big + 1].tolist(), strict=True):
        first = max(0, math.floor((a + 3 * half - start_s - settings.window_s) / hop) + 1)
        end = math.ceil((b - half - start_s) / hop - 1e-9)
        if end > first:
            taken.append((first, end, (a, b)))
    return taken


def first_gaps(taken: list[tuple]) -> list[tuple]:
    """The first gaps of ``taken`` (:func:`windows_in_gaps`) whose windows run on without a
    window between them, each from where the one before ends: (first, end, gap)."""
    run = []
    for first, end, gap in taken:
        if run and first > run[-1][1]:
            break
        run.append((max(first, run[-1][1] if run else 0), end, gap))
    return run


def in_time_order(chunk, last_time: float, first_time: float | None, block_span: float, source):
    """(times, times to cut blocks at, resistances, speeds, first time, note) of the chunk's rows
    up to the first whose time does not increase on the times before it (``last_time``: the
    last time read; ``first_time``: the record's first, None before it is read): the reading
    ends there, with the ``note`` (None: it goes on; TraceError within the record's first
    block, ``block_span`` long, which is refused as ``prepare_trace`` refuses it). A missing
    time is cut at the time before it (the block holding it repairs it, or refuses it, as
    ``estimate`` does): a NaN among the times would make the blocks' bisections meaningless."""
    t, r, v = chunk.time_s, chunk.resistance_ohm, chunk.speed_rad_s
    finite = np.isfinite(t)
    at, rows = t, None  # (rows: those with a time, None when all have)
    if not finite.all():
        last = np.maximum.accumulate(np.where(finite, np.arange(t.size), -1))
        at = np.where(last >= 0, t[np.maximum(last, 0)], last_time)
        rows = np.flatnonzero(finite)
    timed = t if rows is None else t[rows]
    if timed.size and first_time is None:
        first_time = float(timed[0])
    back = np.flatnonzero(~(np.diff(timed, prepend=last_time) > 0.0))
    note = None
    if back.size:
        i = int(back[0] if rows is None else rows[back[0]])
        before = last_time if back[0] == 0 else float(timed[back[0] - 1])
        what = (
            f"time does not increase at row {chunk.first_row + i} (t = {before:.9g} s, "
            f"then {t[i]:.9g} s){daylight_saving(t[i] - before)}"
        )
        if before < first_time + block_span:  # the first block is refused
            raise TraceError(f"{source}: {what}; sort the trace or remove repeated times")
        note = f"{what}: the record is read up to there"
        t, at, r = t[:i], at[:i], r[:i]
        v = None if v is None else v[:i]
    return t, at, r, v, first_time, note


def set_filed(parts: list[pd.DataFrame], start_s: float, values: dict) -> None:
    """Set ``values`` in the row of the window from ``start_s`` among the frames of windows
    filed (``parts``, in time order: searched from the last)."""
    for part in reversed(parts):
        at = part["start_s"] == start_s
        if at.any():
            for key, value in values.items():
                number = isinstance(value, numbers.Real) and not isinstance(value, bool)
                if key in part and not number and value is not None and part[key].dtype != object:
                    # a column no filed window had a text for (all None: read as float) takes
                    # one: pandas refuses a string or a bool into a float column
                    part[key] = part[key].astype(object)
                part.loc[at, key] = value
            return


def unconfirmed(pending: list[dict], parts: list[pd.DataFrame], since: float, at: float) -> str:
    """The windows from ``since``, pending (rows) or filed (frames), take the ripple status
    "unconfirmed", their regime not confident, when the screen at ``at`` finds the line away
    from the speed's, or none; the note that says so."""
    for row in pending:
        if row["start_s"] >= since:
            row["ripple"] = "unconfirmed"
            row["regime_confident"] = False
    for part in reversed(parts):  # batches filed since
        if not len(part) or part["start_s"].max() < since:
            break
        rows = part["start_s"] >= since
        part.loc[rows, "ripple"] = "unconfirmed"
        if "regime_confident" in part:
            part.loc[rows, "regime_confident"] = False
    return (
        f"at t = {time_text(at)} s the ball-pass line is not where the speed puts it, or is "
        "gone: the windows since the last screen that found it, at t = "
        f"{time_text(since)} s, may have been read at a wrong speed (ripple 'unconfirmed')"
    )


def gap_rows(starts: np.ndarray, window_s: float, gap: tuple, ripple: str) -> pd.DataFrame:
    """The rows of the windows from ``starts`` that a gap (last time before, first time after)
    takes: status "no data", naming the gap."""
    a, b = gap
    return pd.DataFrame(
        {
            "start_s": starts,
            "end_s": starts + window_s,
            "time_s": starts + 0.5 * window_s,
            "status": f"no data: no sample from t = {time_text(a)} to {time_text(b)} s",
            "ripple": ripple,
        }
    )


def check_rate(settings: MonitorSettings, fs: float) -> None:
    """TraceError when the window or the hop spans too few samples at the rate ``fs``."""
    if settings.window_s * fs < 16:
        raise TraceError(
            f"--window {settings.window_s:g}: {settings.window_s * fs:.1f} samples at "
            f"{fs:.6g} Hz; a window needs at least 16 (is --time-column "
            f"{settings.time_column!r} in seconds?)"
        )
    if settings.hop * fs < 1.0:
        raise TraceError(
            f"--hop {settings.hop:g}: {settings.hop * fs:.2g} samples at {fs:.6g} "
            "Hz; a hop needs at least one sample"
        )
