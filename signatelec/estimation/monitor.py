"""Monitoring a long trace: the load state window by window, then stretches, changes and alarms.

:func:`monitor_trace` reads a trace file in chunks
(:func:`signatelec.measurement.stream.read_chunks`: memory bounded whatever the file's length, a
CSV file followed as it grows, or CSV piped to standard input, followed to its end), cuts it
into windows of ``window_s`` every ``hop_s`` and estimates each as ``signatelec estimate`` does
(:mod:`signatelec.estimation.estimate`: the same features, in-domain score and model): the
windows of a block analysed together (:func:`~signatelec.estimation.analysis.analyse_windows`,
equal to the one-window analysis, of what the features read); the model asked once per batch.
The trace's reading and sanity checks are those of ``estimate``, applied per block of
:data:`BLOCK_S`: each block is repaired or refused by
:func:`~signatelec.measurement.traces.prepare_trace`; the first block's first :data:`SCREEN_S`,
then one block's every :data:`SCREEN_EVERY_S`, is screened for the level and the ball-pass line
(:func:`~signatelec.measurement.sanity.check_level`, :func:`~signatelec.measurement.ripple.
find_ripple`). A first block that is refused refuses the trace (one line: wrong column, unit,
speed, ...); a later one is kept as windows with a ``status`` saying why they carry no
estimate; ``estimate``'s set-up trim is not applied (a level step is what a monitor seeks).

The speed of each window: ``omega_rad_s`` (constant), the median of a speed column over the
window, or, with ``track_speed``, the ball-pass frequency found in the previous window (the
estimate searches +-1 % around the expected one: the speed may drift by ~1 % per window).

With a condition model, one window every ``condition_every_s`` is assessed for the bearing's
condition as well (:mod:`signatelec.estimation.health`: the window nearest each due time, and
the record's last usable one if more than a hop after the last assessed; the others' condition
columns stay empty). Another bearing than the model learnt (``settings.bearing``) has no load
state: only those windows are analysed.

The per-window table then goes to :mod:`signatelec.estimation.evidence` (change points,
stretches, alarms); :mod:`signatelec.estimation.monitor_report` writes the output directory.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from signatelec.estimation.analysis import analyse_windows
from signatelec.estimation.features import trace_feature_names, window_features
from signatelec.estimation.health import assess_window, confident_faults
from signatelec.estimation.models import LoadStateModel
from signatelec.estimation.monitor_answers import (
    SCREEN_S,
    analysed,
    estimate_batch,
    feature_columns,
    kept_features,
    screen_block,
)
from signatelec.estimation.monitor_settings import (
    MAX_GAP_WINDOWS,
    RATE_CHANGE,
    STEADY_SPEED,
    TRACK_MIN_SNR,
    TYPICAL_SLIP,
    MonitorSettings,
    check_rate,
    first_gaps,
    followed,
    gap_rows,
    in_time_order,
    omega_of,
    screen_speeds,
    set_filed,
    speed_given,
    speed_of,
    speed_refusal,
    turning,
    unconfirmed,
    windows_in_gaps,
)
from signatelec.interrupts import interruption
from signatelec.measurement.band import SEARCH_REL
from signatelec.measurement.stream import read_chunks, trace_label
from signatelec.measurement.traces import (
    MAX_GAP_BALL_PASSES,
    TraceError,
    prepare_trace,
    sampling_step,
    time_text,
)
from signatelec.physics.kinematics import expected_ball_pass_hz

#: Trace per block of windows: repaired and screened together.
BLOCK_S = 2.0
#: Windows whose features the model is asked about in one batch (its compiled walk of the
#: trees: ~0.02 ms a window in batches of 1000); a followed file is answered every 100 windows.
BATCH_WINDOWS = 1000
FOLLOW_BATCH_WINDOWS = 100
#: Analysed windows whose features are measured together (~7 us a window against ~20 us in
#: blocks of 10; their analyses, ~0.16 MB a window at 50 kHz, wait meanwhile).
MEASURE_WINDOWS = 100
#: Trace between two screenings of the ripple (the first block is always screened): a speed
#: gone wrong is refused within this; screening every block cost ~1.4 ms per 0.2 s window at
#: 50 kHz, more than the window's features.
SCREEN_EVERY_S = 10.0


@dataclass
class WindowTable:
    """The windows analysed so far and what the trace looked like."""

    parts: list[pd.DataFrame] = field(default_factory=list)
    sample_rate_hz: float | None = None
    n_samples: int = 0
    duration_s: float = 0.0  # from the first time to one step after the last
    notes: list[str] = field(default_factory=list)
    cpu_s: float = 0.0
    interrupted: bool = False
    gaps: list[tuple[float, float]] = field(default_factory=list)  # (last time, next) around
    time_origin_utc: str | None = None  # a time column of timestamps: its first (Chunk)

    @property
    def n_windows(self) -> int:
        return sum(len(p) for p in self.parts)

    def frame(self) -> pd.DataFrame:
        if not self.parts:
            return pd.DataFrame()
        return pd.concat(self.parts, ignore_index=True)


class _Windows:
    """Cuts the stream of samples into blocks of whole windows and estimates them."""

    def __init__(self, settings, model, table, source):
        self.s, self.model, self.table, self.source = settings, model, table, source
        self.t = np.empty(0)
        self.at = np.empty(0)  # the times the blocks are cut at (:meth:`_in_order`)
        self.first_time, self.last_time = None, -math.inf  # the first and last times read
        self.before = math.nan  # the last time before the next block's samples
        self.ended = False  # a time that did not increase ended the reading
        self.rate_noted = False
        self.blocks, self.repaired, self.first_repair = 0, 0, None  # blocks read, repaired
        self.r = np.empty(0)
        self.v = None if settings.speed_column is None else np.empty(0)
        self.next_window = 0  # index of the next window
        self.t0 = None
        self.fs = None
        self.tracked = settings.omega_rad_s
        self.first = True
        self.ripple = "unchecked"  # the last screening's ripple status
        self.next_screen_s = -math.inf
        self.last_screen_s = None  # when the last screen found the line (None: it did not)
        self.next_condition_s = -math.inf  # when the next window's condition is due
        self.condition_noted = False
        self.pending: list[dict] = []  # windows waiting for the model
        self.unmeasured: list[tuple] = []  # (row, analysis) of windows waiting for features
        self.last_usable = None  # (row, segment, rate, speed) of the last window assessable
        self.followed = False  # whether a screen moved the tracked speed

    def add(self, chunk) -> None:
        if self.ended:
            return
        t, at, r, v = self._in_order(chunk)
        self.t = np.concatenate([self.t, t])
        self.at = np.concatenate([self.at, at])
        self.r = np.concatenate([self.r, r])
        if self.v is not None:
            self.v = np.concatenate([self.v, v])
        self.table.n_samples += t.size
        steps = np.diff(self.t[:4096]) if self.fs is None else np.empty(0)
        steps = steps[np.isfinite(steps)]  # (pairs of times read)
        if steps.size >= 63 or (self.fs is None and self.t.size >= 4096):
            if not steps.size:
                raise TraceError(f"{self.source}: no time in its first {self.t.size} rows")
            head, lo, hi = self.t[: steps.size + 1], steps.min(), steps.max()
            whole = np.isfinite(head).all()  # (the steps consecutive: no time missing)
            step = sampling_step(head, steps, lo, hi) if whole else float(np.median(steps))
            if not step > 0.0:
                raise TraceError(f"{self.source}: time does not increase at the start")
            self.fs = self.block_fs = 1.0 / step
            self.table.sample_rate_hz = self.fs
            self.t0 = self.first_time  # (the first time read: _in_order)
            check_rate(self.s, self.fs)
        if self.fs is not None and math.isfinite(self.last_time):
            self.table.duration_s = self.last_time - self.t0 + 1.0 / self.fs
        while self.fs is not None and self._block(final=False):
            pass

    def _in_order(self, chunk) -> tuple:
        """(times, times to cut blocks at, resistances, speeds) of the chunk's rows in time
        order (:func:`~signatelec.estimation.monitor_settings.in_time_order`): a time that
        does not increase ends the reading there, with a note."""
        t, at, r, v, self.first_time, note = in_time_order(
            chunk, self.last_time, self.first_time, self._block_span(), self.source
        )
        if note is not None:
            self.table.notes.append(note)
            self.ended = True
        if at.size:
            self.last_time = float(at[-1])
        return t, at, r, v

    def finish(self) -> None:
        if self.fs is None and self.t.size and not np.isfinite(self.t).any():
            raise TraceError(f"{self.source}: no time in its {self.t.size} rows")
        while self.fs is not None and self._block(final=True):
            pass
        self._assess_last_usable()
        self.flush()
        if self.repaired:
            self.table.notes.append(
                f"{self.repaired} of {self.blocks} blocks of {BLOCK_S:g} s repaired as estimate "
                f"repairs a trace, the first {self.first_repair}"
            )

    def flush(self) -> None:
        """Ask the model about the pending windows and file them in the table."""
        clock = time.process_time()
        self._features()
        ok = [row for row in self.pending if "_features" in row]
        feats = [row.pop("_features") for row in ok]
        if self.s.load_state:
            estimate_batch(ok, feats, self.model)
        for row in self.pending:  # a window interrupted before its assessment has none
            row.pop("_condition", None)
        if self.pending:
            self.table.parts.append(pd.DataFrame(self.pending))
        self.pending = []
        self.table.cpu_s += time.process_time() - clock

    def _block_span(self) -> float:
        """The trace a block of windows spans, s."""
        return (max(1, int(round(BLOCK_S / self.s.hop))) - 1) * self.s.hop + self.s.window_s

    def _block(self, final: bool) -> bool:
        """Estimate the next block of windows if the samples are there; False if not."""
        hop, win = self.s.hop, self.s.window_s
        n_per = max(1, int(round(BLOCK_S / hop)))
        start = self.t0 + self.next_window * hop
        end_needed = start + self._block_span()
        if not self.at.size:
            return False
        last = self.at[-1]
        if last < end_needed:
            if not final:
                return False
            n_per = int(math.floor((last + 1.0 / self.block_fs - start - win) / hop + 1e-9)) + 1
            if n_per < 1:
                return False
            end_needed = start + (n_per - 1) * hop + win
        # the record's last block (no further window fits yet) waits for the end, its screen's
        if not final and (last + 1.0 / self.block_fs - end_needed) / hop < 1.0 - 1e-9:
            return False
        lo = int(np.searchsorted(self.at, start - 0.5 / self.fs))
        hi = int(np.searchsorted(self.at, end_needed - 0.5 / self.fs))
        omega = omega_of(self.s, None if self.v is None else self.v[lo:hi], self.tracked)
        taken = self._in_gaps(lo, hi, start, n_per, omega)
        if not taken:
            self._estimate(lo, hi, start, n_per, final, omega)
        elif taken[0][0] > 0:  # the windows before the gap, as a block of their own
            n_per = taken[0][0]
            end = start + (n_per - 1) * hop + win
            hi = int(np.searchsorted(self.at, end - 0.5 / self.fs))
            self._estimate(lo, hi, start, n_per)
        else:  # the windows the gaps take (none beyond the record's last sample)
            n_per = self._no_data(start, taken, n_per if final else None)
            if not n_per:
                return True  # the reading ended at the gap
        self.next_window += n_per
        keep = int(np.searchsorted(self.at, self.t0 + self.next_window * hop - 0.5 / self.fs))
        if keep:
            self.before = float(self.at[keep - 1])
        self.t, self.at, self.r = self.t[keep:], self.at[keep:], self.r[keep:]
        if self.v is not None:
            self.v = self.v[keep:]
        if len(self.pending) >= (FOLLOW_BATCH_WINDOWS if self.s.follow else BATCH_WINDOWS):
            self.flush()  # (the block counted: a Ctrl-C in the flush leaves its windows pending)
        return True

    def _in_gaps(self, lo: int, hi: int, start: float, n_per: int, omega: float) -> list[tuple]:
        """:func:`~signatelec.estimation.monitor_settings.windows_in_gaps` of the block's
        samples and the one before them (``omega``: the block's speed)."""
        times = np.concatenate([[self.before], self.at[lo : hi + 1]])
        if times.size < 2 or not turning(omega):
            return []
        limit = MAX_GAP_BALL_PASSES / expected_ball_pass_hz(omega, self.s.bearing)
        return windows_in_gaps(times, limit, start, self.s, self.fs, n_per)

    def _assess_last_usable(self) -> None:
        """The record's last usable window (full, not refused), if more than a hop after the last
        assessed, is assessed in its row, pending or filed, however the record ends."""
        if self.last_usable is None:
            return
        row, seg, fs, omega = self.last_usable
        last_assessed = self.next_condition_s - self.s.condition_every_s
        if row["start_s"] - last_assessed <= 1.000001 * self.s.hop:
            return
        clock = time.process_time()
        late = {"start_s": row["start_s"], "_condition": (seg, fs, omega)}
        self._measure([(late, seg, omega)], fs)  # (as any window due: features, condition)
        self._features()
        if late.pop("status", None) is not None:  # refused (measured once already: unexpected)
            return
        late = {k: v for k, v in late.items() if k not in ("_features", "start_s")}
        row.update(late)
        if not any(pending is row for pending in self.pending):  # filed: its frame's row
            set_filed(self.table.parts, row["start_s"], late)
        self.table.cpu_s += time.process_time() - clock

    def _no_data(self, start: float, taken: list[tuple], most: int | None) -> int:
        """File the windows from ``start`` that the first gaps of ``taken`` (:meth:`_in_gaps`)
        take, each with its gap (at most ``most``), as status "no data"; how many. A gap of more
        than :data:`MAX_GAP_WINDOWS` ends the reading there, with a note, and files none."""
        run = first_gaps(taken)
        n = run[-1][1] if most is None else min(run[-1][1], most)
        if n > MAX_GAP_WINDOWS:
            a, b = run[-1][2]
            self.table.notes.append(
                f"no sample from t = {time_text(a)} to {time_text(b)} s, more than "
                f"{MAX_GAP_WINDOWS} windows: the record is read up to there (a clock jump?)"
            )
            keep = int(np.searchsorted(self.at, a, side="right"))
            self.table.n_samples -= self.at.size - keep  # (read, not kept)
            self.t, self.at, self.r = self.t[:keep], self.at[:keep], self.r[:keep]
            self.v = None if self.v is None else self.v[:keep]
            self.ended, self.last_time = True, a
            self.table.duration_s = a - self.t0 + 1.0 / self.fs
            return 0
        self.flush()  # the rows in time order, the gap's as one frame (a day: 432000 rows)
        for first, end, (a, b) in [(f, min(e, n), g) for f, e, g in run if min(e, n) > f]:
            if not self.table.gaps or self.table.gaps[-1][1] < b:
                self.table.gaps.append((a, b))
            starts = start + np.arange(first, end) * self.s.hop
            self.table.parts.append(gap_rows(starts, self.s.window_s, (a, b), self.ripple))
        return n

    def _unconfirmed(self, start: float) -> None:
        """The windows since the last screen that found the line are "unconfirmed" (their
        stretches warned, :func:`~signatelec.estimation.monitor_report.qualify`), with a note."""
        since, self.last_screen_s = self.last_screen_s, None
        self.table.notes.append(unconfirmed(self.pending, self.table.parts, since, start))

    def _measure(self, windows, fs: float) -> None:
        """Analyses of windows [(row, segment, omega)] of one length, computed together
        (:func:`~signatelec.estimation.analysis.analyse_windows`); their features follow
        (:meth:`_features`) once :data:`MEASURE_WINDOWS` wait, or at once when the speed is
        tracked (the next window's speed is read from this one's)."""
        if not windows:
            return
        x = np.stack([seg for _, seg, _ in windows])
        try:
            omegas = [om for _, _, om in windows]
            analyses = analyse_windows(x, fs, omegas, bearing=self.s.learnt, **analysed(self.model))
        except ValueError as exc:
            for row, _, _ in windows:
                row["status"] = f"refused: {exc}"
                row.pop("_condition", None)
            return
        lows, highs = x.min(axis=1).tolist(), x.max(axis=1).tolist()
        for (row, _, omega), a, low, high in zip(windows, analyses, lows, highs, strict=True):
            row.update(omega_rad_s=omega, resistance_min_ohm=low, resistance_max_ohm=high)
            self.unmeasured.append((row, a))
        if self.s.track_speed or len(self.unmeasured) >= MEASURE_WINDOWS:
            self._features()

    def _features(self) -> None:
        """Features of the analysed windows waiting for them, measured together
        (:func:`~signatelec.estimation.features.window_features`), written into their rows
        (all of them under ``_features``, a row of the table, for the model)."""
        if not self.unmeasured:
            return
        rows, analyses = zip(*self.unmeasured, strict=True)
        table = window_features(analyses)
        self.unmeasured = []  # (after: a Ctrl-C while measuring leaves them to be measured)
        column = feature_columns(analyses[0].n_harmonics)
        names = kept_features(self.model) if self.s.load_state else ("level_mean_ohm",)
        kept = table[:, [column[name] for name in names]].tolist()
        snr = table[:, column["harmonic_snr"]].tolist()
        found = table[:, column["ball_pass_found_hz"]].tolist()
        for i, row in enumerate(rows):
            row.update(zip(names, kept[i], strict=True))
            if self.s.track_speed and snr[i] >= TRACK_MIN_SNR:
                # the found line predicts the next window's speed (kinematics are linear in it)
                f_per = expected_ball_pass_hz(1.0, self.s.learnt)
                self.tracked = found[i] / (f_per * (1.0 + TYPICAL_SLIP))
            row["_features"] = table[i]
            if "_condition" in row:
                self._assess(row, table[i], analyses[i])

    def _assess(self, row: dict, features: np.ndarray, analysis) -> None:
        """The bearing's condition of a window due for one (:mod:`~signatelec.estimation.
        health`), into its row; why a window was not assessed goes to the notes once."""
        segment, fs, omega = row.pop("_condition")
        named = dict(zip(trace_feature_names(analysis.n_harmonics), features.tolist(), strict=True))
        # the analysis found the model's bearing's ball-pass line: another's is found again
        mine = analysis if self.s.load_state else None
        keys, note = assess_window(
            segment, fs, omega, named, self.model.condition, mine, self.s.bearing
        )
        row.update(keys)
        if note and not self.condition_noted:
            self.table.notes.append(f"at t = {time_text(row['start_s'])} s: {note}")
            self.condition_noted = True

    def _estimate(self, lo, hi, start, n_per, final=False, omega=None) -> None:
        """Estimate ``n_per`` windows from ``start`` (samples lo:hi; ``omega``: their speed)."""
        clock = time.process_time()
        self.blocks += 1
        speed = None if self.v is None else self.v[lo:hi]
        omega_block = omega_of(self.s, speed, self.tracked) if omega is None else omega
        where = f"{self.source} at t = {time_text(start)} s"
        rows, status, ripple = [], self.s.window_status, "unchecked"
        # a speed column at rest, or changing across the block by more than STEADY_SPEED: a
        # refusal of the record's first block does not refuse the record, the next is first
        ends = screen_speeds(speed, int(SCREEN_S * self.fs), omega_block) if self.first else None
        turns = turning(omega_block)
        at_rest = speed is not None and not turns
        ramp = self.first and speed is not None and ends[0] > 0
        ramp = ramp and abs(ends[1] / ends[0] - 1.0) > STEADY_SPEED
        try:
            if not turns:
                raise TraceError(f"{where}: speed {omega_block!r} rad/s; must be finite and > 0")
            trace = prepare_trace(
                self.t[lo:hi],
                self.r[lo:hi],
                omega_block,
                source=where if not self.first else self.source,
                bearing=self.s.bearing,
            )
            if trace.repairs:
                self.repaired += 1
                self.first_repair = (
                    self.first_repair or f"at t = {time_text(start)} s: " + "; ".join(trace.repairs)
                )
            # and the record's last blocks: a speed gone wrong since the last screen is named
            long = trace.duration_s >= SCREEN_S  # (a shorter screen misses lines)
            if self.first or long and (final or start >= self.next_screen_s):
                ends = ends or screen_speeds(speed, int(SCREEN_S * self.fs), omega_block)
                end = self.at[hi - 1]  # (the screen's span, and the speed there, are named)
                named, span = ends[0], (start, min(start + SCREEN_S, end))
                if math.isnan(ends[0]):  # the block starts at rest: its end is screened
                    named, span = ends[1], (max(start, end - SCREEN_S), end)
                given = speed_given(self.s, named, *span, self.first)
                window = self.s.window_s if self.s.condition_every_s is not None else None
                track = self.s.track_speed and speed is None  # (window: a defect's to confirm)
                try:
                    ripple, note, moved = screen_block(
                        trace, ends, self.model, self.first, given, window, self.s.bearing, track
                    )
                except TraceError:
                    if self.last_screen_s is not None:
                        self._unconfirmed(start)
                    raise
                if moved is not None:  # the windows from here at the line's speed, the first noted
                    lost = abs(moved / omega_block - 1.0) > SEARCH_REL  # beyond the windows' search
                    if lost and self.last_screen_s is not None:  # (they may have read a wrong one)
                        self._unconfirmed(start)
                    self.table.notes += [followed(start, omega_block, moved)] * (not self.followed)
                    self.tracked, self.followed = moved / (1.0 + TYPICAL_SLIP), True
                if ripple in ("found", "harmonic", "defect"):
                    self.last_screen_s = start
                elif self.last_screen_s is not None:  # the line lost since the last screen
                    self._unconfirmed(start)
                self.ripple, self.next_screen_s = ripple, start + SCREEN_EVERY_S
                if note:
                    self.table.notes.append(note)
            ripple = self.ripple
        except TraceError as exc:
            if self.first and not (at_rest or ramp):
                raise
            status, trace = f"refused: {exc}", None
        self.first = self.first and trace is None  # (refused at rest or in a ramp)
        # the windows cut at the block's own rate (a logger's rate may change within a record)
        fs = self.fs if trace is None else trace.sample_rate_hz
        if abs(fs / self.fs - 1.0) > RATE_CHANGE and not self.rate_noted:
            self.table.notes.append(
                f"at t = {time_text(start)} s: sampled at {fs:.6g} Hz, the record's first block at "
                f"{self.fs:.6g} Hz; each block's windows are cut at its own rate"
            )
            self.rate_noted = True
        hop_n, win_n = int(round(self.s.hop * fs)), int(round(self.s.window_s * fs))
        self.block_fs = fs
        every = self.s.condition_every_s
        assess = getattr(self.model, "condition", None) is not None and every is not None
        todo = []  # (row, segment, omega) of the windows to measure
        # each window's speed, why it is refused for it if it is, and the block's last window
        # that can be assessed (of full length, not refused): the record's, if none follows
        omegas, refused = [omega_block] * n_per, [None] * n_per
        if speed is not None and trace is not None:
            omegas = [speed_of(speed[k * hop_n : k * hop_n + win_n]) for k in range(n_per)]
            refused = [speed_refusal(w, self.s) for w in omegas]
        last_full = -1 if trace is None else (trace.resistance_ohm.size - win_n) // hop_n
        usable_k = max([k for k in range(min(n_per, last_full + 1)) if not refused[k]], default=-1)
        for k in range(n_per):
            t_start = start + k * self.s.hop
            row = {
                "start_s": t_start,
                "end_s": t_start + self.s.window_s,
                "time_s": t_start + 0.5 * self.s.window_s,
                "status": status,
                "ripple": ripple,
            }
            rows.append(row)
            if trace is None:
                continue
            seg = trace.resistance_ohm[k * hop_n : k * hop_n + win_n]
            if seg.size < 0.9 * win_n:
                row["status"] = "refused: window cut short by a repair"
                continue
            omega = omegas[k]
            if refused[k]:
                row["status"] = f"refused: {refused[k]}"
                continue
            # the window nearest the due time, a tie to the later (1.5 hops: every second one)
            due = assess and t_start >= self.next_condition_s - (0.5 - 1e-6) * self.s.hop
            measured = self.tracked if self.s.track_speed and speed is None else omega
            if assess and k == usable_k and seg.size == win_n:
                self.last_usable = (row, seg.copy(), trace.sample_rate_hz, measured)
            if due and seg.size == win_n:
                row["_condition"] = (seg.copy(), trace.sample_rate_hz, measured)
                self.next_condition_s = t_start + every
            elif not self.s.load_state:  # nothing to estimate: the envelope alone
                row.update(omega_rad_s=omega, resistance_min_ohm=float(seg.min()))
                row["resistance_max_ohm"] = float(seg.max())
                continue
            if self.s.track_speed and speed is None:
                # the speed comes from the previous window's line: one window at a time
                self._measure([(row, seg, self.tracked)], trace.sample_rate_hz)
            else:
                todo.append((row, seg, omega))
        # windows of full length in one batch, any others (cut by a repair) one by one
        full = [w for w in todo if w[1].size == win_n]
        self._measure(full, trace.sample_rate_hz if trace else 0.0)
        for w in todo:
            if w[1].size != win_n:
                self._measure([w], trace.sample_rate_hz)
        self.pending.extend(rows)
        self.table.cpu_s += time.process_time() - clock


def monitor_trace(
    path,
    model: LoadStateModel,
    settings: MonitorSettings,
    progress: Callable[[WindowTable], None] | None = None,
) -> WindowTable:
    """The per-window estimates of a trace file, or of CSV on standard input (``path`` "-"),
    followed to its end (module docstring). Raises TraceError (one line) when the trace or its
    first block is refused; Ctrl-C while following ends the reading and keeps what was analysed
    (``interrupted``)."""
    s = settings.for_trace(path).for_model(model)
    s.check()
    s.check_model(model)
    table = WindowTable()
    source = trace_label(path)
    cutter = _Windows(s, model, table, source)
    chunks = read_chunks(
        path,
        s.time_column,
        s.resistance_column,
        s.speed_column,
        chunk_rows=s.chunk_rows,
        follow=s.follow,
        idle_s=s.follow_idle_s,
    )
    # one core's work: the BLAS library's idle threads would spin beside it (~0.6 s of another
    # core's CPU per minute of a 55 kHz trace, measured; none at 50 kHz)
    with threadpool_limits(limits=1, user_api="blas"):
        try:
            for chunk in chunks:
                table.time_origin_utc = table.time_origin_utc or chunk.origin_utc
                cutter.add(chunk)
                if progress is not None:
                    progress(table)
                if cutter.ended:
                    break
        except (KeyboardInterrupt, SystemError) as exc:
            if not (s.follow and interruption(exc)):
                raise
            table.interrupted = True
        cutter.finish()
    windows = table.frame()
    # a window whose condition is a confident fault answers too (:func:`confident_faults`), and
    # any assessed one where the load state is not estimated
    answers = (windows["status"] == "ok") | confident_faults(windows) if len(windows) else None
    if not s.load_state and "condition" in windows:
        answers |= windows["condition"].notna()
    if len(windows) and not answers.any():
        # the first that is not a gap's (a record that starts with a gap names its rule)
        told = windows["status"][~windows["status"].str.startswith("no data")]
        raise TraceError(
            f"{source}: none of its {len(windows)} windows carries an estimate; the first: "
            f"{(told if len(told) else windows['status']).iloc[0]}"
        )
    if not table.parts:
        raise TraceError(
            f"{source}: {table.n_samples} sample{'' if table.n_samples == 1 else 's'}, shorter "
            f"than one --window of {s.window_s:g} s"
        )
    return table
