"""False alarms of the condition model with statistical weight, and the load state beside a
defect: two parts of the diagnosis study (:mod:`signatelec.studies.diagnosis`).

**False alarms.** A false-alarm rate of at most 1 % cannot be shown on a few dozen runs: with
none of n runs flagged, the one-sided 95 % upper bound on the rate is 1 - 0.05^(1/n) (about
3/n, the "rule of three"), below 1 % only from n = 299.
:func:`signatelec.studies.diagnosis.alarm_predictions` generates
:data:`~signatelec.studies.diagnosis.ALARM_RUNS` held-out healthy runs per bearing (the seed's
and the 6205; F_r, clearance, speed and ball phase drawn from the training design's ranges
with their own seed; the paper's fidelity, 0.2 s at 20 kHz, through the ensemble kernel),
measures each once over its whole window at the acceptance condition (0.2 % white noise,
0.05 % drift, its own noise draw) and asks the condition model. The unit is the run: each is an
independent draw of the load state, the clearance, the speed, the phase and the noise, where
windows of one run are not. :func:`alarm_figures` counts the runs flagged (called anything but
healthy) and gives the exact one-sided upper bound of :func:`clopper_pearson_upper`.

**Load state with a defect.** :func:`load_error_figures` gives the F_r MAPE of the default
load-state model per condition with a bootstrap 95 % interval over the held-out runs (runs
resampled, each run's windows kept together), and whether a spall's MAPE stays within the
healthy one: its interval overlaps the healthy interval or lies below it, and its point value
exceeds the healthy one by no more than the healthy interval's half-width (the requirement is
that the error does not grow with a defect: an error smaller than the healthy one holds).
Under an unbalance, F_r is the static
radial load (the rotating force is a load the model is not asked about), so its MAPE is that of
the static part.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.stats import beta

from signatelec.config.constraints import HEALTHY
from signatelec.estimation.condition import SPALLS

#: One-sided confidence of the upper bounds.
CONFIDENCE = 0.95
#: Bootstrap resamples of the F_r MAPE intervals.
BOOTSTRAP = 4000


def clopper_pearson_upper(flagged: int, n: int, confidence: float = CONFIDENCE) -> float:
    """Exact one-sided upper confidence bound on a binomial rate with ``flagged`` of ``n``
    (Clopper and Pearson 1934): the rate p at which P(X <= flagged | n, p) = 1 - confidence,
    the ``confidence`` quantile of Beta(flagged + 1, n - flagged)."""
    if n <= 0:
        return float("nan")
    if flagged >= n:
        return 1.0
    return float(beta.ppf(confidence, flagged + 1, n - flagged))


def alarm_figures(pred: pd.DataFrame) -> pd.DataFrame:
    """Per bearing and for all: runs, runs flagged, the rate and its one-sided upper bound,
    and what the flagged runs were called."""
    rows = []
    for group, g in [("all", pred), *pred.groupby("bearing", observed=True)]:
        # a run is flagged when any of its windows is: its call, the first flagged window's
        g = g.assign(flag=g["pred_condition"].astype(str) != HEALTHY)
        runs = g.sort_values("flag", ascending=False).groupby("run_id").head(1)
        called = runs["pred_condition"].astype(str)
        flagged = int(runs["flag"].sum())
        n = len(runs)
        rows.append(
            {
                "group": str(group),
                "runs": n,
                "flagged": flagged,
                "rate": flagged / n if n else float("nan"),
                "upper_95": clopper_pearson_upper(flagged, n),
                "called": ", ".join(
                    f"{c} {k}" for c, k in called[called != HEALTHY].value_counts().items()
                ),
            }
        )
    return pd.DataFrame(rows)


def bootstrap_run_mean(values_by_run: list[np.ndarray], rng: np.random.Generator) -> np.ndarray:
    """The mean over windows of ``BOOTSTRAP`` resamples of the runs (each run's windows kept
    together): of absolute errors, a MAPE; of 0/1 hits, a coverage."""
    ape_by_run = values_by_run
    sums = np.array([a.sum() for a in ape_by_run])
    counts = np.array([a.size for a in ape_by_run])
    picks = rng.integers(0, len(ape_by_run), size=(BOOTSTRAP, len(ape_by_run)))
    return sums[picks].sum(axis=1) / counts[picks].sum(axis=1)


def load_error_figures(
    pred: pd.DataFrame, seed: int = 14, judged: tuple[str, ...] | None = SPALLS
) -> pd.DataFrame:
    """F_r MAPE of the default load-state model per condition with its bootstrap 95 % interval
    (acceptance windows of the rows with a prediction), and for each condition of ``judged``
    (None: every one but healthy) whether it holds against the healthy runs (module
    docstring)."""
    rows = pred[pred["acceptance"] & np.isfinite(pred["pred_load_radial_load_n"])]
    ape = np.abs(rows["pred_load_radial_load_n"] / rows["radial_load_n"] - 1.0)
    rows = rows.assign(ape=ape.to_numpy())
    rng = np.random.default_rng(seed)
    out = []
    for condition, g in rows.groupby("condition", observed=True):
        by_run = [v.to_numpy() for _, v in g.groupby("run_id")["ape"]]
        lo, hi = np.percentile(bootstrap_run_mean(by_run, rng), [2.5, 97.5])
        out.append(
            {
                "condition": str(condition),
                "runs": len(by_run),
                "windows": int(len(g)),
                "mape": float(g["ape"].mean()),
                "low": float(lo),
                "high": float(hi),
            }
        )
    table = pd.DataFrame(out)
    healthy = table[table["condition"] == HEALTHY]
    holds = np.full(len(table), np.nan)
    if not healthy.empty:
        h = healthy.iloc[0]
        half = 0.5 * (h["high"] - h["low"])
        for i, r in enumerate(table.itertuples()):
            if r.condition != HEALTHY and (judged is None or r.condition in judged):
                not_above = r.low <= h["high"]  # overlapping, or below: not worse
                holds[i] = float(not_above and r.mape <= h["mape"] + half)
    return table.assign(holds=holds)


def _pct(x: float, digits: int = 2) -> str:
    return f"{100 * x:.{digits}f} %"


def markdown(alarms: pd.DataFrame, load: pd.DataFrame, quick: bool) -> list[str]:
    """The report's sections on false alarms and on the load state with a defect."""
    runs = int(alarms.loc[alarms["group"] == "all", "runs"].iloc[0])
    lines = [
        "## False alarms (held-out healthy runs, one per independent draw)",
        "",
        f"{runs} healthy runs of their own seed"
        + (" (quick variant: fast preset)" if quick else " at the paper's fidelity")
        + ", F_r 0.1-0.4 C_r, clearance 0-15 um, 300-700 rad/s and the ball phase drawn from "
        "the training design's ranges; each measured once over its 0.2 s at 20 kHz with 0.2 % "
        "white noise and 0.05 % drift. *Upper bound*: exact one-sided 95 % (Clopper-Pearson).",
        "",
        "| bearing | runs | flagged | rate | upper bound (95 %) | flagged runs called |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for r in alarms.itertuples():
        lines.append(
            f"| {r.group} | {r.runs} | {r.flagged} | {_pct(r.rate)} | {_pct(r.upper_95)} | "
            f"{r.called or '-'} |"
        )
    lines += [
        "",
        "## Load state with a defect present (seed's bearing)",
        "",
        "F_r MAPE of the default load-state model on the held-out acceptance windows, with a "
        "bootstrap 95 % interval over the runs. A spall *holds* when its interval overlaps the "
        "healthy one (or lies below it) and its MAPE exceeds the healthy MAPE by at most the "
        "healthy interval's half-width. Under an unbalance F_r is the static radial load (the "
        "rotating force turns at shaft speed and averages out over a revolution); its row is "
        "the error on that static part.",
        "",
        "| condition | runs | windows | F_r MAPE | 95 % interval | holds |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    lines += [f"| {' | '.join(load_cells(r))} |" for r in load.itertuples()]
    return [*lines, ""]


def load_cells(row) -> list[str]:
    """The cells of one row of :func:`load_error_figures` in a Markdown table: condition, runs,
    windows, F_r MAPE, its interval and whether it holds."""
    holds = "-" if not np.isfinite(row.holds) else ("yes" if row.holds else "no")
    interval = f"{_pct(row.low)} - {_pct(row.high)}"
    return [str(row.condition), str(row.runs), str(row.windows), _pct(row.mape), interval, holds]
