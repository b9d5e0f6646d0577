"""How sure a stretch's regime should be: the combined regime probability against the truth.

Usage::

    python pipelines/monitor_regime_probability.py [--bank DIR] [--out DIR]

The design records of ``signatelec study monitor`` (:data:`N_CALIBRATION_RECORDS` records
assembled from the design bank, ``--bank``, as the study assembles them: not its acceptance
records) are monitored with the default model; for each true stretch, the found stretch
overlapping it most and its windows' regime log-probabilities (per class: their sum, their
mean, the weight :func:`~signatelec.estimation.evidence.combine_classes` gives the sum) are
kept in ``--out``/regime_stretches.parquet. :func:`fit_report` then compares, cross-validated
by state (the stretches of one state share its model error), the stretch probabilities of

- ``summed``: the windows' log-probabilities summed with the weight n_eff / n (evidence that
  grows with the stretch, as if the windows' errors were independent);
- ``scaled``: the same divided by one temperature fitted on the design stretches;
- ``mean``: the mean log-probability times one factor fitted on them (evidence that does not
  grow with the stretch: the model's error is the state's, shared by its windows).

The argmax, and so the regime, is the same for all three; the factors are also fitted per band
of the estimated epsilon's distance from 0.5 (:data:`BANDS`). ``--model`` asks another model
file (the regime and F_r of the design stretches are printed for it too: how the default
model's training runs were chosen); ``--seed`` another bank of states drawn alike (records from
seed + 1, as the study's), e.g. 20263777: 72 states that informed nothing, regime right for
96.7 % of stretches with the model of the 1200 fast and 1200 uniform paper runs, 98.3 % with
the default model.

Found (200 splits): with the model trained on the 1200 fast and 1200 uniform paper-fidelity
runs, whose wrong regimes the summed evidence reported at 0.90 on average, the scaled mean
lowered the log-loss from 0.55 to 0.13 and the Brier score from 0.090 to 0.066; with the default
model (600 runs placed near the boundaries too) only one state is misread, the summed evidence
has the lowest Brier score (0.042 against 0.050) and the factors fitted without that state do
not hold for it: the stretch keeps the summed evidence.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import pandas as pd
from monitor_bias import markdown

REGIMES = ("clearance", "preload", "zero")


def collect(
    bank_dir: Path,
    out: Path,
    log=print,
    model_path: str | None = None,
    seed: int | None = None,
    features: tuple[str, ...] = (),
) -> pd.DataFrame:
    """The design stretches (module docstring); with ``features``, also the mean of each over
    the stretch's windows (the windows then keep them beside the monitor's own)."""
    from signatelec.estimation import monitor_answers as monitor_module
    from signatelec.estimation.changes import effective_fraction
    from signatelec.estimation.evidence import class_columns, stretches_and_changes, usable
    from signatelec.estimation.monitor import MonitorSettings, monitor_trace
    from signatelec.estimation.persistence import default_model, load_model
    from signatelec.studies.monitor import N_CALIBRATION_RECORDS, N_STRETCHES
    from signatelec.studies.monitor_records import (
        CALIBRATION_STATES,
        DESIGN_SEED,
        OMEGA_RAD_S,
        SAMPLE_RATE_HZ,
        assemble_record,
        dem_bank,
        write_record,
    )

    seed = DESIGN_SEED if seed is None else seed
    name = Path(model_path).stem if model_path else "default"
    cache = out / f"regime_stretches-{name}-{seed}{'-features' if features else ''}.parquet"
    if cache.is_file():
        return pd.read_parquet(cache)
    kept = monitor_module.KEPT_FEATURES
    # the speed is each window's own column already
    monitor_module.KEPT_FEATURES = tuple(
        f for f in dict.fromkeys((*kept, *features)) if f != "omega_rad_s"
    )
    bank = dem_bank(bank_dir, log, CALIBRATION_STATES, seed)
    model = load_model(model_path) if model_path else default_model(log=log)
    settings = MonitorSettings(omega_rad_s=OMEGA_RAD_S)
    rng = np.random.default_rng(seed + 1)
    rows = []
    for i in range(N_CALIBRATION_RECORDS):
        noisy, truth = assemble_record(bank, rng, N_STRETCHES, None)
        path = out / f"record-{i:02d}.parquet"
        write_record(path, noisy, SAMPLE_RATE_HZ)
        windows = monitor_trace(path, model, settings).frame()
        path.unlink()
        stretches, _, _ = stretches_and_changes(windows, settings.hop)
        found = pd.DataFrame(stretches)
        good = usable(windows)
        pc = class_columns(good, "regime")
        for tr in truth.itertuples(index=False):
            overlap = np.minimum(found.end_s, tr.end_s) - np.maximum(found.start_s, tr.start_s)
            f = found.iloc[int(np.argmax(overlap))]
            w = good[(good.start_s >= f.start_s - 1e-9) & (good.end_s <= f.end_s + 1e-9)]
            logp = np.log(np.clip(w[pc].to_numpy(float), 1e-12, 1.0))
            top = int(np.argmax(logp.sum(axis=0)))
            others = np.delete(logp, top, axis=1)
            margin = logp[:, top] - others.max(axis=1)
            weight = effective_fraction(margin) if len(logp) > 1 else 1.0
            row = {
                "record": i,
                "state": int(tr.state),
                "length_s": tr.end_s - tr.start_s,
                "regime": tr.regime,
                "epsilon": tr.epsilon,
                "clearance_m": tr.clearance_m,
                "n_windows": len(w),
                "weight": weight,
                "regime_est": f.regime,
                "radial_load_n": tr.radial_load_n,
                "radial_load_n_est": f.radial_load_n,
                "epsilon_est": f.epsilon,
                "clearance_est": f.clearance_m,
            }
            for c, s, m in zip(pc, logp.sum(axis=0), logp.mean(axis=0), strict=True):
                name = c.removeprefix("regime_probability_")
                row[f"sum_{name}"], row[f"mean_{name}"] = float(s), float(m)
            row.update({f: float(w[f].mean()) for f in features})
            rows.append(row)
        log(f"record {i}: {len(truth)} stretches")
    monitor_module.KEPT_FEATURES = kept
    table = pd.DataFrame(rows)
    table.to_parquet(cache)
    return table


def _probabilities(z: np.ndarray) -> np.ndarray:
    z = z - z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


def scores(table: pd.DataFrame, kind: str) -> np.ndarray:
    """The stretch's unscaled class scores of ``kind`` (summed with the weight, or mean)."""
    if kind == "mean":
        return table[[f"mean_{r}" for r in REGIMES]].to_numpy(float)
    return table[[f"sum_{r}" for r in REGIMES]].to_numpy(float) * table.weight.to_numpy()[:, None]


def fit_factor(z: np.ndarray, y: np.ndarray) -> float:
    """The factor on the scores that minimises the negative log-likelihood of the truth."""
    from scipy.optimize import minimize_scalar

    def nll(log_k: float) -> float:
        p = _probabilities(z * math.exp(log_k))
        return -float(np.log(np.clip(p[np.arange(len(y)), y], 1e-300, 1.0)).mean())

    return math.exp(minimize_scalar(nll, bounds=(-12.0, 6.0), method="bounded").x)


#: Candidate bands of the estimated epsilon's distance from 0.5 (the zero regime, +-1 um, is
#: epsilon 0.5 +- ~0.006 at these loads; the model's epsilon error is ~0.013, model_error.md):
#: a factor is fitted per band.
BANDS = {"one factor": (), "two bands": (0.02,), "three bands": (0.005, 0.02)}


def band_of(epsilon_est, edges) -> np.ndarray:
    return np.digitize(np.abs(np.asarray(epsilon_est, float) - 0.5), edges)


def fit_bands(z, y, bands, n_bands) -> np.ndarray:
    """A factor per band (1 where a band has no stretch to fit on)."""
    return np.array(
        [
            fit_factor(z[bands == b], y[bands == b]) if (bands == b).any() else 1.0
            for b in range(n_bands)
        ]
    )


def evaluate(table: pd.DataFrame, splits: int = 200, seed: int = 0) -> pd.DataFrame:
    """Cross-validated (two thirds of the states fit, the rest scored) NLL, Brier score, and
    mean probability of the reported regime when right and when wrong, per method."""
    y = np.array([REGIMES.index(r) for r in table.regime])
    right = table.regime.to_numpy() == table.regime_est.to_numpy()
    states = np.unique(table.state)
    rng = np.random.default_rng(seed)
    rows = []
    methods = [("summed", "sum", ())] + [
        (f"{kind} x factor, {name}", kind, edges)
        for kind in ("sum", "mean")
        for name, edges in BANDS.items()
    ]
    for method, kind, edges in methods:
        z = scores(table, kind)
        bands = band_of(table.epsilon_est, edges)
        acc = {"nll": [], "brier": [], "p_right": [], "p_wrong": [], "factor": []}
        for _ in range(splits):
            fit = np.isin(table.state, rng.choice(states, 2 * states.size // 3, replace=False))
            if method == "summed":
                k = np.ones(len(edges) + 1)
            else:
                k = fit_bands(z[fit], y[fit], bands[fit], len(edges) + 1)
            p = _probabilities(z[~fit] * k[bands[~fit]][:, None])
            yt = y[~fit]
            acc["factor"].append(k)
            acc["nll"].append(-np.log(np.clip(p[np.arange(len(yt)), yt], 1e-300, 1)).mean())
            onehot = np.eye(len(REGIMES))[yt]
            acc["brier"].append(((p - onehot) ** 2).sum(axis=1).mean())
            top = p.max(axis=1)
            r = right[~fit]
            acc["p_right"].append(top[r].mean() if r.any() else np.nan)
            acc["p_wrong"].append(top[~r].mean() if (~r).any() else np.nan)
        factors = np.median(np.array(acc.pop("factor")), axis=0)
        rows.append(
            {
                "method": method,
                **{k: float(np.nanmean(v)) for k, v in acc.items()},
                "factors": " / ".join(f"{f:.3g}" for f in factors),
            }
        )
    return pd.DataFrame(rows)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--bank", default="/tmp/monitor-bank/design")
    p.add_argument("--out", default="/tmp/monitor-regime")
    p.add_argument("--model", default=None, help="a model file (default: the default model)")
    p.add_argument(
        "--seed",
        type=int,
        default=None,
        help="the bank's seed (default: the study's DESIGN_SEED; another draws new states)",
    )
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = collect(Path(args.bank), out, model_path=args.model, seed=args.seed)
    right = table.regime == table.regime_est
    fr = (table.radial_load_n_est / table.radial_load_n - 1).abs()
    print(
        f"{len(table)} stretches, regime right {right.mean():.3f} (>= 2 s: "
        + ", ".join(f"{r} {g.mean():.3f} of {len(g)}" for r, g in right.groupby(table.regime))
        + f"); F_r within 1 % {(fr <= 0.01).mean():.3f}, max {100 * fr.max():.2f} %"
    )
    print("\n".join(markdown(evaluate(table).round(4))))
    y = np.array([REGIMES.index(r) for r in table.regime])
    k = fit_factor(scores(table, "mean"), y)
    print(f"mean x factor fitted on all {len(table)} stretches: {k:.3f} (REGIME_EVIDENCE)")
    return table


if __name__ == "__main__":
    main()
