"""Change points of a monitored record: where its windows' estimates change, and when.

**Change points** (:func:`change_points`): binary segmentation with a Gaussian generalised
likelihood-ratio statistic for a change of mean (Basseville & Nikiforov 1993, *Detection of
Abrupt Changes*, section 2.4; binary segmentation: Vostrikova 1981) on the series of
:func:`detector_series`: log level, log F_r, epsilon, the ripple's first two harmonics (the
regime follows epsilon and the ripple; its classifier's log-odds only added their scatter where
a state lies on a regime boundary: a held-out state 1 um from preload split into spurious
zero/preload stretches with them). The bearing's condition, assessed on fewer windows, is a
series of its own, segmented alike at its cadence (:mod:`~signatelec.estimation.health`); the
record's false-alarm rate is shared between the two series (:func:`rate_shares`).
Each window has a precision of its own, P_i = D_i^(-1/2) R^(-1) D_i^(-1/2): D_i the local
variance of each series (:func:`_local_variance`: residuals about a running median, which
follows the majority side of a step, averaged over a few seconds) and R their correlation over
the record. The model's outputs scatter very differently from one state to another (epsilon's
window-to-window standard deviation spans 17x over the DEM states of the monitoring study's
design bank, log F_r 7x; the log level and harmonics, set by the noise, within 1.3x):
one variance pooled over a record read the windows of a noisy state as changes (8 spurious
changes in 40 design records; docs/monitor/change_detection.md). The statistic of a
split at k compares the precision-weighted means of the two sides, T_k = (m_L - m_R)'
(A^-1 + B^-1)^-1 (m_L - m_R), A and B the sums of the sides' precisions: under no change,
approximately Hotelling's T^2 with as many degrees of freedom as the segment has windows less
one (the precisions are estimated from scatter; :func:`_tail`), chi^2 with d degrees of
freedom on long segments (read as chi^2, records of 20 independent windows had 80 times
the nominal rate of false changes; the condition's sparse series keeps chi^2, ``hotelling``
of :func:`change_points`); each candidate split is tested at
``false_alarm_per_hour`` x hop / 1 h, so that (Bonferroni) at most that many false changes are
expected per hour of trace; a change's ``probability`` is 1 - its Bonferroni-corrected p-value
over its segment.
A segmentation runs twice: the second reads the local variances within the first's segments
and divides T by the long-run variance factor of the residuals (Bartlett window over their
autocorrelation; ~1 on the DEM records: their windows are independent), so that correlated
windows do not pass for independent evidence. Each change found is then placed again by the
same statistic between its neighbours. Every change point is reported; :func:`alarms` says
which are material.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numba import njit
from scipy import stats

from signatelec.measurement.traces import true_runs

#: Fewest windows on either side of a change.
MIN_SEGMENT = 3
#: Default expected number of false changes per hour of trace.
FALSE_ALARM_PER_HOUR = 0.1


#: The window columns the change detector reads (:func:`detector_series`).
DETECTOR_COLUMNS = ("level_mean_ohm", "radial_load_n", "epsilon", "h1_rel", "h2_rel")


def detector_series(windows: pd.DataFrame) -> np.ndarray:
    """The series the change detector reads, one column each (rows: usable windows): the log
    of the level and of F_r, epsilon and the first two ripple harmonics
    (:data:`DETECTOR_COLUMNS`)."""
    cols = [windows[name].to_numpy(float) for name in DETECTOR_COLUMNS]
    cols[0], cols[1] = np.log(cols[0]), np.log(cols[1])
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
#: constant within every stretch (a saturated classifier's) keeps its steps as evidence.
MIN_VARIANCE = 1e-3
#: Half-width, in windows, of the neighbourhood a window's local scatter is averaged over
#: (:func:`_local_variance`; 4.2 s at 0.2 s windows).
SCATTER_HALF_WIDTH = 10
#: Mean of the squared residuals about a running median of 7, averaged over 21 windows, over
#: sigma^2, such that the precision it gives is unbiased on independent Gaussian windows
#: (1 / E[sigma^2 / v], measured on 400 000 white-noise windows: 0.807; the residuals' own
#: mean square is 0.925 sigma^2, the median being correlated with its centre).
LOCAL_PRECISION_FACTOR = 0.807
#: Smallest local variance of a series relative to its median over the record.
LOCAL_FLOOR = 0.1


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


def _scatter(seg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mean square, residual) of one segment's windows (:func:`_local_variance`)."""
    from scipy.ndimage import median_filter

    h, n = MIN_SEGMENT, seg.shape[0]
    m = median_filter(seg, size=(2 * h + 1, 1), mode="nearest")
    m[:h] = np.median(seg[: 2 * h + 1], axis=0)
    m[-h:] = np.median(seg[-(2 * h + 1) :], axis=0)
    r = seg - m
    cum = np.vstack([np.zeros(seg.shape[1]), np.cumsum(r**2, axis=0)])
    # the neighbourhood is shifted, not cut, at the segment's ends: as many residuals
    # everywhere (fewer would overstate the precision, 1 / v being convex)
    width = min(2 * SCATTER_HALF_WIDTH + 1, n)
    lo = np.clip(np.arange(n) - SCATTER_HALF_WIDTH, 0, n - width)
    return (cum[lo + width] - cum[lo]) / width, r


def _local_variance(z: np.ndarray, edges: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(variance, residual) per window and series: the scatter about the current state's level.
    The residuals are about a running median of 2 :data:`MIN_SEGMENT` + 1 windows (which
    follows the majority side of a step, so that a change does not read as scatter; the first
    and last windows take the median of the first or last 2 :data:`MIN_SEGMENT` + 1), squared
    and averaged over the 2 :data:`SCATTER_HALF_WIDTH` + 1 windows around, over
    :data:`LOCAL_PRECISION_FACTOR`; within each segment of ``edges`` (one that holds fewer
    windows takes the larger of its own and the record's: a few windows' own scatter is a
    noisy and, 1 / v being convex, overstated precision); at least :data:`LOCAL_FLOOR` of the
    series' median local variance over the record (a series clipped at zero, such as a
    harmonic below the noise, can sit still for many windows) and at least
    :data:`MIN_VARIANCE`."""
    whole, r = _scatter(z)
    var = whole.copy()
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        if b - a < z.shape[0]:
            var[a:b], r[a:b] = _scatter(z[a:b])
            if b - a < 2 * SCATTER_HALF_WIDTH + 1:
                var[a:b] = np.maximum(var[a:b], whole[a:b])
    var /= LOCAL_PRECISION_FACTOR
    floor = np.maximum(LOCAL_FLOOR * np.median(var, axis=0), MIN_VARIANCE)
    return np.maximum(var, floor), r


def _precisions(z: np.ndarray, edges: list[int]) -> np.ndarray:
    """(n, d, d) precision of each window: D_i^(-1/2) R^(-1) D_i^(-1/2), D_i its series' local
    variances (:func:`_local_variance` within the segments of ``edges``), R the correlation of
    the locally standardised residuals over the record (eigenvalues at least
    :data:`MIN_VARIANCE`)."""
    var, r = _local_variance(z, edges)
    s = 1.0 / np.sqrt(var)
    u = r * s
    sd = u.std(axis=0)
    # a series without scatter (a saturated classifier) is uncorrelated with the others
    u = np.divide(u - u.mean(axis=0), sd, out=np.zeros_like(u), where=sd > 0)
    corr = u.T @ u / u.shape[0]
    corr[np.diag_indices_from(corr)] = 1.0
    w, v = np.linalg.eigh(corr)
    inv = (v / np.maximum(w, MIN_VARIANCE)) @ v.T
    return s[:, :, None] * inv[None] * s[:, None, :]


@njit(cache=True, error_model="numpy")
def _quadratic(cum_p, cum_px, a: int, b: int, lo: np.ndarray) -> float:
    """s' M^-1 s for M = cum_p[b] - cum_p[a] (symmetric positive definite, d x d) and
    s = cum_px[b] - cum_px[a]: |y|^2 with L y = s, M = L L' (Cholesky; Golub & Van Loan 2013,
    alg. 4.2.1), in the work array ``lo`` (d x (d + 1): L, and y in its last column);
    -inf when M is not positive definite."""
    d = cum_px.shape[1]
    total = 0.0
    for i in range(d):
        for j in range(i + 1):
            acc = cum_p[b, i, j] - cum_p[a, i, j]
            for q in range(j):
                acc -= lo[i, q] * lo[j, q]
            if i == j:
                if acc <= 0.0:
                    return -math.inf
                lo[i, i] = math.sqrt(acc)
            else:
                lo[i, j] = acc / lo[j, j]
        acc = cum_px[b, i] - cum_px[a, i]
        for q in range(i):
            acc -= lo[i, q] * lo[q, d]
        lo[i, d] = acc / lo[i, i]
        total += lo[i, d] * lo[i, d]
    return total


@njit(cache=True, error_model="numpy")
def _best_split(cum_p, cum_px, a: int, b: int, min_segment: int) -> tuple[int, float]:
    """(k, T_k) of the largest GLR statistic over splits of [a, b) with at least
    ``min_segment`` windows a side, (-1, 0) when there is none: T_k = (m_L - m_R)'
    (A^-1 + B^-1)^-1 (m_L - m_R), m_L and m_R the precision-weighted means of the two sides and
    A and B the sums of their precisions (chi^2 with d degrees of freedom under no change),
    computed as the weighted residual sum of squares that the split removes,
    s_L' A^-1 s_L + s_R' B^-1 s_R - s' (A + B)^-1 s (s_L, s_R the sides' precision-weighted
    sums; the same number: both are twice the log-likelihood ratio of a change of mean at k)."""
    d = cum_px.shape[1]
    lo = np.zeros((d, d + 1))
    whole = _quadratic(cum_p, cum_px, a, b, lo)
    best_k, best_t = -1, 0.0
    for k in range(a + min_segment, b - min_segment + 1):
        t = _quadratic(cum_p, cum_px, a, k, lo) + _quadratic(cum_p, cum_px, k, b, lo) - whole
        # a sum of precisions that rounding left not positive definite gives no statistic
        if math.isfinite(t) and (best_k < 0 or t > best_t):
            best_k, best_t = k, t
    return best_k, best_t


def _segment(
    p: np.ndarray, z: np.ndarray, alpha_per_split: float, factor: float = 1.0, hotelling=True
):
    """Binary segmentation of series ``z`` with window precisions ``p`` (the statistic divided
    by the long-run variance ``factor``; its tail Hotelling's, else chi^2): [(index, p-value)]
    of the changes."""
    n, d = z.shape
    cum_p = np.concatenate([np.zeros((1, d, d)), np.cumsum(p, axis=0)])
    cum_px = np.vstack([np.zeros(d), np.cumsum(np.einsum("kij,kj->ki", p, z), axis=0)])

    def best(a, b):
        k, t = _best_split(cum_p, cum_px, a, b, MIN_SEGMENT)
        return k, t / factor

    def tail(a, b, t):
        """P(T > t) of a split of [a, b) under no change."""
        return _tail(t, d, b - a - 1 if hotelling else math.inf)

    def p_value_of(a, b, t):
        """The split's p-value, Bonferroni-corrected over the b - a - 1 splits of [a, b)."""
        return min(1.0, (b - a - 1) * tail(a, b, t))

    found, todo = [], [(0, n)]
    while todo:
        a, b = todo.pop()
        k, t = best(a, b)
        if k < 0 or not tail(a, b, t) < alpha_per_split:
            continue
        found.append((k, p_value_of(a, b, t)))
        todo += [(a, k), (k, b)]
    found.sort()
    # place each change again between its neighbours (binary segmentation's first splits
    # see several changes at once)
    edges = [0] + [k for k, _ in found] + [n]
    placed = []
    for i, (_, p_value) in enumerate(found):
        k, t = best(edges[i], edges[i + 2])
        if k > 0:
            edges[i + 1] = k
            p_value = min(p_value, p_value_of(edges[i], edges[i + 2], t))
        placed.append((edges[i + 1], p_value))
    return placed


def _tail(t: float, d: int, nu: float) -> float:
    """P(T > t) of the statistic of a split of a segment of nu + 1 windows under no change:
    Hotelling's T^2 with nu degrees of freedom, (nu - d + 1) / (d nu) T ~ F(d, nu - d + 1)
    (Anderson 2003, *An Introduction to Multivariate Statistical Analysis*, section 5.2), exact
    for a covariance estimated from the segment's own windows. Here each window's comes from
    the scatter of its neighbours (at most 2 SCATTER_HALF_WIDTH + 1 windows): an approximation
    that tends to chi^2(d) (nu infinite) on long segments, checked on independent Gaussian
    windows (records of 20, 40 and 100 windows within their nominal rate,
    tests/test_monitor.py); 1 when nu < d."""
    if nu < d:
        return 1.0
    if math.isinf(nu):
        return float(stats.chi2.sf(t, d))
    return float(stats.f.sf(t * (nu - d + 1) / (d * nu), d, nu - d + 1))


def _long_run_factor(p: np.ndarray, z: np.ndarray, changes: list[int]) -> float:
    """The median over whitened directions of n / n_eff of the residuals about the segments'
    weighted means (:func:`effective_fraction`): correlated windows are not independent
    evidence."""
    edges = [0, *changes, z.shape[0]]
    res = np.empty_like(z)
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        m = np.linalg.solve(p[a:b].sum(axis=0), np.einsum("kij,kj->i", p[a:b], z[a:b]))
        res[a:b] = z[a:b] - m
    # whiten each window with its own precision (Cholesky factor: u' u = r' P r)
    chol = np.linalg.cholesky(p)
    u = np.einsum("kji,kj->ki", chol, res)
    return float(np.median([1.0 / effective_fraction(u[:, j]) for j in range(u.shape[1])]))


def rate_shares(false_alarm_per_hour: float, *lengths: int) -> list[float]:
    """The record's ``false_alarm_per_hour`` shared among its change series (the load state's
    windows, the condition's assessments; ``lengths``: each one's number of rows): equal
    shares among those long enough to hold a change (2 :data:`MIN_SEGMENT` rows), none to the
    others, so that (Bonferroni over the series) the false changes of the whole record stay
    within the rate, not within the rate for each series."""
    can = [n >= 2 * MIN_SEGMENT for n in lengths]
    share = false_alarm_per_hour / max(1, sum(can))
    return [share if c else 0.0 for c in can]


def change_points(
    windows: pd.DataFrame,
    hop_s: float,
    false_alarm_per_hour: float = FALSE_ALARM_PER_HOUR,
    series: np.ndarray | None = None,
    hotelling: bool = True,
) -> list[tuple[int, float]]:
    """[(row of ``windows`` where a new stretch starts, probability)] (module docstring);
    ``windows`` holds the usable windows only, in time order, ``hop_s`` apart; ``series``:
    one row per window, instead of :func:`detector_series`; ``hotelling``: the statistic's
    tail Hotelling's T^2 (:func:`_tail`), else chi^2."""
    x = detector_series(windows) if series is None else series
    ok = np.all(np.isfinite(x), axis=1)
    x = x[ok]
    rows = np.flatnonzero(ok)
    if x.shape[0] < 2 * MIN_SEGMENT or false_alarm_per_hour <= 0.0:
        return []
    alpha = min(0.5, false_alarm_per_hour * hop_s / 3600.0)
    z = x / _robust_scale(x)
    z -= np.median(z, axis=0)
    p = _precisions(z, [0, z.shape[0]])
    first = [k for k, _ in _segment(p, z, alpha, hotelling=hotelling)]
    # the second pass reads each window's scatter within its first-pass segment
    p = _precisions(z, [0, *first, z.shape[0]])
    second = _segment(p, z, alpha, _long_run_factor(p, z, first), hotelling)
    return [(int(rows[k]), 1.0 - p_value) for k, p_value in second]


#: Shortest run of consecutive windows out of the load model's domain that can be a span of its
#: own (:func:`unread_changes`), s: a spall's pulses or a state the model never learnt keep
#: every window out; a state at the domain's edge whose windows fall out of it half the time
#: stays out for 5 s (25 windows of 0.2 s) once in ~3e7 windows.
UNREAD_MIN_S = 5.0
#: Largest share of a segment's other windows out of the domain beside such a run: a spall
#: whose windows fall in and out of the domain (runs of 5-20 s, by how its pulses fall in
#: them) leaves many, and its segment is one state the load model reads in part.
UNREAD_OTHER_SHARE = 0.1
#: What the changes at the ends of such a run say.
LOST = "the load model cannot read the windows from here (out of its domain)"
READ = "the load model reads the windows again"


def unread_changes(found: list, good: pd.DataFrame, windows: pd.DataFrame):
    """(changes, {time: what}): the changes ``found`` [(row of the usable windows ``good`` where
    the next stretch starts, time, probability, whether the condition changed)] with one at
    each end of a run of windows the load model cannot read (status "out of domain") of at
    least :data:`UNREAD_MIN_S` and 2 :data:`MIN_SEGMENT` windows, the only such run of its
    segment between two changes, whose other windows are read (at most
    :data:`UNREAD_OTHER_SHARE` of them out of the domain), in time order; an end within a
    window of the segment's own change is that change. The change detector reads the usable
    windows only, and a stretch had spanned a spall that took every window out of the domain,
    with the load state of the windows before it and the condition of the assessments of both.
    Each such change has probability 1 (the windows' status, not a statistic) and is a change
    of condition too, whose alarm the two sides' assessments raise where their calls differ."""
    if good.empty or "status" not in windows:
        return found, {}
    w = windows.sort_values("start_s")
    out = w["status"].astype(str).str.startswith("out of domain").to_numpy()
    if not out.any():
        return found, {}
    start, end = w["start_s"].to_numpy(float), w["end_s"].to_numpy(float)
    window = float(np.median(end - start))
    runs = [
        (float(start[a]), float(end[b - 1]))
        for a, b in true_runs(out)
        if b - a >= 2 * MIN_SEGMENT and end[b - 1] - start[a] >= UNREAD_MIN_S
    ]
    found = sorted(found, key=lambda c: c[1])
    bounds = [-math.inf, *(c[1] for c in found), math.inf]
    good_start = good["start_s"].to_numpy(float)
    added, unread = [], {}
    for i, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:], strict=True)):
        inside = [r for r in runs if lo - window < r[0] and r[1] < hi + window]
        if len(inside) != 1:
            continue
        a, b = inside[0]
        segment = (start >= lo - 1e-9) & (end <= hi + 1e-9)
        others = segment & ((end <= a + 1e-9) | (start >= b - 1e-9))
        if others.any() and out[others].mean() > UNREAD_OTHER_SHARE:
            continue
        ends = ((a, i - 1, lo, end <= a + 1e-9, LOST), (b, i, hi, start >= b - 1e-9, READ))
        for t, j, bound, side, what in ends:
            if abs(t - bound) <= window + 1e-9:  # at the segment's change: it holds the run's end
                if 0 <= j < len(found):
                    found[j] = (*found[j][:3], True)
                    unread[found[j][1]] = what
            elif (segment & side).any():
                added.append((int(np.searchsorted(good_start, t - 1e-9)), t, 1.0, True))
                unread[t] = what
    return sorted([*found, *added], key=lambda c: c[1]), unread


def change_time(windows: pd.DataFrame, good: pd.DataFrame, k: int) -> float:
    """When the state changed between usable windows k - 1 and k: from a window that straddles
    the change, whose mean level mixes the two stretches' levels L1, L2 in proportion to the
    time spent in each (L = f L1 + (1 - f) L2: t = start + f x window; a window wholly between
    the two, left out as out of the model's domain, straddles it: its f is clipped to [0, 1],
    a change in its first or last 2 % of the window being at its start or end); else (the two
    levels too close to tell) the middle of the time between the two windows, or the start of
    window k when they touch."""
    before = good["level_mean_ohm"].iloc[max(0, k - 3) : k].to_numpy(float)
    after = good["level_mean_ohm"].iloc[k : k + 3].to_numpy(float)
    end_before, start_after = float(good["end_s"].iloc[k - 1]), float(good["start_s"].iloc[k])
    fallback = 0.5 * (end_before + start_after) if start_after > end_before else start_after
    l1, l2 = float(np.median(before)), float(np.median(after))
    spread = max(np.ptp(before), np.ptp(after), 1e-12)
    if abs(l1 - l2) < 10.0 * spread:
        return fallback
    lo, hi = float(good["start_s"].iloc[k - 1]), float(good["end_s"].iloc[k])
    if "level_mean_ohm" not in windows:
        return fallback
    # the few windows between the two, as arrays (a frame's boolean selection copies every
    # column: ~5 ms a change on an hour's table)
    start, end = windows["start_s"].to_numpy(float), windows["end_s"].to_numpy(float)
    level = windows["level_mean_ohm"].to_numpy(float)
    near = np.flatnonzero((start >= lo) & (end <= hi) & np.isfinite(level))
    best, best_t = 0.5, fallback
    for i in near:
        f = (level[i] - l2) / (l1 - l2)
        if start[i] >= end_before - 1e-9 and end[i] <= start_after + 1e-9:
            f = min(1.0, max(0.0, f))
        elif not 0.02 < f < 0.98:
            continue
        if abs(f - 0.5) <= best:
            best, best_t = abs(f - 0.5), float(start[i] + f * (end[i] - start[i]))
    return best_t
