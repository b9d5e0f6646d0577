"""Stretch intervals' coverage by band of epsilon: the quantile interval against the residual.

Usage::

    git show 2bd5616:docs/monitor/monitor_calibration.parquet > quantile.parquet
    python pipelines/monitor_interval_bands.py quantile.parquet \
        docs/monitor/monitor_calibration.parquet [--report FILE]

Each argument is the calibration stretches that ``signatelec study monitor`` writes
(``monitor_calibration.parquet``: 1120 stretches of 288 held-out DEM states), the first with the
stretch model's interval from its conformalised quantile models (the default model of recipe 4,
commit 2bd5616), the second from the model of its own out-of-fold error (``interval =
"residual"``). Both have the same estimates; only the interval sd w differs.

For each, the per-regime ratios b are calibrated on the stretches of two thirds of the states
and the coverage is measured on the others' (200 random splits by state, as the study
cross-validates), by band of the true epsilon; with the median interval half-width, and the
spread of the coverage over banks of 56 held-out states (as many as the acceptance bank
holds): its standard deviation and how often such a bank falls below 85 %. A conformal
interval covers 90 % over the mix of states; a bank of 56 states, whose stretches share their
state's error, measures it to a few points.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

#: Bands of the true epsilon: the fold of R(epsilon) near 0.35, zero clearance, the null near
#: 0.55 among them.
EDGES = (0.29, 0.33, 0.37, 0.41, 0.45, 0.499, 0.501, 0.52, 0.55, 0.61)
SPLITS = 200
BANK_STATES = 56


def coverage_by_band(truth: pd.DataFrame, seed: int = 0) -> pd.DataFrame:
    """Cross-validated coverage per band and target, the median half-width and the spread of
    56-state banks' coverage."""
    from signatelec.estimation.evidence import ANY_REGIME, Z90
    from signatelec.studies.monitor_metrics import TARGETS, calibrate_bias_ratio, stretch_errors

    truth = truth.reset_index(drop=True)
    rng = np.random.default_rng(seed)
    states = truth.state.unique()
    band = pd.cut(truth.epsilon, list(EDGES)).astype(str).to_numpy()
    out = {}
    for target in TARGETS:
        err, se, w = stretch_errors(truth, target)
        hits, counts = np.zeros(len(truth)), np.zeros(len(truth))
        widths, banks = [], []
        for _ in range(SPLITS):
            held = truth.state.isin(rng.choice(states, len(states) // 3, replace=False))
            held = held.to_numpy()
            by = calibrate_bias_ratio(truth[~held])[target]
            b = np.array([by.get(r, by[ANY_REGIME]) for r in truth.regime_est])
            half = Z90 * np.hypot(b * w, se)
            hit = np.abs(err) <= half
            hits[held] += hit[held]
            counts[held] += 1
            widths.append(np.median(half[held]))
            chosen = rng.choice(truth.state[held].unique(), BANK_STATES, replace=False)
            banks.append(hit[truth.state.isin(chosen).to_numpy()].mean())
        cover = pd.Series(hits / np.maximum(counts, 1)).groupby(band).mean()
        cover["all"] = float((hits / np.maximum(counts, 1)).mean())
        cover["median half-width"] = float(np.median(widths))
        cover["56-state bank sd"] = float(np.std(banks))
        cover["56-state bank < 85 %"] = float(np.mean(np.array(banks) < 0.85))
        out[target] = cover
    frame = pd.DataFrame(out)
    frame.insert(0, "stretches", pd.Series(band).value_counts().astype(object))
    frame["stretches"] = frame["stretches"].fillna("-")
    return frame.rename_axis("true epsilon").reset_index()


def main() -> None:
    from monitor_bias import markdown

    from signatelec.io import write_bytes_atomic

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("quantile", help="calibration stretches, quantile interval")
    parser.add_argument("residual", help="calibration stretches, residual interval")
    parser.add_argument("--report", default="docs/monitor/interval_bands.md")
    args = parser.parse_args()
    lines = [
        "# Stretch intervals by band of epsilon",
        "",
        "Written by `python pipelines/monitor_interval_bands.py` (its docstring says how): "
        "the calibration records' stretches, cross-validated by state (ratios on two thirds "
        "of the states, coverage on the rest, 200 splits), nominal 90 %. Half-widths are "
        "relative for F_r and absolute for epsilon and clearance (m).",
    ]
    for name, path in (("quantile", args.quantile), ("residual", args.residual)):
        frame = coverage_by_band(pd.read_parquet(path))
        lines += ["", f"## Interval from the stretch model's {name} models", "", *markdown(frame)]
    write_bytes_atomic(args.report, ("\n".join(lines) + "\n").encode())
    print(f"wrote {args.report}")


if __name__ == "__main__":
    main()
