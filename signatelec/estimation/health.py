"""The bearing's health over a long trace: a window's condition now and then, and where it changes.

The condition model (:mod:`signatelec.estimation.condition`, through :func:`~signatelec.
estimation.diagnose.assess_condition`) reads a trace of a few cage revolutions: the default
model learnt from traces of 3.8-8.9 (0.12-0.28 s at 500 rad/s), so the monitor's 0.2 s window
is one it can read as it is. Its envelope analysis (the spectral-kurtosis band, the Hilbert
envelope, two spectra; the window's own trace analysis reused) costs ~4 ms for a 0.2 s window
at 50 kHz, ~6 times the window's load-state analysis: every window would cost ~75 s of CPU an
hour of trace, one every 10 s ~1.5 s (the monitor's whole budget at 200x real time is 18 s).
A spall, once it has appeared, persists and grows over many hours of running, and on-line
condition monitoring systems take their snapshots minutes apart, so the monitor assesses one
window every :data:`CONDITION_EVERY_S` (the first full window of a block once that much trace
has passed; ~0.25 s of CPU an hour) and leaves the others' condition empty;
``--condition-every`` down to the hop assesses more.

:func:`assess_window` asks the condition model about a window; its result keys are the
window's ``condition`` columns. :func:`condition_changes` gives the change detector
(:func:`~signatelec.estimation.changes.change_points`) the assessed windows' log-odds, a
series of its own at the assessments' cadence, and places each change it finds halfway between
the last assessment before and the first after, so that a defect's onset is timed to within
half the cadence (+-30 s at the default); the detector needs :data:`~signatelec.estimation.
changes.MIN_SEGMENT` assessments on either side (3 min at the default).

:func:`stretch_condition` calls a stretch's condition from its assessments: the condition most
of them were called (each by the condition model's own rule, whose healthy threshold sets its
false-alarm rate), with their mean probabilities. The assessments of one stretch are not
independent evidence: the model's error is the run's, and every one of them shares it (healthy
runs at the paper's fidelity whose every assessment leans to an inner-race spall, P(inner)
0.35-0.76 against P(healthy) 0.13-0.45, each still called healthy). The product of their
probabilities, right for independent evidence, called 8 of 15 such healthy stretches faulty
(docs/monitor/health.md); the mean (the sum rule, robust where the probabilities carry a
shared error: Kittler, Hatef, Duin & Matas 1998, *On combining classifiers*, IEEE TPAMI 20(3),
section 5) does not sharpen with their number.

A stretch called faulty is answered by the model's ``faulty`` load-state model, as ``estimate``
answers a trace its condition model calls faulty (:func:`faulty_windows`): the healthy load
model never saw a spall's pulses, which take most of a faulty stretch's windows out of its
domain (on the held-out records of docs/monitor/health.md it answered 17 of 45 spalled stretches,
F_r 0.2-3.8 % off on average by location), while the faulty model learnt the condition model's
runs of the seed's bearing, spalled and unbalanced. Its windows are segmented again by the
change detector (:func:`~signatelec.estimation.evidence.stretches_and_changes`): the record's
detector read only the windows the healthy model answered.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from signatelec.config.constraints import HEALTHY
from signatelec.estimation.analysis import analyse_trace
from signatelec.estimation.changes import change_points
from signatelec.estimation.condition import PROBABILITY, SEVERITY_TARGET
from signatelec.estimation.diagnose import CONFIDENT_CONDITION, LINE_KEYS, assess_condition
from signatelec.estimation.domain import refuse_score
from signatelec.estimation.features import trace_features
from signatelec.measurement.sanity import explains, fault_line

#: Trace between two assessments of the condition, s (module docstring).
CONDITION_EVERY_S = 60.0
#: Prefixes of a window's load-state answers (targets, their intervals, the regime).
LOAD_OUTPUTS = ("radial_load_n", "epsilon", "clearance_m", "regime")
#: Floor of a probability before its log (a saturated classifier's 0).
FLOOR = 1e-6


def assess_window(
    segment,
    sample_rate_hz: float,
    omega_rad_s: float,
    features: dict,
    model,
    analysis=None,
    bearing=None,
):
    """(keys, note) of one window: ``condition``, ``condition_probability_<name>``,
    ``condition_in_domain_score``, the spall length with its interval and the characteristic
    line that names the condition (:data:`~signatelec.estimation.diagnose.LINE_KEYS`; None where
    not assessed), and the reason it was not assessed (None if it was). ``features``: the window's
    load-state features (:func:`~signatelec.estimation.features.trace_features`' names);
    ``bearing``: its geometry, which places the defects' lines (default: the seed's)."""
    out, notes = assess_condition(
        segment, sample_rate_hz, omega_rad_s, features, model, bearing, trace_analysis=analysis
    )
    keys = ["condition", "condition_in_domain_score", SEVERITY_TARGET]
    keys += [f"{SEVERITY_TARGET}_low", f"{SEVERITY_TARGET}_high", *LINE_KEYS]
    row = {k: out.get(k) for k in keys}
    row.update({k: v for k, v in out.items() if k.startswith(PROBABILITY)})
    missing = out.get("condition") is None
    return row, (notes[0] if missing and notes else None)


def defect_explains(
    trace,
    omega_rad_s: float,
    model,
    ripple,
    window_s: float,
    screened: int,
    bearing=None,
    learnt=None,
):
    """Whether the strongest line of the first ``screened`` samples of a block's ``trace``,
    away from the ball-pass frequency, is a defect's (:func:`~signatelec.measurement.sanity.
    fault_line`, of ``bearing``) that the condition ``model`` confidently calls on the
    block's first ``window_s`` (its training traces' length), as ``estimate`` keeps a trace
    whose strongest line a confident call of that very condition explains (of any fault, for
    a line at no defect's frequency beside the ripple found); its load features
    read at the ball-pass line of ``learnt``, the bearing the model learnt (None: the seed's),
    as ``estimate`` reads them."""
    fs = trace.sample_rate_hz
    seg = trace.resistance_ohm[: int(round(window_s * fs))]
    line = None if model is None else fault_line(ripple, omega_rad_s, screened / fs, bearing)
    if line is None:
        return False
    mine = None if learnt is None else analyse_trace(seg, fs, omega_rad_s, bearing=learnt)
    feats = trace_features(seg, fs, omega_rad_s, analysis=mine)
    keys, _ = assess_window(seg, fs, omega_rad_s, feats, model, bearing=bearing)
    p = keys.get(f"{PROBABILITY}{keys['condition']}")
    return explains(line[0], keys["condition"]) and p is not None and p >= CONFIDENT_CONDITION


def confident_faults(windows: pd.DataFrame) -> pd.Series:
    """Windows whose condition is a fault called with at least CONFIDENT_CONDITION: those that
    answer without a load estimate (a spall can take every window's load features out of the
    load model's domain), as ``estimate`` keeps a trace out of that domain only when a
    confident fault explains it."""
    call = windows["condition"] if "condition" in windows else pd.Series(None, windows.index)
    p = pd.Series(np.nan, index=windows.index)
    for name in call.dropna().unique():
        if name != HEALTHY and f"{PROBABILITY}{name}" in windows:
            at = call == name
            p[at] = windows.loc[at, f"{PROBABILITY}{name}"]
    return p >= CONFIDENT_CONDITION


def assessed_windows(windows: pd.DataFrame) -> pd.DataFrame:
    """The windows whose condition was assessed (whatever their load state's status: a spall
    can take the load features out of the load model's domain), in time order."""
    pc = [c for c in windows.columns if c.startswith(PROBABILITY)]
    if not pc:
        return windows.iloc[0:0]
    done = np.all(np.isfinite(windows[pc].to_numpy(float)), axis=1)
    return windows[done].sort_values("start_s").reset_index(drop=True)


def stretch_condition(assessed: pd.DataFrame) -> dict:
    """The condition keys of a stretch from its ``assessed`` windows (module docstring):
    ``condition`` (the call most of them share; a tie to healthy, else to the larger mean
    probability), ``condition_probability`` (the called condition's mean probability) and
    ``condition_probability_<name>`` (the means), ``condition_assessments`` (their number),
    ``condition_faulty_share`` (the share of them called anything but healthy: above 1/2 the
    stretch is faulty) and ``condition_speeds_rad_s`` (the lowest and highest of their speeds,
    which :func:`~signatelec.estimation.monitor_report.qualify` checks against the condition
    model's training range); none without an assessment."""
    pc = [c for c in assessed.columns if c.startswith(PROBABILITY)]
    if not pc:
        return {}
    p = assessed[pc].to_numpy(float)
    done = np.all(np.isfinite(p), axis=1)
    if not done.any():
        return {}
    names = [c.removeprefix(PROBABILITY) for c in pc]
    mean = dict(zip(names, p[done].mean(axis=0).tolist(), strict=True))
    calls = assessed["condition"].to_numpy(object)[done]
    votes = {k: int(np.count_nonzero(calls == k)) for k in names}
    # a fault needs more calls than healthy: a tie is healthy (the mean probabilities can lean
    # to a fault that the model's own rule called healthy in each window)
    best = max(names, key=lambda k: (votes[k], k == HEALTHY, mean[k]))
    faulty = sum(v for k, v in votes.items() if k != HEALTHY) / calls.size
    out = {
        "condition": best,
        "condition_probability": mean[best],
        "condition_assessments": int(calls.size),
        "condition_faulty_share": faulty,
    }
    speeds = assessed["omega_rad_s"].to_numpy(float)[done] if "omega_rad_s" in assessed else []
    if np.isfinite(speeds).any():
        out["condition_speeds_rad_s"] = [float(np.nanmin(speeds)), float(np.nanmax(speeds))]
    return out | {f"{PROBABILITY}{k}": v for k, v in mean.items()}


def refused_assessments(windows: pd.DataFrame, start_s: float, end_s: float) -> dict:
    """``condition_refused`` (how many) and ``condition_refused_first_s`` of the windows from
    ``start_s`` to ``end_s`` whose condition was not assessed because they are unlike every
    training trace of the condition model (an in-domain score, no call), or none: a fault or
    a bearing the model did not learn, whose stretch a healthy call does not cover."""
    if "condition_in_domain_score" not in windows or "condition" not in windows:
        return {}
    inside = (windows["start_s"] >= start_s - 1e-9) & (windows["end_s"] <= end_s + 1e-9)
    refused = inside & windows["condition_in_domain_score"].notna() & windows["condition"].isna()
    if not refused.any():
        return {}
    return {
        "condition_refused": int(refused.sum()),
        "condition_refused_first_s": float(windows.loc[refused, "start_s"].min()),
    }


def faulty_windows(windows: pd.DataFrame, start_s: float, end_s: float, model) -> pd.DataFrame:
    """The windows within ``start_s``-``end_s`` that hold ``model``'s features (every window the
    monitor measured, whatever the healthy load model made of it), answered by ``model`` (a
    load-state model: the model's ``faulty``), those within its domain (not refused by
    :func:`~signatelec.estimation.domain.refuse_score`, as the monitor refuses a window), with
    ``status`` ``ok``, in time order."""
    names = list(model.features)
    inside = (windows["start_s"] >= start_s - 1e-9) & (windows["end_s"] <= end_s + 1e-9)
    part = windows[inside]
    if part.empty or not set(names) <= set(part.columns):
        return part.iloc[0:0]
    part = part[np.all(np.isfinite(part[names].to_numpy(float)), axis=1)]
    if part.empty:
        return part
    pred = model.predict_columns(part[names].to_numpy(float))
    # the healthy model's answers go, all of them (a class or target the faulty model lacks
    # would otherwise be mixed in)
    theirs = [c for c in part.columns if c.startswith(LOAD_OUTPUTS)]
    out = part.drop(columns=theirs).assign(**pred)
    out["status"] = "ok"
    out = out.sort_values("start_s").reset_index(drop=True)
    if model.domain is None:  # the healthy model's score is not this model's
        out = out.drop(columns="in_domain_score", errors="ignore")
    else:
        out["in_domain_score"] = model.domain.scores(out[list(model.domain.features)])
        ripple = out["ripple"] if "ripple" in out else pd.Series("", index=out.index)
        limit = [refuse_score(r != "none") for r in ripple]  # as a window is refused
        out = out[out["in_domain_score"] >= limit]
    return out


def condition_changes(
    good: pd.DataFrame, assessed: pd.DataFrame, false_alarm_per_hour: float
) -> list[tuple[int, float, float, float]]:
    """[(row of ``good`` where a stretch starts, time, probability, half the time between the
    two assessments)] of the changes of the ``assessed`` windows' condition: the change
    detector on their log-odds against the last class, at their cadence
    (``false_alarm_per_hour``: this series' share of the record's rate); a change is halfway
    between the last assessment before and the first after, or where the usable load windows
    stop or start between the two (a spall's pulses can take them out of the load model's
    domain); in time order."""
    pc = [c for c in assessed.columns if c.startswith(PROBABILITY)]
    if len(pc) < 2 or len(assessed) < 2:
        return []
    logp = np.log(np.clip(assessed[pc].to_numpy(float), FLOOR, 1.0))
    x = (logp - logp.mean(axis=1, keepdims=True))[:, :-1]
    start = assessed["start_s"].to_numpy(float)
    every_s = float(np.median(np.diff(start)))
    # chi^2's tail, not Hotelling's: at ~10 assessments a record Hotelling's thresholds lost
    # 4 of 10 ball spalls and 5 of 10 unbalances of the health study's DEM records, while
    # chi^2 kept its rate there (no condition alarm in 40 healthy records; docs/monitor/health.md)
    found = sorted(
        change_points(assessed, every_s, false_alarm_per_hour, series=x, hotelling=False)
    )
    good_start = good["start_s"].to_numpy(float)
    good_end = good["end_s"].to_numpy(float)
    usable = (assessed["status"] == "ok").to_numpy() if "status" in assessed else None
    out = []
    for j, p in found:
        a, b = start[j - 1], start[j]
        t, half = 0.5 * (a + b), 0.5 * (b - a)
        between = (good_start > a) & (good_start < b)
        if usable is not None and usable[j - 1] != usable[j] and between.any():
            # the load windows stop (or start) between the two: the change is there
            t = float(good_end[between][-1] if usable[j - 1] else good_start[between][0])
        out.append((int(np.searchsorted(good_start, t - 1e-9)), t, p, half))
    return out
