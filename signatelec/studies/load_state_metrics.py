"""What the load-state study measures: the conditions, and the accuracy figures at each.

The acceptance condition is held-out runs, 0.2 % white noise per sample, 50 ms at 20 kHz
(:data:`ACCEPTANCE`); around it the study scans the noise and the trace length (:data:`SCANS`).
:func:`metrics` gives the accuracy and uncertainty figures of a block of predictions,
:func:`metrics_table` all of them by source and condition; :func:`signature_twins` measures how
far each run's resistance signature lies from another regime's, which bounds what any estimator
can tell apart (:func:`twin_table`, :func:`epsilon_table`).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from signatelec.estimation.estimate import CONFIDENT_PROBABILITY
from signatelec.estimation.training import model_features
from signatelec.physics.regimes import REGIMES

SAMPLE_RATE_HZ = 20000.0
#: The acceptance condition: held-out runs, 0.2 % noise, 50 ms at 20 kHz (and 0.05 % drift).
ACCEPT_NOISE, ACCEPT_LENGTH_S, ACCEPT_DRIFT = 0.002, 0.05, 5e-4
ACCEPTANCE = {"noise_fraction": ACCEPT_NOISE, "length_s": ACCEPT_LENGTH_S}
NOISE_LEVELS = (5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2)
LENGTHS_S = (0.0125, 0.025, 0.05, 0.1, 0.2)
#: The scans around the acceptance condition: (condition, the column it varies, its values).
SCANS = (("noise", "noise_fraction", NOISE_LEVELS), ("length", "length_s", LENGTHS_S))


def metrics(p: pd.DataFrame) -> dict:
    """Accuracy and uncertainty figures of a block of predictions."""
    fr, fr_hat = p["radial_load_n"], p["pred_radial_load_n"]
    proba = np.stack([p[f"pred_regime_probability_{r}"] for r in REGIMES], axis=1)
    truth = p["regime"].map({r: i for i, r in enumerate(REGIMES)}).to_numpy()
    right = (p["pred_regime"] == p["regime"]).to_numpy()
    confident = proba.max(axis=1) >= CONFIDENT_PROBABILITY
    out = {
        "n": len(p),
        "n_runs": int(p["run_id"].nunique()),
        "fr_mape_pct": float(100 * np.mean(np.abs(fr_hat / fr - 1))),
        "epsilon_mae": float(np.mean(np.abs(p["pred_epsilon"] - p["epsilon"]))),
        "clearance_mae_um": float(1e6 * np.mean(np.abs(p["pred_clearance_m"] - p["clearance_m"]))),
        "regime_accuracy": float(np.mean(right)),
        # calls at or above CONFIDENT_PROBABILITY: their share and accuracy
        "regime_confident_share": float(np.mean(confident)),
        "regime_confident_accuracy": float(np.mean(right[confident]))
        if confident.any()
        else math.nan,
        "regime_log_loss": float(
            -np.mean(np.log(np.clip(proba[np.arange(len(p)), truth], 1e-12, 1)))
        ),
    }
    for name, scale in (("radial_load_n", 1.0), ("epsilon", 1.0), ("clearance_m", 1e6)):
        lo, hi = p[f"pred_{name}_low"], p[f"pred_{name}_high"]
        out[f"{name}_coverage"] = float(np.mean((p[name] >= lo) & (p[name] <= hi)))
        width = (hi - lo) / (p[name] if name == "radial_load_n" else 1.0) * scale
        out[f"{name}_width_median"] = float(np.median(width))
    return out


def metrics_table(
    cv: pd.DataFrame, test: pd.DataFrame, test_default: pd.DataFrame | None = None
) -> pd.DataFrame:
    """:func:`metrics` by source (``cv_fast``: cross-validated training runs; ``test_dem``:
    paper-fidelity test runs; ``test_dem_default_model``: the same by the default model) and
    condition: ``acceptance`` (all and by regime), then the ``noise`` and ``length`` scans (at
    the acceptance condition's other coordinate; their acceptance point is window 0 of the
    acceptance rows)."""
    rows = []

    def add(source, condition, frame, **extra):
        if len(frame):
            rows.append({"source": source, "condition": condition, **extra, **metrics(frame)})

    sources = [("cv_fast", cv), ("test_dem", test)]
    if test_default is not None:
        sources.append(("test_dem_default_model", test_default))
    for source, p in sources:
        acc = p[p["condition"] == "acceptance"]
        add(source, "acceptance", acc, **ACCEPTANCE)
        for regime in REGIMES:
            add(source, f"acceptance:{regime}", acc[acc["regime"] == regime], **ACCEPTANCE)
        first = acc[acc["window"] == 0]
        for condition, column, values in SCANS:
            for value in values:
                frame = (
                    first
                    if value == ACCEPTANCE[column]
                    else p[(p["condition"] == condition) & np.isclose(p[column], value)]
                )
                add(source, condition, frame, **{**ACCEPTANCE, column: value})
    return pd.DataFrame(rows)


#: Features known rather than measured (speed, trace length in ball passes): not signature.
KNOWN_FEATURES = ("omega_rad_s", "duration_ball_passes")
TWIN_BANDS = (0.0, 0.75, 1.0, 1.5, 2.0, 3.0, np.inf)
EPSILON_BANDS = tuple(np.round(np.arange(0.30, 0.601, 0.025), 3))


def signature_twins(evaluation: pd.DataFrame, cv: pd.DataFrame) -> pd.DataFrame:
    """How far each run's resistance signature lies from the nearest run of another regime.

    Per run: the mean of the model's features over its acceptance windows (0.2 % noise, 50 ms),
    each feature divided by its measurement scatter (the pooled within-run standard deviation
    of single windows). ``twin_distance`` is the RMS over features of the difference to the
    nearest run of another regime, in those units: below ~1 the two load states differ by less
    than one window's noise, and no estimator can tell them apart from one window. The design
    samples its space finitely, so these distances are upper bounds: twins lie at least this
    close. ``regime_accuracy`` is the cross-validated accuracy on the run's windows.
    """
    from sklearn.neighbors import NearestNeighbors

    feats = [f for f in model_features() if f not in KNOWN_FEATURES]
    acc = evaluation[evaluation["condition"] == "acceptance"]
    by_run = acc.groupby("run_id")
    scatter = np.sqrt(by_run[feats].var(ddof=1).mean())
    signature = (by_run[feats].mean() / scatter).to_numpy()
    runs = by_run[["regime", "epsilon", "clearance_m", "radial_load_n"]].first()
    regime = runs["regime"].astype(str).to_numpy()
    distance = np.full(len(runs), np.nan)
    for r in REGIMES:
        mine, other = regime == r, regime != r
        if mine.any() and other.any():
            d, _ = NearestNeighbors(n_neighbors=1).fit(signature[other]).kneighbors(signature[mine])
            distance[mine] = d[:, 0] / math.sqrt(len(feats))
    runs["twin_distance"] = distance
    pred = cv[cv["condition"] == "acceptance"]
    right = (pred["pred_regime"] == pred["regime"]).groupby(pred["run_id"]).mean()
    runs["regime_accuracy"] = right.reindex(runs.index)
    return runs.reset_index()


def twin_table(twins: pd.DataFrame) -> pd.DataFrame:
    """Runs and their regime accuracy by distance to the nearest other-regime signature."""
    band = pd.cut(twins["twin_distance"], TWIN_BANDS, right=False)
    out = twins.groupby(band, observed=True).agg(
        runs=("run_id", "size"), regime_accuracy=("regime_accuracy", "mean")
    )
    out["share"] = out["runs"] / out["runs"].sum()
    return out.reset_index().rename(columns={"twin_distance": "band"})


def epsilon_table(cv: pd.DataFrame, twins: pd.DataFrame) -> pd.DataFrame:
    """Regime accuracy, epsilon error and the share of twinned runs by true epsilon."""
    acc = cv[cv["condition"] == "acceptance"]
    band = pd.cut(acc["epsilon"], EPSILON_BANDS)
    out = pd.DataFrame(
        {
            "windows": acc.groupby(band, observed=True).size(),
            "regime_accuracy": (acc["pred_regime"] == acc["regime"])
            .groupby(band, observed=True)
            .mean(),
            "epsilon_mae": (acc["pred_epsilon"] - acc["epsilon"])
            .abs()
            .groupby(band, observed=True)
            .mean(),
        }
    )
    tb = pd.cut(twins["epsilon"], EPSILON_BANDS)
    out["twinned_runs"] = (twins["twin_distance"] < 1.0).groupby(tb, observed=True).mean()
    return out.reset_index().rename(columns={"epsilon": "band"})
