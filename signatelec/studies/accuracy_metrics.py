"""Measures of the accuracy-cost study: a run's trace against the reference's, and the summary.

Pure functions of result tables and arrays (no simulation): the amplitude of the resistance at
the ball-pass frequency, the RMS difference of two traces, the relative errors of a run against
the reference, the per-setting summary over the scenes and its Pareto front. The study itself
(scenes, settings, runs) is :mod:`signatelec.studies.accuracy_cost`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: The paper's setting (seed section 4): the cost every other is compared with.
PAPER_SETTING = "dem verlet dt=1e-7 (paper)"
#: Accuracy asked of a cheaper setting: mean resistance and ball-pass amplitude within 1 %.
TOLERANCE = 0.01
#: Cost asked of a cheaper setting, relative to the paper's CPU time.
COST_FRACTION = 0.1


def ball_pass_amplitude(time_s, values, frequency_hz: float) -> float:
    """Amplitude of the component of ``values`` at ``frequency_hz`` (least squares).

    Fits ``a + b (t - t_mean) + c cos(2 pi f t) + d sin(2 pi f t)`` and returns ``hypot(c, d)``:
    the amplitude (half the peak-to-peak) of the fundamental, exact for a sampled sinusoid of
    that frequency whatever the number of periods (no FFT bin leakage; the linear term absorbs a
    slow drift). Same unit as ``values``.
    """
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(values, dtype=float)
    if t.shape != y.shape or t.ndim != 1 or t.size < 5:
        raise ValueError("time_s and values: equal 1-D shapes with at least 5 samples expected")
    if not frequency_hz > 0.0:
        raise ValueError(f"frequency_hz = {frequency_hz!r}: must be > 0")
    phase = 2.0 * math.pi * frequency_hz * t
    design = np.column_stack((np.ones_like(t), t - t.mean(), np.cos(phase), np.sin(phase)))
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    return float(math.hypot(coef[2], coef[3]))


def rms_difference(time_s, values, reference_time_s, reference_values) -> float:
    """RMS of ``values`` (linearly interpolated onto the reference instants) minus the reference.

    Reference instants outside ``time_s`` are left out.
    """
    t, y = np.asarray(time_s, dtype=float), np.asarray(values, dtype=float)
    tr, yr = np.asarray(reference_time_s, dtype=float), np.asarray(reference_values, dtype=float)
    inside = (tr >= t[0]) & (tr <= t[-1])
    diff = np.interp(tr[inside], t, y) - yr[inside]
    return float(np.sqrt(np.mean(diff * diff)))


@dataclass(frozen=True)
class Trace:
    """The compared part of a run: the steady window after the settling."""

    time_s: np.ndarray
    resistance_ohm: np.ndarray
    max_ball_load_n: np.ndarray
    ball_pass_frequency_hz: float

    @classmethod
    def of(cls, result, window_start_s: float) -> Trace:
        sig = result.signals
        sig = sig[sig["time_s"] > window_start_s]
        z = result.scene.bearing.n_balls
        # the run's own ball-pass frequency, from its mean cage speed (slip lowers it a little)
        frequency = z * float(sig["cage_speed_rad_s"].mean()) / (2.0 * math.pi)
        return cls(
            sig["time_s"].to_numpy(),
            sig["resistance_ohm"].to_numpy(),
            sig["max_ball_load_n"].to_numpy(),
            frequency,
        )

    def measures(self) -> dict:
        return {
            "mean_resistance_ohm": float(self.resistance_ohm.mean()),
            "ball_pass_amplitude_ohm": ball_pass_amplitude(
                self.time_s, self.resistance_ohm, self.ball_pass_frequency_hz
            ),
            "max_ball_load_n": float(self.max_ball_load_n.max()),
            "ball_pass_frequency_hz": self.ball_pass_frequency_hz,
        }


def compare(trace: Trace, reference: Trace) -> dict:
    """Relative errors of a run against the reference (signed, except the RMS)."""
    m, r = trace.measures(), reference.measures()
    mean = r["mean_resistance_ohm"]
    return {
        **m,
        "mean_resistance_error": m["mean_resistance_ohm"] / mean - 1.0,
        "ball_pass_amplitude_error": m["ball_pass_amplitude_ohm"] / r["ball_pass_amplitude_ohm"]
        - 1.0,
        "rms_resistance_error": rms_difference(
            trace.time_s, trace.resistance_ohm, reference.time_s, reference.resistance_ohm
        )
        / mean,
        "max_ball_load_error": m["max_ball_load_n"] / r["max_ball_load_n"] - 1.0,
    }


# --- summary over the scenes ----------------------------------------------------------------------


def summarise(table: pd.DataFrame) -> pd.DataFrame:
    """One row per setting: worst |error| over the scenes, median cost."""
    ok = table[table["status"] == "ok"].copy()
    ok["accuracy_error"] = np.maximum(
        ok["mean_resistance_error"].abs(), ok["ball_pass_amplitude_error"].abs()
    )
    agg = {
        "mean_resistance_error": lambda s: s.abs().max(),
        "ball_pass_amplitude_error": lambda s: s.abs().max(),
        "accuracy_error": "max",
        "rms_resistance_error": "max",
        "max_ball_load_error": lambda s: s.abs().max(),
        "wall_s_per_simulated_s": "median",
        "cpu_s_per_simulated_s": "median",
        "dt_over_limit": "median",
    }
    for column in ("cost_vs_paper", "cpu_cost_vs_paper"):
        if column in ok:
            agg[column] = "median"
    summary = ok.groupby("setting", sort=False).agg(agg)
    summary["scenes"] = ok.groupby("setting", sort=False).size()
    failed = table[table["status"] != "ok"].groupby("setting", sort=False).size()
    summary["failed"] = failed.reindex(summary.index).fillna(0).astype(int)
    return summary.reset_index()


def cheap_and_accurate(summary: pd.DataFrame) -> pd.DataFrame:
    """DEM settings within TOLERANCE on mean R and ball-pass amplitude at no more than
    COST_FRACTION of the paper's CPU cost (medians over the scenes): the study's question."""
    dem = summary[~summary["setting"].isin(["quasistatic"])]
    return dem[(dem["accuracy_error"] <= TOLERANCE) & (dem["cpu_cost_vs_paper"] <= COST_FRACTION)]


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both cost and error, by cost."""
    order = np.argsort(cost, kind="stable")
    front, best = [], math.inf
    for i in order:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return np.array(front, dtype=int)
