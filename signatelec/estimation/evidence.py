"""Evidence over time: change points in the window estimates, stretch estimates, alarms.

**Change points** (:mod:`~signatelec.estimation.changes`): where the windows' estimates change
(:func:`~signatelec.estimation.changes.change_points`) and when
(:func:`~signatelec.estimation.changes.change_time`).

**Stretches** (:func:`combine_stretch`): the windows between two changes. With the model's
stretch model (:mod:`~signatelec.estimation.stretch`), F_r, epsilon, clearance and the regime
are its estimates from the windows' MEAN features, and the model's error part below is its own
interval's standard deviation w (a model of its out-of-fold error draws that interval). Without
one, a regression target (F_r on a log scale, epsilon, clearance) is the mean of the window
estimates, a model of the window means whose error has two parts. The windows' scatter about
their mean (noise), divided by the effective number of independent windows n_eff = n / (1 + 2
sum_k (1 - k / (K + 1)) rho_k) (Bartlett, rho_k their autocorrelation at lag k, K = n^(1/3)):
the windows themselves check the independence assumption; this part shrinks as a stretch grows.
And the model's own error for that state, which does not shrink (the windows of one state share
it): ``bias_ratio`` times the root-mean-square standard deviation of the windows' intervals
(their width / 2 z90), a ratio per target and per regime the stretch is estimated in,
calibrated by Mondrian split conformal prediction (Vovk, Gammerman, Shafer 2005, ch. 2 and
4.5: the conformal quantile taken within each category of a taxonomy known at prediction time,
here the estimated regime, so that the coverage holds within each regime, not only over their
mix; Lei et al. 2018, JASA 113, 1094) on held-out runs that are not the acceptance records
(:data:`BIAS_RATIO`, :data:`BIAS_RATIO_WINDOWS`; ``signatelec study monitor`` measures them;
one ratio per target over-covers some regimes and under-covers others, docs/monitor). The two
parts add in quadrature: half-width
z90 (b^2 w^2 + s^2 / n_eff)^(1/2). The regime combines the windows' log-probabilities, each
weighted n_eff / n (the same correction for correlation); the condition, assessed on a few
windows, is the call most of them share, with their mean probabilities
(:func:`~signatelec.estimation.health.stretch_condition` says why).

**Speed**: features read at another speed move with it, so a change that came with the
speed and raises no alarm is the speed's, and its two stretches are joined
(:func:`_join_speed_changes`): a run-up at a constant load is one stretch.

**Windows the load model cannot read**: the detector reads the usable windows only; a run of
windows out of the load model's domain that is the one such run of its segment among windows
it reads is a stretch of its own (:func:`~signatelec.estimation.changes.unread_changes`).

**Alarms** (:func:`alarms`): at each change, a load change beyond ``load_threshold`` (with the
probability that the stretches' F_r differ by more, from their scatter parts), a change of
regime or of condition (the probability that the two stretches' classes differ).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import pandas as pd
from scipy import stats

from signatelec.config.constraints import HEALTHY
from signatelec.estimation.changes import (
    DETECTOR_COLUMNS,
    FALSE_ALARM_PER_HOUR,
    change_points,
    change_time,
    effective_fraction,
    rate_shares,
    unread_changes,
)
from signatelec.estimation.condition import PROBABILITY
from signatelec.estimation.estimate import CONFIDENT_PROBABILITY
from signatelec.estimation.health import (
    assessed_windows,
    condition_changes,
    faulty_windows,
    refused_assessments,
    stretch_condition,
)
from signatelec.estimation.stretch import stretch_estimate

#: A change of the stretches' median speed beyond which the features may have moved with it:
#: the level's elasticity to the speed is about -0.01 at 500 rad/s (it falls ~0.4 % from 400 to
#: 600 rad/s at a constant load, the balls' centrifugal force, growing as the speed squared),
#: so 0.1 % moves it by 1-2e-5, a few standard deviations of a few seconds' mean (a 0.2 s
#: window's is ~3e-5 at 0.2 % noise): what the change detector can see.
SPEED_MOVED_REL = 1e-3
#: The z of a two-sided 90 % normal interval (intervals are combined on this scale).
Z90 = stats.norm.ppf(0.95)
#: The model's error of a state (shared by its windows) in units of the stretch model's
#: interval sd, per target and estimated regime: Mondrian split-conformal 90 % quantile over
#: the calibration stretches of ``signatelec study monitor`` in that regime (288 other held-out
#: DEM states, records as the acceptance ones, 0.2 s windows); ``"any"``: over all of them.
BIAS_RATIO = {
    "radial_load_n": {"any": 0.482, "clearance": 0.455, "preload": 0.451, "zero": 0.517},
    "epsilon": {"any": 0.552, "clearance": 0.603, "preload": 0.472, "zero": 0.611},
    "clearance_m": {"any": 0.479, "clearance": 0.624, "preload": 0.422, "zero": 0.287},
}
#: The same for the windows' estimates combined (units: their intervals' rms sd), on the same
#: stretches (they answer for a model without a stretch model, or where it does not).
BIAS_RATIO_WINDOWS = {
    "radial_load_n": {"any": 0.439, "clearance": 0.573, "preload": 0.504, "zero": 0.101},
    "epsilon": {"any": 0.425, "clearance": 0.616, "preload": 0.654, "zero": 0.055},
    "clearance_m": {"any": 0.407, "clearance": 0.733, "preload": 0.585, "zero": 0.060},
}
#: The ratios by what answers a stretch (its ``estimated_from``).
RATIOS_BY_SOURCE = {"mean features": BIAS_RATIO, "windows": BIAS_RATIO_WINDOWS}
#: The category of a stretch without an estimated regime.
ANY_REGIME = "any"
#: The ratio of a model whose stretches were not calibrated (any but the default model): a
#: stretch's model part is then its windows' own interval sd, so that its interval is at least
#: as wide as theirs (the windows' intervals cover the model's error over the states it learnt;
#: the shipped ratios, 0.06-0.73, are the default model's, and with them a 6208's model trained
#: by a user missed its F_r in 5 of 5 stretches of a record).
UNCALIBRATED_RATIO = 1.0
#: Class outputs of the model, each with ``<name>_probability_<class>`` columns.
CLASS_OUTPUTS = ("regime", "condition")
#: Regression targets and the scale they are combined on.
TARGET_SCALES = {"radial_load_n": "log", "epsilon": "linear", "clearance_m": "linear"}
#: Default threshold of a load-change alarm (relative change of F_r).
LOAD_THRESHOLD = 0.05


def class_columns(windows: pd.DataFrame, name: str) -> list[str]:
    prefix = f"{name}_probability_"
    return [c for c in windows.columns if c.startswith(prefix)]


def combine_target(values, low, high, log: bool, bias_ratio: float, model=None) -> dict:
    """Mean of the window estimates with its interval (module docstring): ``value``, ``low``,
    ``high``, ``se_noise`` (the noise part's standard error), ``n_eff`` and ``window_sd`` (the
    windows' interval standard deviation, which ``bias_ratio`` multiplies), the last two on
    the combining scale (log for ``log``). ``model``: the stretch model's (value, low, high),
    which give the value and the standard deviation that ``bias_ratio`` multiplies instead."""
    y = np.asarray(values, float)
    lo, hi = np.asarray(low, float), np.asarray(high, float)
    if log:
        y, lo, hi = np.log(y), np.log(lo), np.log(hi)
    n = y.size
    n_eff = max(1.0, effective_fraction(y) * n)
    scatter2 = float(np.var(y, ddof=1)) if n > 1 else 0.0
    window_sd = math.sqrt(float(np.mean(((hi - lo) / (2.0 * Z90)) ** 2)))
    centre = float(y.mean())
    if model is not None:  # the stretch model's estimate and interval
        m = np.log(np.asarray(model, float)) if log else np.asarray(model, float)
        centre, window_sd = float(m[0]), float(m[2] - m[1]) / (2.0 * Z90)
    se_noise = math.sqrt(scatter2 / n_eff)
    half = Z90 * math.hypot(bias_ratio * window_sd, se_noise)
    out = {"value": centre, "low": centre - half, "high": centre + half}
    if log:
        out = {k: math.exp(v) for k, v in out.items()}
    return {**out, "se_noise": se_noise, "n_eff": n_eff, "window_sd": window_sd}


def combine_classes(windows: pd.DataFrame, name: str) -> dict[str, float] | None:
    """Class probabilities of a stretch: windows' log-probabilities summed, weighted n_eff / n."""
    pc = class_columns(windows, name)
    p = windows[pc].dropna().to_numpy(float)  # the windows that answered (health: a few)
    if not pc or not len(p):
        return None
    logp = np.log(np.clip(p, 1e-12, 1.0))
    top = int(np.argmax(logp.sum(axis=0)))
    others = np.delete(logp, top, axis=1)
    margin = logp[:, top] - (others.max(axis=1) if others.size else 0.0)
    weight = effective_fraction(margin) if len(logp) > 1 else 1.0
    z = weight * logp.sum(axis=0)
    z -= z.max()
    p = np.exp(z) / np.exp(z).sum()
    return {c.removeprefix(f"{name}_probability_"): float(q) for c, q in zip(pc, p, strict=True)}


def _named(name: str, probs: dict[str, float] | None) -> dict:
    """A class output's keys from its probabilities: ``<name>`` (the most probable class),
    ``<name>_probability`` and ``<name>_probability_<class>`` (none without probabilities)."""
    if not probs:
        return {}
    best = max(probs, key=probs.get)
    named = {name: best, f"{name}_probability": probs[best]}
    return named | {f"{name}_probability_{k}": v for k, v in probs.items()}


def bias_ratios(model) -> dict | None:
    """The ratios a stretch of ``model``'s windows is read with (:func:`combine_stretch`'s
    ``bias_ratio``): None, the shipped ones, for the default model, on which they were
    calibrated (``signatelec study monitor``); else :data:`UNCALIBRATED_RATIO` for every target
    and regime."""
    from signatelec.estimation.training import DEFAULT_SOURCE

    if model is None or model.info.get("trained_on") == DEFAULT_SOURCE:
        return None
    one = {target: {ANY_REGIME: UNCALIBRATED_RATIO} for target in TARGET_SCALES}
    return dict.fromkeys(RATIOS_BY_SOURCE, one)


def combine_stretch(
    windows: pd.DataFrame, bias_ratio: dict | None = None, stretch_model=None
) -> dict:
    """One stretch's estimate from its usable windows (``bias_ratio``: per source, as
    :data:`RATIOS_BY_SOURCE`, then per target, per estimated regime and :data:`ANY_REGIME`; a
    source it lacks takes the shipped ratios). With a
    ``stretch_model`` (:mod:`~signatelec.estimation.stretch`) that answers, the targets and the
    regime are its estimates from the windows' mean features, its interval sd the model part
    of each target's interval (``estimated_from``: ``mean features``, else ``windows``), and
    ``stretch_in_domain_score`` how like its training stretches those mean features are
    (``in_domain_score`` stays the windows' median: :func:`_windows_seen`)."""
    out: dict = {"n_windows": int(len(windows))}
    classes = _named("regime", combine_classes(windows, "regime")) | stretch_condition(windows)
    if windows.empty:  # a stretch of assessed windows only: its condition alone
        return {**out, **classes}
    est = stretch_estimate(windows, stretch_model)
    out["estimated_from"] = "windows" if est is None else "mean features"
    out |= _windows_seen(windows)
    if est is not None and "in_domain_score" in est:
        out["stretch_in_domain_score"] = est["in_domain_score"]
    ratios = {**RATIOS_BY_SOURCE, **(bias_ratio or {})}[out["estimated_from"]]
    if est is not None and "regime" in classes:
        pc = [c for c in est if c.startswith("regime_probability_")]
        probs = {c.removeprefix("regime_probability_"): float(est[c]) for c in pc}
        best = max(probs, key=probs.get)
        classes.update({"regime": best, "regime_probability": probs[best]})
        classes.update({f"regime_probability_{k}": v for k, v in probs.items()})
    regime = classes.get("regime", ANY_REGIME)
    for target, scale in TARGET_SCALES.items():
        if target not in windows:
            continue
        c = combine_target(
            windows[target],
            windows[f"{target}_low"],
            windows[f"{target}_high"],
            scale == "log",
            ratios[target].get(regime, ratios[target][ANY_REGIME]),
            None if est is None else [est[target], est[f"{target}_low"], est[f"{target}_high"]],
        )
        out[target] = c["value"]
        out[f"{target}_low"] = c["low"]
        out[f"{target}_high"] = c["high"]
        for part in ("se_noise", "n_eff", "window_sd"):
            out[f"{target}_{part}"] = c[part]
    return {**out, **classes}


def _windows_seen(windows: pd.DataFrame) -> dict:
    """What the windows that answer a stretch were like, as ``estimate`` reports of one trace
    (read by :func:`~signatelec.estimation.monitor_report.qualify`): their median in-domain
    score (of the window model that answered them, the healthy or the faulty one) and speed,
    and the share of them in which the ripple screen found no ball-pass line."""
    out = {}
    for name in ("in_domain_score", "omega_rad_s"):
        if name in windows and windows[name].notna().any():
            out[name] = float(windows[name].median())
    if "ripple" in windows:
        # no line at the screen, or a later screen that lost it (the speed went wrong)
        out["no_line_share"] = float(windows["ripple"].isin(("none", "unconfirmed")).mean())
    return out


def usable(windows: pd.DataFrame) -> pd.DataFrame:
    """The windows with an estimate (status ``ok``), in time order."""
    if "status" not in windows or "radial_load_n" not in windows:
        return windows.iloc[0:0]
    good = windows[(windows["status"] == "ok") & windows["radial_load_n"].notna()]
    return good.sort_values("start_s").reset_index(drop=True)


def check_settings(hop_s: float, false_alarm_per_hour: float, load_threshold: float) -> None:
    """ValueError (one line naming the option, its value and what is allowed) for settings
    the detector cannot work with (a NaN rate or threshold passed every comparison)."""
    for name, value, lo, hi in (
        ("--hop", hop_s, 0.0, math.inf),
        ("--false-alarm-rate", false_alarm_per_hour, 0.0, 3600.0),
        ("--load-threshold", load_threshold, 0.0, 10.0),
    ):
        if not (
            isinstance(value, numbers.Real) and not isinstance(value, bool) and lo < value <= hi
        ):
            raise ValueError(f"{name} {value!r}: must be in ({lo:g}, {hi:g}]")


def non_overlapping(good: pd.DataFrame) -> pd.DataFrame:
    """The windows of ``good`` (time order) kept greedily so that none overlaps the last kept:
    independent samples of the trace."""
    start, end = good["start_s"].to_numpy(float), good["end_s"].to_numpy(float)
    keep, free_from = [], -math.inf
    for i in range(start.size):
        if start[i] >= free_from - 1e-9:
            keep.append(i)
            free_from = end[i]
    return good.iloc[keep].reset_index(drop=True)


def _merged(load: list, cond: list) -> list[tuple[int, float, float, bool]]:
    """The changes of the load state, (row of the usable windows where the next stretch starts,
    time, probability), and of the condition (the same and half the time between its two
    assessments), as one list in time order of (row, time, probability, whether the condition
    changed): a condition change between two assessments that hold a load change is that
    change (the nearest one), timed by the level; rows repeat where no usable window lies
    between two changes."""
    found = [(k, t, p, False) for k, t, p in load]
    for k, t, p, half in cond:
        near = [i for i, c in enumerate(found) if not c[3] and abs(c[1] - t) <= half + 1e-9]
        i = min(near, key=lambda i: abs(found[i][1] - t), default=None)
        if i is None:
            found.append((k, t, p, True))
        else:
            found[i] = (*found[i][:3], True)
    return sorted(found, key=lambda c: c[1])


def stretches_and_changes(
    windows: pd.DataFrame,
    hop_s: float,
    false_alarm_per_hour: float = FALSE_ALARM_PER_HOUR,
    load_threshold: float = LOAD_THRESHOLD,
    bias_ratio: dict | None = None,
    stretch_model=None,
    faulty_model=None,
    gaps=None,
) -> tuple[list[dict], list[dict], list[dict]]:
    """(stretches, changes, alarms) of a window table (module docstring): every change point
    is a change (at ``false_alarm_per_hour`` for the whole record, shared between the load
    state's series and the condition's: :func:`~signatelec.estimation.changes.rate_shares`),
    described by its alarms, or by its F_r and
    epsilon when it raises none (a change below ``load_threshold`` within one regime).
    ``bias_ratio``, ``stretch_model`` (the model's ``stretch``): as :func:`combine_stretch`'s;
    a stretch called faulty is answered by ``faulty_model`` (the model's ``faulty``) where its
    windows lie in that model's domain (:func:`~signatelec.estimation.health.faulty_windows`;
    ``load_model`` ``faulty``), its windows' estimates combined, split where they change
    (:func:`_answered_faulty`). ``gaps``: (last time before, first time after) of each gap in
    the record (no sample for longer than ``prepare_trace`` fills in): a change found inside one
    is timed at its end, the first time the new state is seen, and names it (``gap_s``); each
    stretch gives the time it spans without samples (``unobserved_s``, when ``gaps`` is given)."""
    check_settings(hop_s, false_alarm_per_hour, load_threshold)
    good, assessed = usable(windows), assessed_windows(windows)
    if good.empty and assessed.empty:
        return [], [], []
    answered = good["start_s"]  # the windows the healthy model answered
    if len(good) > 1 and float((good["end_s"] - good["start_s"]).median()) > hop_s * (1 + 1e-9):
        # overlapping windows share samples: their residuals about a running median understate
        # the scatter and the detector split a constant record (60 s at a quarter-window hop:
        # 48 changes at 0.1 per hour); the evidence is read from windows that do not overlap
        good = non_overlapping(good)
        if len(good) > 1:
            hop_s = float(np.median(np.diff(good["start_s"].to_numpy(float))))
    load_rate, condition_rate = rate_shares(false_alarm_per_hour, len(windows), len(assessed))
    load = change_points(good, hop_s, load_rate) if len(good) else []
    load = [(k, change_time(windows, good, k), p) for k, p in load]
    cond = condition_changes(good, assessed, condition_rate)
    found = [(k, _after_gap(t, gaps)[0], p, c) for k, t, p, c in _merged(load, cond)]
    found, unread = unread_changes(found, good, windows)
    rows = np.maximum.accumulate([c[0] for c in found]).tolist() if found else []
    edges = [0, *rows, len(good)]
    times = [c[1] for c in found]
    # the condition's own segments, and the unread runs': a stretch takes its own assessments
    cuts = sorted([t for _, t, _, _ in cond] + list(unread))
    # (an assessment at a cut, the first window an unread run holds, is the run's)
    segment = np.searchsorted(cuts, assessed["start_s"].to_numpy(float), "right") if cuts else None
    frames = [f for f in (good, assessed) if len(f)]
    first = min(float(f["start_s"].iloc[0]) for f in frames)
    bounds = [first, *times, max(float(f["end_s"].iloc[-1]) for f in frames)]

    def answer(part: pd.DataFrame, start_s: float, end_s: float) -> dict:
        """The stretch of ``part``'s windows from ``start_s`` to ``end_s``."""
        s = {"start_s": start_s, "end_s": end_s, **combine_stretch(part, bias_ratio, stretch_model)}
        if len(assessed):  # the assessments of the condition segment holding its middle
            s = {k: v for k, v in s.items() if not k.startswith("condition")}
            j = np.searchsorted(cuts, 0.5 * (start_s + end_s))
            s |= stretch_condition(assessed if segment is None else assessed[segment == j])
        return s | refused_assessments(windows, start_s, end_s)

    stretches = []
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        s = answer(_within(good.iloc[a:b], bounds[i], bounds[i + 1]), bounds[i], bounds[i + 1])
        if faulty_model is not None and s.get("condition") not in (None, HEALTHY):
            # the last stretch runs to the last window the faulty model answers (the last
            # assessment may lie up to a cadence before it, the healthy model refused the rest)
            last = i == len(edges) - 2
            end = float(windows["end_s"].max()) if last else bounds[i + 1]
            pieces, inner = _answered_faulty(
                s, windows, end, faulty_model, (load_rate, answered), bias_ratio, gaps
            )
            stretches += pieces
            found += [(0, t, p, False) for t, p in inner]
            continue
        stretches.append(s)
    found.sort(key=lambda c: c[1])

    def joined(start_s: float, end_s: float) -> dict:
        """The stretch of the windows from ``start_s`` to ``end_s``, with their speeds."""
        part = _within(good, start_s, end_s)
        speeds = part["omega_rad_s"].to_numpy(float) if "omega_rad_s" in part else []
        out = answer(part, start_s, end_s)
        if np.isfinite(speeds).any():
            out["omega_range_rad_s"] = [float(np.nanmin(speeds)), float(np.nanmax(speeds))]
        return out

    stretches, found = _join_speed_changes(stretches, found, joined, load_threshold)
    changes, alarm_list = [], []
    for i, ((_, t, p, cond_changed), before, after) in enumerate(
        zip(found, stretches[:-1], stretches[1:], strict=True)
    ):
        raised = alarms(before, after, t, p, load_threshold, condition=cond_changed)
        moved = _speed_moved(before, after)
        what = "; ".join(a["what"] for a in raised) or _described(before, after)
        if t in unread:
            what = f"{unread[t]}; {what}"
        what += f"; {moved}" if moved else ""
        for a in raised:
            a["change"] = i  # the change between stretches i and i + 1
            a["what"] += f"; {moved}" if moved else ""
        changes.append({"time_s": t, "what": what, "probability": p})
        if gap := _after_gap(t, gaps)[1]:
            changes[-1]["gap_s"] = gap
        alarm_list.extend(raised)
    if gaps is not None:
        for s in stretches:
            s["unobserved_s"] = sum(
                max(0.0, min(b, s["end_s"]) - max(a, s["start_s"])) for a, b in gaps
            )
    return stretches, changes, alarm_list


def _after_gap(time_s: float, gaps) -> tuple[float, list[float] | None]:
    """(``time_s``, or the end of the gap of ``gaps`` it lies in; that gap as [start, end])."""
    for a, b in gaps or ():
        if a < time_s <= b + 1e-9:
            return b, [a, b]
    return time_s, None


def _within(part: pd.DataFrame, start_s: float, end_s: float) -> pd.DataFrame:
    """The windows of a stretch's ``part`` that lie within its bounds: those that straddle a
    change mix two states and are left out of both stretches (all kept if none lies within)."""
    inside = (part["start_s"] >= start_s - 1e-9) & (part["end_s"] <= end_s + 1e-9)
    return part[inside] if inside.any() else part


def _answered_faulty(
    stretch: dict, windows: pd.DataFrame, end_s: float, model, rate: tuple, bias_ratio, gaps=None
) -> tuple[list[dict], list[tuple[float, float]]]:
    """A stretch called faulty, answered by the faulty load-state ``model`` from the windows
    within its bounds (to ``end_s``) that lie in that model's domain and do not overlap: split
    where their estimates change (the healthy model refused most of them, so the record's
    change detector never read them), each piece with the stretch's condition and
    ``load_model`` faulty. ``rate``: (the load state's share of the false-alarm rate, the starts
    of the windows the healthy model answered); the split is tested at that share times the
    part of the windows the healthy model did not answer (the record's detector read those it
    did), so that the false changes of the record stay within its rate. (pieces, [(time of a
    change between two, probability)]); the stretch as it was, and no change, without such
    windows."""
    faulty = non_overlapping(faulty_windows(windows, stretch["start_s"], end_s, model))
    if faulty.empty:
        return [stretch], []
    found = []
    if len(faulty) > 1 and set(DETECTOR_COLUMNS) <= set(faulty.columns):
        hop_s = float(np.median(np.diff(faulty["start_s"].to_numpy(float))))
        fresh = 1.0 - float(faulty["start_s"].isin(rate[1]).mean())
        found = change_points(faulty, hop_s, rate[0] * fresh) if hop_s > 0 else []
    times = [_after_gap(change_time(windows, faulty, k), gaps)[0] for k, _ in found]
    edges = [0, *[k for k, _ in found], len(faulty)]
    bounds = [stretch["start_s"], *times, max(stretch["end_s"], float(faulty["end_s"].max()))]
    condition = {k: v for k, v in stretch.items() if k.startswith("condition")}
    pieces = []
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        answer = combine_stretch(_within(faulty.iloc[a:b], bounds[i], bounds[i + 1]), bias_ratio)
        piece = {"start_s": bounds[i], "end_s": bounds[i + 1], **condition}
        piece |= {k: v for k, v in answer.items() if not k.startswith("condition")}
        pieces.append(piece | {"load_model": "faulty"})
    return pieces, [(t, p) for t, (_, p) in zip(times, found, strict=True)]


def _join_speed_changes(stretches: list, found: list, answer, load_threshold: float):
    """(stretches, changes found) with each change of the load state's features that came with
    a change of speed and is the speed's alone joined into the stretch before it, which
    ``answer(start_s, end_s)`` gives anew: features read at another speed move with it (the
    level falls ~0.4 % from 400 to 600 rad/s at a constant load, the centrifugal force on the
    balls; ~100 times a window's noise), so a run-up at a constant load had been cut every
    ~2 s, and the stretches' regime calls, each on a few seconds, had flipped where the
    signature cannot tell the regimes apart (epsilon 0.45-0.55). The speed's alone
    (:func:`_speed_only`), judged between the two stretches as found and between the stretch
    joined so far and the next (a load that drifts with the speed is cut where it has moved
    past the threshold); not a change of condition, nor of a stretch the faulty model
    answered. A joined stretch lists the times joined (``joined_s``) and its windows' speeds
    (``omega_range_rad_s``)."""
    out, kept = [stretches[0]] if stretches else [], []
    for change, previous, after in zip(found, stretches[:-1], stretches[1:], strict=True):
        before = out[-1]
        faulty = "faulty" in (before.get("load_model"), after.get("load_model"))
        if (
            change[3]
            or faulty
            or not _speed_only(previous, after, change, load_threshold)
            or not _speed_only(before, after, change, load_threshold, moved=False)
        ):
            out.append(after)
            kept.append(change)
            continue
        joined = answer(before["start_s"], after["end_s"])
        joined["joined_s"] = [*before.get("joined_s", []), change[1]]
        out[-1] = joined
    return out, kept


def _speed_only(
    before: dict, after: dict, change: tuple, load_threshold: float, moved: bool = True
) -> bool:
    """Whether a change between two stretches may be the speed's alone: their median speeds
    apart (:func:`_speed_moved`, unless ``moved`` is False), their F_r intervals overlapping
    (the load state the same within what the model tells: a speed column wandering by 0.3 %
    on a constant-speed bench had joined a 3 % load step, its stretch covering neither load),
    and no alarm between them (no load change beyond ``load_threshold``, no change of regime
    between two confident calls)."""
    if moved and _speed_moved(before, after) is None:
        return False
    keys = ("radial_load_n_low", "radial_load_n_high")
    if not all(k in s for s in (before, after) for k in keys):
        return False
    if before[keys[0]] > after[keys[1]] or after[keys[0]] > before[keys[1]]:
        return False
    raised = alarms(before, after, change[1], change[2], load_threshold, condition=False)
    sure = all(s.get("regime_probability", 0.0) >= CONFIDENT_PROBABILITY for s in (before, after))
    return not any(a["kind"] == "load" or sure for a in raised)


def _speed_moved(before: dict, after: dict) -> str | None:
    """The speed's change between two stretches (their windows' median), when beyond
    :data:`SPEED_MOVED_REL`, or None: the features, read at another speed, move with it, so
    what changed there may be the speed alone."""
    a, b = before.get("omega_rad_s"), after.get("omega_rad_s")
    if a is None or b is None or not (a > 0 and abs(b / a - 1.0) > SPEED_MOVED_REL):
        return None
    return f"the speed changed too: {a:.6g} -> {b:.6g} rad/s"


def _described(before: dict, after: dict) -> str:
    """What changed between two stretches that raise no alarm: F_r and epsilon."""
    parts = []
    if "radial_load_n" in before and "radial_load_n" in after:
        rel = after["radial_load_n"] / before["radial_load_n"] - 1.0
        parts.append(
            f"load {before['radial_load_n']:.0f} -> {after['radial_load_n']:.0f} N ({rel:+.1%})"
        )
        parts.append(f"epsilon {before['epsilon']:.3f} -> {after['epsilon']:.3f}")
    return ", ".join(parts or ["no load estimate on one side"]) + " (below the alarm thresholds)"


def alarms(
    before: dict, after: dict, time_s: float, p_change: float, load_threshold: float, condition=True
):
    """The alarms of one change: load beyond the threshold, regime, and the condition where
    ``condition`` (its own detector found the change: the few assessments of a stretch cut by
    a change of load state do not make a change of condition)."""
    out = []
    if "radial_load_n" in before and "radial_load_n" in after:
        rel = after["radial_load_n"] / before["radial_load_n"] - 1.0
        se = math.hypot(before["radial_load_n_se_noise"], after["radial_load_n_se_noise"])
        excess = abs(math.log1p(rel)) - math.log1p(load_threshold)
        p_beyond = float(stats.norm.cdf(excess / se)) if se > 0 else float(excess > 0)
        if abs(rel) >= load_threshold:
            out.append(
                {
                    "time_s": time_s,
                    "kind": "load",
                    "what": f"load {before['radial_load_n']:.0f} -> {after['radial_load_n']:.0f} N "
                    f"({rel:+.1%})",
                    "probability": p_change * p_beyond,
                }
            )
    for name in CLASS_OUTPUTS:
        if name not in before or name not in after or (name == "condition" and not condition):
            continue
        if before[name] != after[name]:
            out.append(
                {
                    "time_s": time_s,
                    "kind": name,
                    "what": f"{name} {before[name]} -> {after[name]}",
                    "probability": p_change * _differ(before, after, name),
                }
            )
    return out


def _differ(before: dict, after: dict, name: str) -> float:
    """The probability that two stretches' classes ``name`` differ, from their probabilities."""
    keys = [k for k in before if k.startswith(f"{name}_probability_")]
    return 1.0 - sum(before[k] * after.get(k, 0.0) for k in keys)


def report_under_prior(
    stretches: list[dict], changes: list[dict], alarms_: list[dict], condition_model, prior
) -> None:
    """Move, in place, the condition probabilities the stretches and the condition alarms
    report from ``condition_model``'s training mix to ``prior`` (a probability of healthy or
    each condition's share: :meth:`~signatelec.estimation.condition.ConditionModel.
    move_to_prior`), once every call, change and warning was made on the training mix (the
    call's false-alarm rate is measured there). A stretch's mean probabilities are moved as
    one posterior (Bayes' rule), its ``condition_probability`` is then its call's; a condition
    alarm's probability is its change's times the probability that the two stretches' moved
    conditions differ, as :func:`alarms` gives it (an alarm's ``change`` i: between stretches
    i and i + 1)."""
    for s in condition_model.move_records(stretches, prior):
        s["condition_probability"] = s[f"{PROBABILITY}{s['condition']}"]
    for a in alarms_:
        if a["kind"] == "condition":
            i = a["change"]
            differ = _differ(stretches[i], stretches[i + 1], "condition")
            a["probability"] = changes[i]["probability"] * differ
