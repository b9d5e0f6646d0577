"""Load-state estimation from a resistance trace (issue 6): generate, features, train, evaluate.

Usage::

    python pipelines/load_state.py [--out OUT] [--report DIR] [--quick] [--reuse] [--ship]

Steps (each writes into OUT, default ``out/load_state``; generation resumes where it stopped):

1. **generate**: the training runs of ``datasets/load_state.toml`` (1200 DEM runs at the "fast"
   preset, 0.2 s of steady trace each after 30 ms of settling, clean signal at 20 kHz;
   ``signatelec generate``; ~0.25 s of CPU per run) and 90 held-out test runs of the same
   design at the paper's fidelity (velocity Verlet, dt = 1e-7 s; ~2.5 s per run);
2. **features**: each run is cut into windows (12.5, 25, 50, 100, 200 ms; at least 5 ball
   passes), each measured through :class:`signatelec.measurement.model.MeasurementModel` with its
   own
   draw (white noise 0.05-1 % log-uniform, random-walk drift up to 0.1 %, offset +-20 uOhm,
   0.1 uOhm quantisation) -> ``features_train.parquet``; the acceptance condition (0.2 % noise,
   50 ms, 20 kHz, drift 0.05 %, same offset and quantisation) and a noise x length grid ->
   ``features_eval.parquet`` (training runs), ``features_test.parquet`` (test runs);
3. **train**: :class:`signatelec.estimation.estimate.LoadStateEstimator` on every training window
   (``load_state.model``); cross-validation grouped by run (GroupKFold, 5 folds) predicts every
   evaluation window from a model that never saw its run -> ``predictions_cv.parquet``; the
   final model predicts the test runs -> ``predictions_test.parquet``;
4. **evaluate**: F_r MAPE, epsilon and clearance MAE, regime accuracy, interval coverage and
   width, regime log-loss, by condition, on the cross-validated training runs and on the
   independent paper-fidelity test runs -> ``load_state_metrics.parquet``;
5. **report**: ``load_state.png`` (predicted vs true F_r and epsilon, confusion matrix of
   regimes, accuracy vs noise and vs trace length, reliability of the regime probabilities) and
   ``load_state.md`` in the report directory (default ``docs/load_state``), with the time to
   estimate a 1 s trace at 50 kHz (checks, features and model, model loaded).

About 30 min on one core from scratch, 6 min with ``--reuse`` (skips generation and features
when OUT holds the feature tables). ``--ship`` also writes the default model's training table
``signatelec/data/load_state_features.parquet`` (one 50 ms and one other window per training
run, the model's features as float32) and the example trace ``datasets/example_trace.csv``.
``--quick`` (a pipeline check, ~30 s): 24 training and 6 test runs of 0.1 s, 2 folds.
"""

from __future__ import annotations

import argparse
import json
import math
import time
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.estimation.estimate import (
    CLASS_TARGET,
    CONFIDENT_PROBABILITY,
    REGIMES,
    LoadStateEstimator,
    LoadStateModel,
    model_features,
    save_model,
    train_model,
)
from signatelec.estimation.features import trace_features
from signatelec.measurement.model import MeasurementDraw, MeasurementModel
from signatelec.measurement.traces import MIN_BALL_PASSES
from signatelec.physics.kinematics import expected_ball_pass_hz

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "datasets" / "load_state.toml"
DEFAULT_OUT = ROOT / "out" / "load_state"
DEFAULT_REPORT = ROOT / "docs" / "load_state"
SHIPPED_TABLE = ROOT / "signatelec" / "data" / "load_state_features.parquet"
EXAMPLE_TRACE = ROOT / "datasets" / "example_trace.csv"

SAMPLE_RATE_HZ = 20000.0
QUANTISATION_OHM = 1e-7
OFFSET_OHM = 20e-6
#: Training windows: length (s) -> how many per run.
TRAIN_WINDOWS = {0.0125: 2, 0.025: 2, 0.05: 2, 0.1: 2, 0.2: 1}
TRAIN_NOISE = (5e-4, 1e-2)  # log-uniform
TRAIN_DRIFT = (0.0, 1e-3)
#: The acceptance condition: held-out runs, 0.2 % noise, 50 ms at 20 kHz.
ACCEPT_NOISE, ACCEPT_LENGTH_S, ACCEPT_DRIFT = 0.002, 0.05, 5e-4
NOISE_LEVELS = (5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2)
LENGTHS_S = (0.0125, 0.025, 0.05, 0.1, 0.2)
TEST_RUNS_PER_REGIME = 30


def log(msg: str) -> None:
    print(msg, flush=True)


# --- 1. generate ------------------------------------------------------------------------------


def _spec(quick: bool, test: bool):
    from signatelec.data import spec_from_dict

    data = tomllib.loads(SPEC.read_text())
    if test:
        data["dataset"]["name"] = "load_state_test"
        data["dataset"]["seed"] = data["dataset"]["seed"] + 1
        data["dataset"]["fidelity"] = "dem"
    for block in data["design"]:
        if quick:
            block["n_traces"] = 2 if test else 8
        elif test:
            block["n_traces"] = TEST_RUNS_PER_REGIME
    if quick:
        data["dataset"]["duration_s"] = 0.1
    return spec_from_dict(data, str(SPEC))


def generate(out: Path, quick: bool) -> tuple[Path, Path]:
    from signatelec.data import generate as run

    dirs = []
    for test in (False, True):
        spec = _spec(quick, test)
        d = out / ("runs_test" if test else "runs")
        t0 = time.perf_counter()
        summary = run(spec, d, workers=0, progress=True)
        log(
            f"generate {spec.name}: {summary.generated} new traces, {summary.n_traces} in all, "
            f"{time.perf_counter() - t0:.0f} s"
        )
        dirs.append(d)
    return dirs[0], dirs[1]


def load_runs(path: Path) -> pd.DataFrame:
    from signatelec.data import read_dataset

    runs = read_dataset(path)
    failed = runs[runs["status"] != "ok"]
    if len(failed):
        log(f"{path.name}: {len(failed)} failed runs skipped, e.g. {failed['error'].iloc[0]}")
    return runs[runs["status"] == "ok"].reset_index(drop=True)


# --- 2. features -------------------------------------------------------------------------------


def _rng(*key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(6, spawn_key=tuple(int(k) for k in key)))


def measured_windows(
    runs: pd.DataFrame,
    length_s: float,
    max_windows: int,
    draw,
    key: int,
) -> list[dict]:
    """Windows of ``length_s`` (at most ``max_windows`` per run, at least MIN_BALL_PASSES ball
    passes), each measured with ``draw(rng)`` -> MeasurementDraw: rows of labels + features."""
    meter = MeasurementModel(sample_rate_hz=SAMPLE_RATE_HZ, quantisation_ohm=QUANTISATION_OHM)
    rows = []
    for run in runs.itertuples(index=False):
        clean = np.asarray(run.resistance_clean_ohm, dtype=float)
        fs = float(run.sample_rate_hz)
        n = int(round(length_s * fs))
        if n * expected_ball_pass_hz(run.omega_rad_s) / fs < MIN_BALL_PASSES:
            continue
        for w in range(min(max_windows, clean.size // n)):
            rng = _rng(key, run.trace_id, int(length_s * 1e4), w)
            d = draw(rng)
            r = meter.measure(clean[w * n : (w + 1) * n], d, rng)
            feats = trace_features(r, fs, run.omega_rad_s)
            rows.append(
                {
                    "run_id": int(run.trace_id),
                    "window": w,
                    "length_s": length_s,
                    "noise_fraction": d.noise_fraction,
                    "drift_fraction": d.drift_fraction,
                    "offset_ohm": d.offset_ohm,
                    "radial_load_n": float(run.radial_load_n),
                    "epsilon": float(run.epsilon),
                    "clearance_m": float(run.clearance_m),
                    "regime": str(run.regime),
                    "omega_rad_s": float(run.omega_rad_s),
                    **feats,
                }
            )
    return rows


def train_draw(rng: np.random.Generator) -> MeasurementDraw:
    lo, hi = np.log(TRAIN_NOISE)
    return MeasurementDraw(
        noise_fraction=float(np.exp(rng.uniform(lo, hi))),
        drift_fraction=float(rng.uniform(*TRAIN_DRIFT)),
        offset_ohm=float(rng.uniform(-OFFSET_OHM, OFFSET_OHM)),
    )


def fixed_draw(noise: float, drift: float = ACCEPT_DRIFT):
    def draw(rng: np.random.Generator) -> MeasurementDraw:
        return MeasurementDraw(noise, drift, float(rng.uniform(-OFFSET_OHM, OFFSET_OHM)))

    return draw


def train_table(runs: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for i, (length, count) in enumerate(TRAIN_WINDOWS.items()):
        rows += measured_windows(runs, length, count, train_draw, key=100 + i)
    return pd.DataFrame(rows)


def eval_table(runs: pd.DataFrame, quick: bool) -> pd.DataFrame:
    """Acceptance windows (every 50 ms window) and the noise x length grid (one window each)."""
    rows = []
    for row in measured_windows(runs, ACCEPT_LENGTH_S, 99, fixed_draw(ACCEPT_NOISE), key=1):
        rows.append({**row, "condition": "acceptance"})
    noises = NOISE_LEVELS[1::2] if quick else NOISE_LEVELS
    for i, noise in enumerate(noises):
        if noise == ACCEPT_NOISE:
            continue
        for row in measured_windows(runs, ACCEPT_LENGTH_S, 1, fixed_draw(noise), key=200 + i):
            rows.append({**row, "condition": "noise"})
    for i, length in enumerate(LENGTHS_S):
        if length == ACCEPT_LENGTH_S:
            continue
        for row in measured_windows(runs, length, 1, fixed_draw(ACCEPT_NOISE), key=300 + i):
            rows.append({**row, "condition": "length"})
    return pd.DataFrame(rows)


# --- 3. train (and cross-validate) --------------------------------------------------------------


def labels_of(table: pd.DataFrame) -> pd.DataFrame:
    y = table[["radial_load_n", "epsilon", "clearance_m", CLASS_TARGET]].copy()
    y[CLASS_TARGET] = y[CLASS_TARGET].astype(str).to_numpy(dtype=object)
    return y


def cross_validate(train: pd.DataFrame, evaluation: pd.DataFrame, n_splits: int) -> pd.DataFrame:
    """Predictions for every evaluation row from a model fitted without its run."""
    from sklearn.model_selection import GroupKFold

    features = model_features()
    runs = np.unique(train["run_id"])
    parts = []
    for k, (_, test_idx) in enumerate(GroupKFold(n_splits).split(runs, groups=runs)):
        held = set(runs[test_idx])
        fit_rows = train[~train["run_id"].isin(held)]
        t0 = time.perf_counter()
        est = LoadStateEstimator().fit(
            fit_rows[features], labels_of(fit_rows), groups=fit_rows["run_id"].to_numpy()
        )
        ev = evaluation[evaluation["run_id"].isin(held)]
        pred = est.predict_frame(ev[features]).add_prefix("pred_")
        parts.append(pd.concat([ev.reset_index(drop=True), pred], axis=1))
        log(f"cv fold {k + 1}/{n_splits}: fit {time.perf_counter() - t0:.0f} s, {len(ev)} rows")
    return pd.concat(parts, ignore_index=True)


def predict_rows(model: LoadStateModel, table: pd.DataFrame) -> pd.DataFrame:
    pred = model.predict_frame(table).add_prefix("pred_")
    return pd.concat([table.reset_index(drop=True), pred], axis=1)


# --- 4. evaluate -------------------------------------------------------------------------------


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
    rows = []

    def add(source, condition, frame, **extra):
        if len(frame):
            rows.append({"source": source, "condition": condition, **extra, **metrics(frame)})

    sources = [("cv_fast", cv), ("test_dem", test)]
    if test_default is not None:
        sources.append(("test_dem_default_model", test_default))
    for source, p in sources:
        acc = p[p["condition"] == "acceptance"]
        add(source, "acceptance", acc, noise_fraction=ACCEPT_NOISE, length_s=ACCEPT_LENGTH_S)
        for regime in REGIMES:
            add(
                source,
                f"acceptance:{regime}",
                acc[acc["regime"] == regime],
                noise_fraction=ACCEPT_NOISE,
                length_s=ACCEPT_LENGTH_S,
            )
        first = acc[acc["window"] == 0]
        for noise in NOISE_LEVELS:
            frame = (
                first
                if noise == ACCEPT_NOISE
                else p[(p["condition"] == "noise") & np.isclose(p["noise_fraction"], noise)]
            )
            add(source, "noise", frame, noise_fraction=noise, length_s=ACCEPT_LENGTH_S)
        for length in LENGTHS_S:
            frame = (
                first
                if length == ACCEPT_LENGTH_S
                else p[(p["condition"] == "length") & np.isclose(p["length_s"], length)]
            )
            add(source, "length", frame, noise_fraction=ACCEPT_NOISE, length_s=length)
    return pd.DataFrame(rows)


#: Features known rather than measured (speed, trace length in ball passes): not signature.
_KNOWN = ("omega_rad_s", "duration_ball_passes")
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

    feats = [f for f in model_features() if f not in _KNOWN]
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


# --- 5. report ---------------------------------------------------------------------------------


def plot_report(cv: pd.DataFrame, table: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    acc = cv[cv["condition"] == "acceptance"]
    fig, ax = plt.subplots(2, 3, figsize=(16, 10))
    colours = {"preload": "tab:blue", "zero": "tab:green", "clearance": "tab:red"}
    a = ax[0, 0]
    for regime, g in acc.groupby("regime"):
        a.scatter(
            g["radial_load_n"],
            g["pred_radial_load_n"],
            s=4,
            alpha=0.5,
            color=colours[regime],
            label=regime,
        )
    lim = [acc["radial_load_n"].min() * 0.9, acc["radial_load_n"].max() * 1.1]
    a.plot(lim, lim, "k-", lw=0.8)
    a.set(
        xscale="log",
        yscale="log",
        xlabel="true F_r (N)",
        ylabel="estimated F_r (N)",
        title="radial load (held-out runs, 0.2 % noise, 50 ms)",
    )
    a.legend(markerscale=3)
    a = ax[0, 1]
    for regime, g in acc.groupby("regime"):
        a.scatter(g["epsilon"], g["pred_epsilon"], s=4, alpha=0.5, color=colours[regime])
    a.plot([0.28, 0.62], [0.28, 0.62], "k-", lw=0.8)
    a.set(xlabel="true epsilon", ylabel="estimated epsilon", title="load parameter epsilon")
    a = ax[0, 2]
    cm = pd.crosstab(acc["regime"], acc["pred_regime"]).reindex(
        index=REGIMES, columns=REGIMES, fill_value=0
    )
    frac = cm.to_numpy() / cm.to_numpy().sum(axis=1, keepdims=True)
    a.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    for i in range(3):
        for j in range(3):
            a.text(
                j,
                i,
                f"{cm.iat[i, j]}\n{frac[i, j]:.0%}",
                ha="center",
                va="center",
                color="white" if frac[i, j] > 0.5 else "black",
            )
    a.set(
        xticks=range(3),
        xticklabels=REGIMES,
        yticks=range(3),
        yticklabels=REGIMES,
        xlabel="estimated regime",
        ylabel="true regime",
        title="regimes (held-out runs)",
    )
    for a, cond, x, xlabel in (
        (ax[1, 0], "noise", "noise_fraction", "white noise per sample (% of R)"),
        (ax[1, 1], "length", "length_s", "trace length (ms)"),
    ):
        m = table[(table["source"] == "cv_fast") & (table["condition"] == cond)].sort_values(x)
        t = table[(table["source"] == "test_dem") & (table["condition"] == cond)].sort_values(x)
        scale = 100.0 if cond == "noise" else 1e3
        xs = m[x] * scale
        a.plot(xs, m["fr_mape_pct"], "o-", label="F_r MAPE (%)")
        a.plot(xs, 100 * m["epsilon_mae"], "s-", label="epsilon MAE x 100")
        a.plot(xs, 100 * (1 - m["regime_accuracy"]), "^-", label="regime error (%)")
        if len(t):
            xt = t[x] * scale
            a.plot(xt, t["fr_mape_pct"], "o--", color="C0", alpha=0.5)
            a.plot(xt, 100 * t["epsilon_mae"], "s--", color="C1", alpha=0.5)
            a.plot(
                xt,
                100 * (1 - t["regime_accuracy"]),
                "^--",
                color="C2",
                alpha=0.5,
                label="dashed: paper-fidelity test runs",
            )
        a.axhline(3, color="grey", lw=0.6, ls=":")
        a.axhline(10, color="grey", lw=0.6, ls=":")
        ticks = sorted(set(xs))
        a.set(
            xscale="log",
            xlabel=xlabel,
            ylabel="error",
            title=f"accuracy vs {'noise (50 ms)' if cond == 'noise' else 'length (0.2 % noise)'}",
        )
        a.set_xticks(ticks, [f"{v:g}" for v in ticks])
        a.minorticks_off()
        a.legend(fontsize=8)
    a = ax[1, 2]
    proba = np.stack([acc[f"pred_regime_probability_{r}"] for r in REGIMES], axis=1)
    conf = proba.max(axis=1)
    right = (acc["pred_regime"] == acc["regime"]).to_numpy()
    edges = np.linspace(1 / 3, 1.0, 9)
    idx = np.clip(np.digitize(conf, edges) - 1, 0, len(edges) - 2)
    mids = 0.5 * (edges[1:] + edges[:-1])
    n_bin = np.bincount(idx, minlength=len(mids))
    hit = np.bincount(idx, weights=right, minlength=len(mids))
    ok = n_bin > 0
    a.plot([1 / 3, 1], [1 / 3, 1], "k-", lw=0.8)
    a.plot(mids[ok], hit[ok] / n_bin[ok], "o-", color="C3", label="fraction right")
    a2 = a.twinx()
    a2.bar(mids, n_bin / n_bin.sum(), width=0.07, alpha=0.25, color="grey")
    a2.set_ylabel("share of traces")
    a.set(
        xlabel="probability of the estimated regime",
        ylabel="fraction estimated right",
        title=f"regime probabilities (wrong calls: mean {conf[~right].mean():.2f}, "
        f"right: {conf[right].mean():.2f})",
    )
    a.legend(loc="upper left")
    fig.tight_layout()
    tmp = path.with_name(path.name + ".tmp.png")
    fig.savefig(tmp, dpi=80)
    plt.close(fig)
    tmp.replace(path)


def benchmark(model: LoadStateModel, repeats: int = 20) -> dict:
    """Time to estimate a 1 s trace at 50 kHz (features + model), model loaded."""
    from signatelec.config.scene import Scene
    from signatelec.estimation.estimate import estimate
    from signatelec.measurement.traces import prepare_trace

    sc = Scene().with_overrides(
        duration_s=0.007 + 1.0, sample_rate_hz=50000.0, fidelity="quasistatic"
    )
    from signatelec.engines.simulate import simulate

    st = simulate(sc).steady()
    r = st["resistance_ohm"].to_numpy()[:50000]
    r = r * (1 + 0.002 * np.random.default_rng(0).standard_normal(r.size))
    t = np.arange(r.size) / 50000.0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        trace = prepare_trace(t, r, 500.0, "benchmark")
        estimate(trace, 500.0, model)
        times.append(time.perf_counter() - t0)
    return {
        "samples": int(r.size),
        "first_s": times[0],
        "median_s": float(np.median(times)),
        "max_s": float(np.max(times)),
        "repeats": repeats,
    }


def write_markdown(
    table: pd.DataFrame,
    bench: dict,
    info: dict,
    path: Path,
    twins: pd.DataFrame | None = None,
    by_epsilon: pd.DataFrame | None = None,
) -> None:
    def row(source, condition):
        m = table[(table["source"] == source) & (table["condition"] == condition)]
        return m.iloc[0] if len(m) else None

    lines = [
        "# Load-state estimation (issue 6)",
        "",
        "Generated by `python pipelines/load_state.py`; see its docstring for the steps.",
        f"Model: `LoadStateEstimator` trained on {info['n_rows']} windows of {info['n_runs']} DEM "
        f"runs; features: {len(model_features())}; fit {info['fit_s']} s.",
        "",
        "## Acceptance: held-out runs, 0.2 % noise, 50 ms at 20 kHz",
        "",
        "| runs | n | F_r MAPE | epsilon MAE | clearance MAE | regime acc. | "
        "F_r / eps / clearance 90 % interval coverage | median width F_r, eps, c |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for source, label in (
        ("cv_fast", "CV, fast preset"),
        ("test_dem", "test, paper fidelity"),
        ("test_dem_default_model", "test, default model"),
    ):
        for cond in ("acceptance", *(f"acceptance:{r}" for r in REGIMES)):
            m = row(source, cond)
            if m is None:
                continue
            lines.append(
                f"| {label} {cond.split(':')[-1] if ':' in cond else 'all'} | {m['n']} | "
                f"{m['fr_mape_pct']:.2f} % | {m['epsilon_mae']:.3f} | "
                f"{m['clearance_mae_um']:.1f} um | {m['regime_accuracy']:.1%} | "
                f"{m['radial_load_n_coverage']:.0%} / {m['epsilon_coverage']:.0%} / "
                f"{m['clearance_m_coverage']:.0%} | {m['radial_load_n_width_median']:.1%}, "
                f"{m['epsilon_width_median']:.3f}, {m['clearance_m_width_median']:.1f} um |"
            )
    lines += ["", "## Sensitivity (cross-validated training runs)", ""]
    lines += [
        "| condition | noise | length | F_r MAPE | eps MAE | regime acc. |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    sens = table[(table["source"] == "cv_fast") & table["condition"].isin(["noise", "length"])]
    for _, m in sens.iterrows():
        lines.append(
            f"| {m['condition']} | {m['noise_fraction']:.2%} | {m['length_s'] * 1e3:g} ms | "
            f"{m['fr_mape_pct']:.2f} % | {m['epsilon_mae']:.3f} | {m['regime_accuracy']:.1%} |"
        )
    if twins is not None and by_epsilon is not None:
        lines += _limits_markdown(table, twins, by_epsilon)
    lines += [
        "",
        f"Estimate of a 1 s trace at 50 kHz (prepare + features + model, model loaded): median "
        f"{bench['median_s'] * 1e3:.1f} ms, first call {bench['first_s'] * 1e3:.1f} ms, "
        f"max {bench['max_s'] * 1e3:.1f} ms over {bench.get('repeats', 20)} calls.",
        "",
        "![report](load_state.png)",
        "",
    ]
    path.write_text("\n".join(lines))


def _limits_markdown(table: pd.DataFrame, twins: pd.DataFrame, by_eps: pd.DataFrame) -> list:
    tt = twin_table(twins)
    close = twins["twin_distance"] < 1.0
    lines = [
        "",
        "## Where the targets are out of reach",
        "",
        "Resistance signatures of different regimes coincide within the noise. For each training "
        "run, the distance to the nearest run of another regime, in units of one 50 ms window's "
        "measurement scatter at 0.2 % noise (RMS over the model's "
        f"{len(model_features()) - len(_KNOWN)} signature features; "
        "`signature_twins` in pipelines/load_state.py; ~0.7 is what noise alone puts between two "
        "4-window means of one state; below 1 two load states differ by less than one window's "
        "noise). "
        f"{close.mean():.0%} of runs have such a twin closer than 1; the median distance is "
        f"{twins['twin_distance'].median():.2f}. Cross-validated regime accuracy follows the "
        "distance:",
        "",
        "| distance to nearest other-regime signature | runs | share | regime accuracy |",
        "| --- | --- | --- | --- |",
    ]
    for _, m in tt.iterrows():
        lines.append(
            f"| {m['band']} | {m['runs']} | {m['share']:.0%} | {m['regime_accuracy']:.1%} |"
        )
    lines += [
        "",
        "By true epsilon (cross-validated windows): the regime calls fail where the first "
        "ball-pass harmonic vanishes (epsilon ~0.40 and ~0.535) and where R(epsilon) folds "
        "(below ~0.35 R rises again as epsilon falls), so that a clearance at one epsilon "
        "and a preload at another give one signature:",
        "",
        "| true epsilon | windows | regime accuracy | epsilon MAE | runs with a twin < 1 |",
        "| --- | --- | --- | --- | --- |",
    ]
    for _, m in by_eps.iterrows():
        lines.append(
            f"| {m['band']} | {m['windows']} | {m['regime_accuracy']:.1%} | "
            f"{m['epsilon_mae']:.3f} | {m['twinned_runs']:.0%} |"
        )
    lines += [
        "",
        "The estimator says so: a call below "
        f"{CONFIDENT_PROBABILITY:.0%} probability is reported as uncertain, naming the rival "
        "regimes (`regime_confident` in the JSON). At the acceptance condition:",
        "",
        "| runs | confident calls | their accuracy | all calls' accuracy |",
        "| --- | --- | --- | --- |",
    ]
    for source, label in (("cv_fast", "CV, fast preset"), ("test_dem", "test, paper fidelity")):
        m = table[(table["source"] == source) & (table["condition"] == "acceptance")]
        if len(m):
            m = m.iloc[0]
            lines.append(
                f"| {label} | {m['regime_confident_share']:.0%} | "
                f"{m['regime_confident_accuracy']:.1%} | {m['regime_accuracy']:.1%} |"
            )
    return lines


# --- ship ---------------------------------------------------------------------------------------


def ship_table(train: pd.DataFrame) -> pd.DataFrame:
    """One 50 ms window and one window of another length per run, features as float32."""
    rng = np.random.default_rng(7)
    parts = [train[(train["length_s"] == ACCEPT_LENGTH_S) & (train["window"] == 0)]]
    other = train[train["length_s"] != ACCEPT_LENGTH_S]
    picks = [rng.choice(ix) for _, ix in sorted(other.groupby("run_id").indices.items())]
    parts.append(other.iloc[picks])
    out = pd.concat(parts, ignore_index=True)
    keep = [
        "run_id",
        "length_s",
        "noise_fraction",
        "radial_load_n",
        "epsilon",
        "clearance_m",
        "regime",
        "omega_rad_s",
    ]
    feats = [c for c in model_features() if c not in keep]
    out = out[keep + feats].copy()
    numbers = [c for c in keep + feats if c not in ("run_id", "regime")]
    out[numbers] = out[numbers].astype(np.float32)
    out["regime"] = out["regime"].astype("category")
    return out


def write_example_trace(path: Path) -> None:
    """A measured-like trace: paper-fidelity DEM, F_r = 7000 N, clearance +8 um, 500 rad/s,
    0.1 s at 20 kHz, 0.2 % noise, 0.05 % drift, +12 uOhm offset, 0.1 uOhm steps."""
    from signatelec.data import generate as run
    from signatelec.data import read_dataset, spec_from_dict

    spec = spec_from_dict(
        {
            "dataset": {
                "name": "example",
                "seed": 8,
                "fidelity": "dem",
                "duration_s": 0.1,
                "settle_s": 0.03,
            },
            "design": [
                {
                    "kind": "grid",
                    "factors": {
                        "radial_load_n": {"value": 7000.0},
                        "clearance_m": {"value": 8e-6},
                        "omega_rad_s": {"value": 500.0},
                    },
                }
            ],
            "measurement": {
                "sample_rate_hz": SAMPLE_RATE_HZ,
                "noise_fraction": ACCEPT_NOISE,
                "drift_fraction": ACCEPT_DRIFT,
                "offset_ohm": 12e-6,
                "quantisation_ohm": QUANTISATION_OHM,
            },
        },
        "example",
    )
    d = path.parent / ".example_run"
    run(spec, d, workers=0)
    rec = read_dataset(d).iloc[0]
    r = np.asarray(rec["resistance_ohm"])
    t = np.arange(r.size) / rec["sample_rate_hz"]
    header = (
        f"# signatelec example trace: DEM (paper fidelity), F_r = 7000 N, clearance = +8 um "
        f"(epsilon {rec['epsilon']:.3f}), omega = 500 rad/s, {r.size} samples at 20 kHz;\n"
        f"# measured: 0.2 % white noise, 0.05 % drift, +12 uOhm offset, 0.1 uOhm steps\n"
    )
    body = pd.DataFrame({"time_s": np.round(t, 7), "resistance_ohm": r}).to_csv(
        index=False, float_format="%.10g"
    )
    tmp = path.with_suffix(".tmp")
    tmp.write_text(header + body)
    tmp.replace(path)
    import shutil

    shutil.rmtree(d, ignore_errors=True)


# --- main ---------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="work directory")
    parser.add_argument("--report", default=str(DEFAULT_REPORT), help="report directory")
    parser.add_argument("--quick", action="store_true", help="a small pipeline check")
    parser.add_argument("--ship", action="store_true", help="write the shipped table and example")
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="reuse the feature tables already in OUT (skip generation and features)",
    )
    args = parser.parse_args(argv)
    out, report = Path(args.out), Path(args.report)
    out.mkdir(parents=True, exist_ok=True)
    report.mkdir(parents=True, exist_ok=True)

    tables = [out / f"features_{n}.parquet" for n in ("train", "eval", "test")]
    if args.reuse and all(p.is_file() for p in tables):
        train, evaluation, test_eval = (pd.read_parquet(p) for p in tables)
        log(f"features: reused {', '.join(p.name for p in tables)}")
    else:
        train_dir, test_dir = generate(out, args.quick)
        runs, test_runs = load_runs(train_dir), load_runs(test_dir)
        t0 = time.perf_counter()
        train = train_table(runs)
        evaluation = eval_table(runs, args.quick)
        test_eval = eval_table(test_runs, args.quick)
        for table, path in zip((train, evaluation, test_eval), tables, strict=True):
            table.to_parquet(path, index=False)
        log(
            f"features: {len(train)} training, {len(evaluation)} + {len(test_eval)} evaluation "
            f"windows in {time.perf_counter() - t0:.0f} s"
        )

    cv_path = out / "predictions_cv.parquet"
    cv = cross_validate(train, evaluation, 2 if args.quick else 5)
    model = train_model(train, source="pipelines/load_state.py (features_train.parquet)")
    save_model(model, out / "load_state.model")
    test = predict_rows(model, test_eval)
    cv.to_parquet(cv_path, index=False)
    test.to_parquet(out / "predictions_test.parquet", index=False)
    log(f"model: {model.info['n_rows']} rows, fit {model.info['fit_s']} s")

    shipped = ship_table(train)
    default = train_model(shipped, source="shipped table")
    test_default = predict_rows(default, test_eval)
    log(
        f"default model (shipped table): {default.info['n_rows']} rows, "
        f"fit {default.info['fit_s']} s"
    )

    table = metrics_table(cv, test, test_default)
    table.to_parquet(report / "load_state_metrics.parquet", index=False)
    twins = signature_twins(evaluation, cv)
    twins.to_parquet(report / "signature_twins.parquet", index=False)
    by_epsilon = epsilon_table(cv, twins)
    bench = benchmark(model)
    plot_report(cv, table, report / "load_state.png")
    write_markdown(table, bench, model.info, report / "load_state.md", twins, by_epsilon)
    (report / "benchmark.json").write_text(json.dumps(bench, indent=2))
    acc = table[table["condition"] == "acceptance"]
    log(
        acc[
            [
                "source",
                "n",
                "fr_mape_pct",
                "epsilon_mae",
                "clearance_mae_um",
                "regime_accuracy",
                "radial_load_n_coverage",
                "epsilon_coverage",
            ]
        ].to_string()
    )
    log(f"estimate 1 s at 50 kHz: median {bench['median_s'] * 1e3:.1f} ms")

    if args.ship:
        SHIPPED_TABLE.parent.mkdir(parents=True, exist_ok=True)
        tmp = SHIPPED_TABLE.with_suffix(".tmp")
        shipped.to_parquet(tmp, index=False, compression="zstd")
        tmp.replace(SHIPPED_TABLE)
        log(
            f"wrote {SHIPPED_TABLE} ({SHIPPED_TABLE.stat().st_size / 1e3:.0f} kB, "
            f"{len(shipped)} rows)"
        )
        write_example_trace(EXAMPLE_TRACE)
        log(f"wrote {EXAMPLE_TRACE}")
    return {"metrics": table, "benchmark": bench, "quick": args.quick}


if __name__ == "__main__":
    main()
