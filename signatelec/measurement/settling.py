"""The set-up transient of a trace: where its level, read per ball pass, has not yet settled
(:func:`trim_transient`, the sanity layer's rule 1: :mod:`signatelec.measurement.sanity`).
Light (numpy only), so that ``simulate`` can say whether its own steady phase still settles
without the spectral searches' imports."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from signatelec.measurement.band import MIN_BALL_PASSES
from signatelec.measurement.traces import Trace, TraceError
from signatelec.physics.kinematics import expected_ball_pass_hz

#: A block mean this many block-noise sigmas off the steady level departs from it...
STEP_SIGMAS = 10.0
#: ... if it is also off by more than this share of the level.
DRIFT_ALLOWANCE = 0.005
#: Departures from the steady level in at least this many separate groups of ball passes,
#: reaching the second half of the trace, recur as a defect's events do.
RECURRENT_GROUPS = 2
_MAD_TO_SIGMA = 1.4826


def recurrent(off: np.ndarray, n_blocks: int) -> bool:
    """Whether the departing blocks ``off`` (indices among ``n_blocks``) recur through the
    trace, as a defect's events do (a spall on a ball is in the load zone once per cage
    revolution), rather than lead up to the steady part as a set-up transient, a step or a
    trend does (those depart from the first block on): at least :data:`RECURRENT_GROUPS`
    separate groups, none at the first block, the last in the second half."""
    if off.size == 0:
        return False
    groups = 1 + int(np.count_nonzero(np.diff(off) > 1))
    return groups >= RECURRENT_GROUPS and off[0] > 0 and off[-1] >= n_blocks // 2


def trim_transient(
    trace: Trace, omega_rad_s: float, *, events: bool = False, bearing=None
) -> Trace:
    """The steady part of a trace (module rules), what was cut said in one line of its
    ``repairs``; TraceError when no steady part is long enough. With ``events`` (the caller
    has a condition model to judge them), departures that recur through the trace
    (:func:`recurrent`) are a defect's events, not a transient: the trace is kept whole."""
    r, fs = trace.resistance_ohm, trace.sample_rate_hz
    f_bp = expected_ball_pass_hz(omega_rad_s, bearing)
    n_block = max(int(round(fs / f_bp)), 1)
    n = r.size // n_block
    if n < 4:
        return trace
    means = r[: n * n_block].reshape(n, n_block).mean(axis=1)
    level = float(np.median(means[n // 2 :]))
    diffs = np.diff(means[n // 2 :])
    noise = _MAD_TO_SIGMA * float(np.median(np.abs(diffs - np.median(diffs)))) / np.sqrt(2.0)
    allowed = max(STEP_SIGMAS * noise, DRIFT_ALLOWANCE * abs(level))
    off = np.flatnonzero(np.abs(means - level) > allowed)
    where = trace.source
    if events and recurrent(off, n):
        return trace
    if off.size:
        last = int(off[-1])
        worst = int(off[np.argmax(np.abs(means[off] - level))])
        start = (last + 1) * n_block
        kept_passes = (r.size - start) / fs * f_bp
        ratio = means[worst] / level if level else np.inf
        step = f"{ratio - 1:+.1%}" if ratio < 2 else f"{ratio:,.0f}x"
        if kept_passes < MIN_BALL_PASSES:
            raise TraceError(
                f"{where}: level not steady: off the final level by {step} at t = "
                f"{worst * n_block / fs:.4g} s, up to t = {start / fs:.4g} s, far beyond the "
                f"noise; the steady part left ({kept_passes:.1f} ball passes) is shorter than "
                f"{MIN_BALL_PASSES:g}"
            )
        note = (
            f"trimmed a transient: the first {start / fs * 1e3:.4g} ms (level off by up to "
            f"{step}) dropped, {kept_passes:.1f} ball passes kept"
        )
        trace = replace(
            trace,
            time_s=trace.time_s[start:] - trace.time_s[start],
            resistance_ohm=r[start:],
            repairs=(*trace.repairs, note),
        )
    return trace
