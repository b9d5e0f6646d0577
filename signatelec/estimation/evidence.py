"""Evidence over time: change points in the window estimates, stretch estimates, alarms.

**Change points** (:func:`change_points`): binary segmentation with a Gaussian generalised
likelihood-ratio statistic for a change of mean (Basseville & Nikiforov 1993, *Detection of
Abrupt Changes*, section 2.4; binary segmentation: Vostrikova 1981) on the standardised series
of :func:`detector_series`: log level, log F_r, epsilon, the ripple's first two harmonics and
the log-odds of each class output but the regime (a bearing condition, when the model has
one); the regime follows epsilon and the ripple, and its classifier's log-odds only add their
scatter where a state lies on a regime boundary (a held-out state 1 um from preload split into
spurious zero/preload stretches with them).
The series are whitened with the covariance of their within-stretch residuals and scaled by
their long-run variance (Bartlett window over the residuals' autocorrelation), so that
correlated windows do not pass for independent evidence. The statistic of a split at k of a
segment of n windows, T_k = k (n - k) / n |mean_left - mean_right|^2, is chi^2 with d degrees
of freedom under no change; each candidate split is tested at ``false_alarm_per_hour`` x
hop / 1 h, so that (Bonferroni) at most that many false changes are expected per hour of
trace; a change's ``probability`` is 1 - its Bonferroni-corrected p-value over its segment.
A segmentation runs twice: the first, with the scale of first differences, gives the residuals
the second's whitening and long-run variance are read from. Each change found is then placed
again by the same statistic between its neighbours.

**Stretches** (:func:`combine_stretch`): the windows between two changes. A regression target
(F_r on a log scale, epsilon, clearance) is the mean of the window estimates, a model of the
window means whose error has two parts. The windows' scatter about their mean (noise), divided
by the effective number of independent windows n_eff = n / (1 + 2 sum_k (1 - k / (K + 1))
rho_k) (Bartlett, rho_k their autocorrelation at lag k, K = n^(1/3)): the independence
assumption is checked on the windows themselves, and this part shrinks as the stretch grows.
And the model's own error for that state, which does not shrink (the windows of one state share
it): ``bias_ratio`` times the root-mean-square standard deviation of the windows' intervals
(their width / 2 z90), a ratio per target and per regime the stretch is estimated in,
calibrated by Mondrian split conformal prediction (Vovk, Gammerman, Shafer 2005, ch. 2 and
4.5: the conformal quantile taken within each category of a taxonomy known at prediction time,
here the estimated regime, so that the coverage holds within each regime, not only over their
mix; Lei et al. 2018, JASA 113, 1094) on held-out runs that are not the acceptance records
(:data:`BIAS_RATIO`; ``signatelec study monitor`` measures it). One ratio per target
over-covered in the zero and preload regimes and under-covered in the clearance regime: the
clearance of a zero or preloaded bearing is known more closely, relative to its windows'
intervals, than a clearance is. The two parts add in quadrature: half-width
z90 (b^2 w^2 + s^2 / n_eff)^(1/2). A class output combines the
windows' log-probabilities, each weighted n_eff / n (the same correction for correlation).

**Alarms** (:func:`alarms`): at each change, a load change beyond ``load_threshold`` (with the
probability that the stretches' F_r differ by more, from their scatter parts), a change of
regime or of condition (the probability that the two stretches' classes differ).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import stats

#: The z of a two-sided 90 % normal interval (intervals are combined on this scale).
Z90 = stats.norm.ppf(0.95)
#: The model's error of a state (shared by its windows) in units of the windows' interval
#: standard deviation, per target and estimated regime: Mondrian split-conformal 90 % quantile
#: over the stretches of the calibration records of ``signatelec study monitor`` estimated in
#: that regime (docs/monitor: held-out paper-fidelity DEM states drawn apart from the
#: acceptance records', default model, 0.2 s windows); ``"any"``: over all of them, for a
#: stretch without a regime.
BIAS_RATIO = {
    "radial_load_n": {"any": 0.426, "clearance": 0.670, "preload": 0.423, "zero": 0.196},
    "epsilon": {"any": 0.478, "clearance": 1.002, "preload": 0.560, "zero": 0.078},
    "clearance_m": {"any": 0.527, "clearance": 0.882, "preload": 0.568, "zero": 0.153},
}
#: The category of a stretch without an estimated regime.
ANY_REGIME = "any"
#: Fewest windows on either side of a change.
MIN_SEGMENT = 3
#: Class outputs of the model, each with ``<name>_probability_<class>`` columns.
CLASS_OUTPUTS = ("regime", "condition")
#: Regression targets and the scale they are combined on.
TARGET_SCALES = {"radial_load_n": "log", "epsilon": "linear", "clearance_m": "linear"}
#: Default threshold of a load-change alarm (relative change of F_r).
LOAD_THRESHOLD = 0.05
#: Default expected number of false changes per hour of trace.
FALSE_ALARM_PER_HOUR = 0.1


def class_columns(windows: pd.DataFrame, name: str) -> list[str]:
    prefix = f"{name}_probability_"
    return [c for c in windows.columns if c.startswith(prefix)]


def detector_series(windows: pd.DataFrame) -> np.ndarray:
    """The series the change detector reads, one column each (rows: usable windows)."""
    cols = [np.log(windows["level_mean_ohm"].to_numpy(float))]
    cols.append(np.log(windows["radial_load_n"].to_numpy(float)))
    for name in ("epsilon", "h1_rel", "h2_rel"):
        cols.append(windows[name].to_numpy(float))
    for name in CLASS_OUTPUTS:
        pc = class_columns(windows, name)
        # the regime follows epsilon and the ripple, already here: its classifier's log-odds
        # would add only their heavy-tailed scatter where a state sits between two regimes
        if len(pc) > 1 and name != "regime":
            logp = np.log(np.clip(windows[pc].to_numpy(float), 1e-6, 1.0))
            cols.extend((logp - logp.mean(axis=1, keepdims=True))[:, :-1].T)
    return np.column_stack(cols)


def _robust_scale(x: np.ndarray) -> np.ndarray:
    """Per column: sigma from the MAD of first differences (a step moves one difference); for
    a column that is piecewise constant (a classifier's output takes few values), the standard
    deviation of its differences; 1 for a constant column."""
    d = np.diff(x, axis=0)
    s = 1.4826 * np.median(np.abs(d - np.median(d, axis=0)), axis=0) / math.sqrt(2.0)
    s = np.where(s > 0, s, d.std(axis=0) / math.sqrt(2.0))
    return np.where(s > 0, s, 1.0)


#: Smallest variance of a whitened direction, in units of the standardised series: a series
#: constant within every stretch (a saturated classifier) keeps its steps as evidence.
MIN_VARIANCE = 1e-3


def effective_fraction(x: np.ndarray) -> float:
    """n_eff / n of a series: 1 / (1 + 2 sum_k (1 - k / (K + 1)) rho_k), K = n^(1/3), at most 1."""
    x = np.asarray(x, float)
    n = x.size
    if n < 4:
        return 1.0
    e = x - x.mean()
    var = float(e @ e) / n
    if var <= 0:
        return 1.0
    lags = max(1, int(round(n ** (1.0 / 3.0))))
    acc = 0.0
    for k in range(1, min(lags, n - 1) + 1):
        # + 1 / n: the sample autocorrelation of an independent series is biased by -1 / n
        # (its mean is removed; Kendall & Stuart 1983, vol. 3, eq. 48.3)
        rho = float(e[:-k] @ e[k:]) / (n * var) + 1.0 / n
        acc += (1.0 - k / (lags + 1.0)) * rho
    return float(min(1.0, max(1.0 / n, 1.0 / (1.0 + 2.0 * acc))))


def _best_split(cum: np.ndarray, a: int, b: int) -> tuple[int, float]:
    """(k, T_k) of the largest GLR statistic over splits of [a, b) (whitened series)."""
    n = b - a
    ks = np.arange(a + MIN_SEGMENT, b - MIN_SEGMENT + 1)
    if ks.size == 0:
        return -1, 0.0
    left = cum[ks] - cum[a]
    total = cum[b] - cum[a]
    nl = (ks - a)[:, None].astype(float)
    diff = left / nl - (total - left) / (n - nl)
    t = (nl[:, 0] * (n - nl[:, 0]) / n) * np.einsum("ij,ij->i", diff, diff)
    i = int(np.argmax(t))
    return int(ks[i]), float(t[i])


def _segment(z: np.ndarray, alpha_per_split: float) -> list[tuple[int, float]]:
    """Binary segmentation of a whitened series: [(index, p-value)] of the changes."""
    n, d = z.shape
    cum = np.vstack([np.zeros(d), np.cumsum(z, axis=0)])
    found, todo = [], [(0, n)]
    threshold = stats.chi2.isf(alpha_per_split, d)
    while todo:
        a, b = todo.pop()
        k, t = _best_split(cum, a, b)
        if k < 0 or t <= threshold:
            continue
        p = min(1.0, (b - a - 1) * stats.chi2.sf(t, d))
        found.append((k, p))
        todo += [(a, k), (k, b)]
    found.sort()
    # place each change again between its neighbours (binary segmentation's first splits
    # see several changes at once)
    edges = [0] + [k for k, _ in found] + [n]
    placed = []
    for i, (_, p) in enumerate(found):
        k, t = _best_split(cum, edges[i], edges[i + 2])
        if k > 0:
            edges[i + 1] = k
            p = min(p, min(1.0, (edges[i + 2] - edges[i] - 1) * stats.chi2.sf(t, d)))
        placed.append((edges[i + 1], p))
    return placed


def _whiten(x: np.ndarray, changes: list[int]) -> np.ndarray:
    """Whiten standardised series with the covariance of their within-segment residuals (each
    direction's variance at least :data:`MIN_VARIANCE`), and divide by the square root of
    their long-run variance factor (the median over columns of n / n_eff)."""
    edges = [0, *changes, x.shape[0]]
    res = np.vstack(
        [x[a:b] - x[a:b].mean(axis=0) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]
    )
    cov = np.cov(res, rowvar=False) if res.shape[0] > res.shape[1] + 1 else None
    if cov is None or not np.all(np.isfinite(cov)):
        return x
    cov = np.atleast_2d(cov)
    w, v = np.linalg.eigh(cov)
    w = np.maximum(w, MIN_VARIANCE)
    white = x @ v / np.sqrt(w)
    wres = res @ v / np.sqrt(w)
    factor = np.median([1.0 / effective_fraction(wres[:, j]) for j in range(wres.shape[1])])
    return white / math.sqrt(factor)


def change_points(
    windows: pd.DataFrame, hop_s: float, false_alarm_per_hour: float = FALSE_ALARM_PER_HOUR
) -> list[tuple[int, float]]:
    """[(row of ``windows`` where a new stretch starts, probability)] (module docstring);
    ``windows`` holds the usable windows only, in time order."""
    x = detector_series(windows)
    ok = np.all(np.isfinite(x), axis=1)
    x = x[ok]
    rows = np.flatnonzero(ok)
    if x.shape[0] < 2 * MIN_SEGMENT:
        return []
    alpha = min(0.5, false_alarm_per_hour * hop_s / 3600.0)
    z = x / _robust_scale(x)
    first = _segment(z, alpha)
    second = _segment(_whiten(z, [k for k, _ in first]), alpha)
    return [(int(rows[k]), 1.0 - p) for k, p in second]


def combine_target(values, low, high, log: bool, bias_ratio: float) -> dict:
    """Mean of the window estimates with its interval (module docstring): ``value``, ``low``,
    ``high``, ``se_noise`` (the noise part's standard error), ``n_eff`` and ``window_sd`` (the
    windows' interval standard deviation, which ``bias_ratio`` multiplies), the last two on
    the combining scale (log for ``log``)."""
    y = np.asarray(values, float)
    lo, hi = np.asarray(low, float), np.asarray(high, float)
    if log:
        y, lo, hi = np.log(y), np.log(lo), np.log(hi)
    n = y.size
    n_eff = max(1.0, effective_fraction(y) * n)
    scatter2 = float(np.var(y, ddof=1)) if n > 1 else 0.0
    window_sd = math.sqrt(float(np.mean(((hi - lo) / (2.0 * Z90)) ** 2)))
    centre = float(y.mean())
    se_noise = math.sqrt(scatter2 / n_eff)
    half = Z90 * math.hypot(bias_ratio * window_sd, se_noise)
    out = {"value": centre, "low": centre - half, "high": centre + half}
    if log:
        out = {k: math.exp(v) for k, v in out.items()}
    return {**out, "se_noise": se_noise, "n_eff": n_eff, "window_sd": window_sd}


def combine_classes(windows: pd.DataFrame, name: str) -> dict[str, float] | None:
    """Class probabilities of a stretch: windows' log-probabilities summed, weighted n_eff / n."""
    pc = class_columns(windows, name)
    if not pc:
        return None
    logp = np.log(np.clip(windows[pc].to_numpy(float), 1e-12, 1.0))
    top = int(np.argmax(logp.sum(axis=0)))
    others = np.delete(logp, top, axis=1)
    margin = logp[:, top] - (others.max(axis=1) if others.size else 0.0)
    weight = effective_fraction(margin) if len(logp) > 1 else 1.0
    z = weight * logp.sum(axis=0)
    z -= z.max()
    p = np.exp(z) / np.exp(z).sum()
    return {c.removeprefix(f"{name}_probability_"): float(q) for c, q in zip(pc, p, strict=True)}


def combine_stretch(windows: pd.DataFrame, bias_ratio: dict | None = None) -> dict:
    """One stretch's estimate from its usable windows (``bias_ratio``: per target, per
    estimated regime and :data:`ANY_REGIME`; default :data:`BIAS_RATIO`)."""
    ratios = BIAS_RATIO if bias_ratio is None else bias_ratio
    out: dict = {"n_windows": int(len(windows))}
    classes = {}
    for name in CLASS_OUTPUTS:
        probs = combine_classes(windows, name)
        if probs:
            best = max(probs, key=probs.get)
            classes[name] = best
            classes[f"{name}_probability"] = probs[best]
            classes.update({f"{name}_probability_{k}": v for k, v in probs.items()})
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
        )
        out[target] = c["value"]
        out[f"{target}_low"] = c["low"]
        out[f"{target}_high"] = c["high"]
        for part in ("se_noise", "n_eff", "window_sd"):
            out[f"{target}_{part}"] = c[part]
    return {**out, **classes}


def usable(windows: pd.DataFrame) -> pd.DataFrame:
    """The windows with an estimate (status ``ok``), in time order."""
    if "status" not in windows or "radial_load_n" not in windows:
        return windows.iloc[0:0]
    good = windows[(windows["status"] == "ok") & windows["radial_load_n"].notna()]
    return good.sort_values("start_s").reset_index(drop=True)


def _material(before: dict, after: dict, load_threshold: float) -> float:
    """How far two stretches differ in what a change is reported for: |log F_r ratio| over
    log(1 + load_threshold) (>= 1 when beyond it), or 1 + the probability that a class
    output differs when its most probable class does (0 when nothing counts)."""
    score = 0.0
    if "radial_load_n" in before:
        ratio = abs(math.log(after["radial_load_n"] / before["radial_load_n"]))
        score = ratio / math.log1p(load_threshold)
    for name in CLASS_OUTPUTS:
        if before.get(name) is not None and before.get(name) != after.get(name):
            keys = [k for k in before if k.startswith(f"{name}_probability_")]
            differ = 1.0 - sum(before[k] * after.get(k, 0.0) for k in keys)
            if differ >= 0.5:
                score = max(score, 1.0 + differ)
    return score


def change_time(windows: pd.DataFrame, good: pd.DataFrame, k: int) -> float:
    """When the state changed between usable windows k - 1 and k: from a window that straddles
    the change, whose mean level mixes the two stretches' levels L1, L2 in proportion to the
    time spent in each (L = f L1 + (1 - f) L2: t = start + f x window); else the start of the
    window k."""
    before = good["level_mean_ohm"].iloc[max(0, k - 3) : k].to_numpy(float)
    after = good["level_mean_ohm"].iloc[k : k + 3].to_numpy(float)
    fallback = float(good["start_s"].iloc[k])
    l1, l2 = float(np.median(before)), float(np.median(after))
    spread = max(np.ptp(before), np.ptp(after), 1e-12)
    if abs(l1 - l2) < 10.0 * spread:
        return fallback
    lo, hi = float(good["start_s"].iloc[k - 1]), float(good["end_s"].iloc[k])
    near = windows[(windows["start_s"] >= lo) & (windows["end_s"] <= hi)]
    near = near[np.isfinite(near.get("level_mean_ohm", pd.Series(dtype=float)))]
    best, best_t = 0.5, fallback
    for _, w in near.iterrows():
        f = (float(w["level_mean_ohm"]) - l2) / (l1 - l2)
        if 0.02 < f < 0.98 and abs(f - 0.5) <= best:
            best, best_t = abs(f - 0.5), float(w["start_s"]) + f * float(w["end_s"] - w["start_s"])
    return best_t


def stretches_and_changes(
    windows: pd.DataFrame,
    hop_s: float,
    false_alarm_per_hour: float = FALSE_ALARM_PER_HOUR,
    load_threshold: float = LOAD_THRESHOLD,
    bias_ratio: dict | None = None,
) -> tuple[list[dict], list[dict], list[dict]]:
    """(stretches, changes, alarms) of a window table (module docstring). A change point
    whose two sides differ neither in F_r by ``load_threshold`` nor in a class output (a
    drift, a state whose windows scatter more than the others') is merged away, the least
    material first. ``bias_ratio``: as :func:`combine_stretch`'s."""
    good = usable(windows)
    if good.empty:
        return [], [], []
    cps = change_points(good, hop_s, false_alarm_per_hour)
    edges = [0] + [k for k, _ in cps] + [len(good)]
    prob = {k: p for k, p in cps}
    while True:
        parts = [good.iloc[a:b] for a, b in zip(edges[:-1], edges[1:], strict=True)]
        combined = [combine_stretch(p) for p in parts]
        scores = [
            _material(x, y, load_threshold)
            for x, y in zip(combined[:-1], combined[1:], strict=True)
        ]
        if not scores or min(scores) >= 1.0:
            break
        del edges[1 + int(np.argmin(scores))]
    times = [change_time(windows, good, k) for k in edges[1:-1]]
    bounds = [float(good["start_s"].iloc[0]), *times, float(good["end_s"].iloc[-1])]
    stretches = []
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
        part = good.iloc[a:b]
        # windows that straddle a change mix two states: left out of both stretches
        inside = (part["start_s"] >= bounds[i] - 1e-9) & (part["end_s"] <= bounds[i + 1] + 1e-9)
        if inside.sum() >= 1:
            part = part[inside]
        s = {"start_s": bounds[i], "end_s": bounds[i + 1]}
        s.update(combine_stretch(part, bias_ratio))
        stretches.append(s)
    changes, alarm_list = [], []
    for k, t, before, after in zip(edges[1:-1], times, stretches[:-1], stretches[1:], strict=True):
        p = prob.get(k, 1.0)
        found = alarms(before, after, t, p, load_threshold)
        changes.append({"time_s": t, "what": "; ".join(a["what"] for a in found), "probability": p})
        alarm_list.extend(found)
    return stretches, changes, alarm_list


def alarms(before: dict, after: dict, time_s: float, p_change: float, load_threshold: float):
    """The alarms of one change: load beyond the threshold, regime, condition."""
    out = []
    if "radial_load_n" in before:
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
        if name not in before or name not in after:
            continue
        keys = [k for k in before if k.startswith(f"{name}_probability_")]
        same = sum(before[k] * after.get(k, 0.0) for k in keys)
        if before[name] != after[name]:
            out.append(
                {
                    "time_s": time_s,
                    "kind": name,
                    "what": f"{name} {before[name]} -> {after[name]}",
                    "probability": p_change * (1.0 - same),
                }
            )
    return out
