"""The load-state study: how well the estimator recovers F_r, epsilon, clearance and regime.

:func:`run_study` (``python pipelines/load_state.py``) runs it:

1. **generate**: the training runs of a dataset spec (``datasets/load_state.toml``: 1200 DEM
   runs at the "fast" preset, 0.2 s of steady trace each after 30 ms of settling, clean signal
   at 20 kHz; ~0.25 s of CPU per run) and :data:`TEST_RUNS_PER_REGIME` held-out test runs per
   regime of the same design at the paper's fidelity (velocity Verlet, dt = 1e-7 s; ~2.5 s per
   run); generation resumes where it stopped;
2. **features**: each run is cut into windows (:data:`TRAIN_WINDOWS`; at least 5 ball passes),
   each measured through :class:`signatelec.measurement.model.MeasurementModel` with its own
   draw (white noise 0.05-1 % log-uniform, random-walk drift up to 0.1 %, offset +-20 uOhm,
   0.1 uOhm quantisation) -> ``features_train.parquet``; the acceptance condition and the noise
   and length scans of :mod:`signatelec.studies.load_state_metrics` ->
   ``features_eval.parquet`` (training runs), ``features_test.parquet`` (test runs);
3. **train**: the estimator on every training window (``load_state.model``); cross-validation
   grouped by run (5 folds) predicts every evaluation window from a model that never saw its
   run -> ``predictions_cv.parquet``; the final model predicts the test runs ->
   ``predictions_test.parquet``; the default model's recipe
   (:func:`signatelec.estimation.training.shipped_table`, :func:`~signatelec.estimation.
   training.train_default_model`) predicts them too;
4. **evaluate** (:mod:`signatelec.studies.load_state_metrics`) and **report**
   (:mod:`signatelec.studies.load_state_report`) into the report directory.

``ship_to`` also writes the default model's training table there, ``example_to`` the example
trace (``datasets/example_trace.csv``).
"""

from __future__ import annotations

import json
import shutil
import time
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from signatelec.data import generate as generate_dataset
from signatelec.data import read_dataset, spec_from_dict
from signatelec.estimation.features import trace_features
from signatelec.estimation.models import LoadStateModel
from signatelec.estimation.persistence import save_model
from signatelec.estimation.training import (
    default_training_table,
    shipped_rows,
    shipped_table,
    train_default_model,
    train_model,
)
from signatelec.io import write_bytes_atomic
from signatelec.measurement.band import MIN_BALL_PASSES
from signatelec.measurement.model import MeasurementDraw, MeasurementModel
from signatelec.physics.kinematics import expected_ball_pass_hz
from signatelec.studies.load_state_metrics import (
    ACCEPT_DRIFT,
    ACCEPT_LENGTH_S,
    ACCEPT_NOISE,
    ACCEPTANCE,
    SAMPLE_RATE_HZ,
    SCANS,
    epsilon_table,
    metrics_table,
    signature_twins,
)
from signatelec.studies.load_state_report import benchmark, plot_report, write_markdown

QUANTISATION_OHM = 1e-7
OFFSET_OHM = 20e-6
#: Training windows: length (s) -> how many per run.
TRAIN_WINDOWS = {0.0125: 2, 0.025: 2, 0.05: 2, 0.1: 2, 0.2: 1}
TRAIN_NOISE = (5e-4, 1e-2)  # log-uniform
TRAIN_DRIFT = (0.0, 1e-3)
TEST_RUNS_PER_REGIME = 30
#: First spawn-key words of the measurement draws: training windows (+ their length's index),
#: acceptance windows, each scan's windows (+ the value's index).
TRAIN_KEY, ACCEPT_KEY, SCAN_KEYS = 100, 1, {"noise": 200, "length": 300}
#: The default model's paper-fidelity runs (``datasets/load_state_paper.toml``, then
#: ``datasets/load_state_paper_boundary.toml``): the windows measured of each (one per length,
#: each with its own :func:`train_draw`; spawn keys from :data:`PAPER_KEY`), and the offset of
#: the run ids of the first dataset (apart from the training runs'); the k-th dataset's run ids
#: start at k + 1 times it.
PAPER_WINDOWS = (0.05, 0.2)
PAPER_KEY = 150
PAPER_RUN_ID_OFFSET = 100000
#: The stretch model's rows (:func:`stretch_table`), per paper-fidelity run: this many
#: stretches, each of a number of windows drawn from :data:`STRETCH_WINDOWS` and one length
#: drawn from :data:`STRETCH_LENGTHS_S` (spawn keys from :data:`STRETCH_KEY`).
STRETCH_ROWS = 12
STRETCH_WINDOWS = (3, 5, 10, 15, 25, 40)
STRETCH_LENGTHS_S = (0.05, 0.1, 0.2)
STRETCH_KEY = 170

Log = Callable[[str], None]


def _quiet(msg: str) -> None:
    pass


# --- 1. generate ------------------------------------------------------------------------------


def study_spec(spec_path: Path, quick: bool, test: bool):
    """The dataset spec of the training runs (``test``: the held-out paper-fidelity runs);
    ``quick``: 8 (test: 2) runs per design block, 0.1 s each."""
    data = tomllib.loads(Path(spec_path).read_text())
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
    return spec_from_dict(data, str(spec_path))


def generate(out: Path, spec_path: Path, quick: bool, log: Log = _quiet) -> tuple[Path, Path]:
    """Generate (or resume) the training and test runs: their dataset directories."""
    dirs = []
    for test in (False, True):
        spec = study_spec(spec_path, quick, test)
        d = out / ("runs_test" if test else "runs")
        t0 = time.perf_counter()
        summary = generate_dataset(spec, d, workers=0, progress=log is not _quiet)
        log(
            f"generate {spec.name}: {summary.generated} new traces, {summary.n_traces} in all, "
            f"{time.perf_counter() - t0:.0f} s"
        )
        dirs.append(d)
    return dirs[0], dirs[1]


def load_runs(path: Path, log: Log = _quiet) -> pd.DataFrame:
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
    """Training windows: :data:`TRAIN_WINDOWS`, each with its own :func:`train_draw`."""
    rows = []
    for i, (length, count) in enumerate(TRAIN_WINDOWS.items()):
        rows += measured_windows(runs, length, count, train_draw, key=TRAIN_KEY + i)
    return pd.DataFrame(rows)


def eval_table(runs: pd.DataFrame, quick: bool) -> pd.DataFrame:
    """Acceptance windows (every 50 ms window) and the scans around it (one window each;
    ``quick``: every other noise level)."""
    accept = fixed_draw(ACCEPT_NOISE)
    rows = [
        {**row, "condition": "acceptance"}
        for row in measured_windows(runs, ACCEPT_LENGTH_S, 99, accept, key=ACCEPT_KEY)
    ]
    for condition, column, values in SCANS:
        if quick and condition == "noise":
            values = values[1::2]
        for i, value in enumerate(values):
            if value == ACCEPTANCE[column]:
                continue
            at = {**ACCEPTANCE, column: value}
            key = SCAN_KEYS[condition] + i
            draw = fixed_draw(at["noise_fraction"])
            windows = measured_windows(runs, at["length_s"], 1, draw, key=key)
            rows += [{**row, "condition": condition} for row in windows]
    return pd.DataFrame(rows)


def feature_tables(
    out: Path, spec_path: Path, quick: bool, reuse: bool, log: Log = _quiet
) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """(training, evaluation, test) windows: read from ``out`` when ``reuse`` and all there,
    else generated and measured, and written to ``out``."""
    paths = [out / f"features_{n}.parquet" for n in ("train", "eval", "test")]
    if reuse and all(p.is_file() for p in paths):
        log(f"features: reused {', '.join(p.name for p in paths)}")
        train, evaluation, test = (pd.read_parquet(p) for p in paths)
        return train, evaluation, test
    train_dir, test_dir = generate(out, spec_path, quick, log)
    runs, test_runs = load_runs(train_dir, log), load_runs(test_dir, log)
    t0 = time.perf_counter()
    tables = (train_table(runs), eval_table(runs, quick), eval_table(test_runs, quick))
    for table, path in zip(tables, paths, strict=True):
        table.to_parquet(path, index=False)
    log(
        f"features: {len(tables[0])} training, {len(tables[1])} + {len(tables[2])} evaluation "
        f"windows in {time.perf_counter() - t0:.0f} s"
    )
    return tables


def paper_table(runs: pd.DataFrame, run_id_offset: int = PAPER_RUN_ID_OFFSET) -> pd.DataFrame:
    """The paper-fidelity rows of the default model from their runs (:data:`PAPER_WINDOWS`),
    as :func:`~signatelec.estimation.training.shipped_rows` keeps them."""
    runs = runs.assign(trace_id=runs["trace_id"] + run_id_offset)
    rows = []
    for i, length in enumerate(PAPER_WINDOWS):
        rows += measured_windows(runs, length, 1, train_draw, key=PAPER_KEY + i)
    return shipped_rows(pd.DataFrame(rows))


def stretch_table(runs: pd.DataFrame, run_id_offset: int = PAPER_RUN_ID_OFFSET) -> pd.DataFrame:
    """The stretch model's rows from paper-fidelity runs: each the MEAN of the model's features
    over the windows of one stretch, drawn as a monitor's stretch is (:data:`STRETCH_ROWS` per
    run): n windows of one length at random offsets of the run's whole-pass tiling
    (:func:`~signatelec.studies.monitor_records.whole_passes`: a steady state that lasts), all
    measured with one :func:`train_draw` (white noise 0.05-1 %, drift, offset, quantisation),
    each with its own noise. The window model learns single windows; a stretch's mean features
    carry the ripple's shape with the noise averaged, which is what tells a state at the fold
    of R(epsilon), the first-harmonic null or a regime boundary from its twins
    (docs/monitor/twins.md). Rows as :func:`~signatelec.estimation.training.shipped_rows`
    keeps them, with ``n_windows``."""
    from signatelec.estimation.training import MODEL_FEATURES
    from signatelec.studies.monitor_records import whole_passes

    meter = MeasurementModel(sample_rate_hz=SAMPLE_RATE_HZ, quantisation_ohm=QUANTISATION_OHM)
    rows = []
    for run in runs.itertuples(index=False):
        fs, omega = float(run.sample_rate_hz), float(run.omega_rad_s)
        tile = whole_passes(np.asarray(run.resistance_clean_ohm, dtype=float), fs, omega)
        for k in range(STRETCH_ROWS):
            rng = _rng(STRETCH_KEY, run.trace_id, k)
            d = train_draw(rng)
            count = int(rng.choice(STRETCH_WINDOWS))
            length = float(rng.choice(STRETCH_LENGTHS_S))
            n = int(round(length * fs))
            if n * expected_ball_pass_hz(omega) / fs < MIN_BALL_PASSES:
                continue
            reps = np.tile(tile, n // tile.size + 2)
            feats = []
            for _ in range(count):
                o = int(rng.integers(tile.size))
                f = trace_features(meter.measure(reps[o : o + n], d, rng), fs, omega)
                feats.append([f[c] for c in MODEL_FEATURES])
            rows.append(
                {
                    "run_id": int(run.trace_id) + run_id_offset,
                    "length_s": length,
                    "noise_fraction": d.noise_fraction,
                    "radial_load_n": float(run.radial_load_n),
                    "epsilon": float(run.epsilon),
                    "clearance_m": float(run.clearance_m),
                    "regime": str(run.regime),
                    "n_windows": count,
                    **dict(zip(MODEL_FEATURES, np.mean(feats, axis=0), strict=True)),
                }
            )
    frame = pd.DataFrame(rows)
    out = shipped_rows(frame)
    out.insert(3, "n_windows", frame["n_windows"].astype(np.int16))
    return out


def _write_table(parts: list[pd.DataFrame], ship_to: Path, log: Log) -> None:
    table = pd.concat(parts, ignore_index=True)
    table["regime"] = table["regime"].astype(str).astype("category")
    Path(ship_to).parent.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(ship_to, table.to_parquet(index=False, compression="zstd"))
    log(f"wrote {ship_to} ({Path(ship_to).stat().st_size / 1e3:.0f} kB, {len(table)} rows)")


def ship_paper_table(
    out: Path, spec_paths: list[Path], ship_to: Path, stretch_to: Path, log: Log = _quiet
) -> Path:
    """Generate (or resume) the paper-fidelity runs of each of ``spec_paths`` into
    ``out/runs_<dataset name>`` (``out/runs_paper`` for the first) and write their
    :func:`paper_table` rows, one dataset after the other, to ``ship_to``, and their
    :func:`stretch_table` rows to ``stretch_to``."""
    parts, stretches = [], []
    for k, spec_path in enumerate(spec_paths):
        spec = spec_from_dict(tomllib.loads(Path(spec_path).read_text()), str(spec_path))
        d = Path(out) / ("runs_paper" if k == 0 else f"runs_{spec.name}")
        t0 = time.perf_counter()
        summary = generate_dataset(spec, d, workers=0, progress=log is not _quiet)
        log(f"generate {spec.name}: {summary.n_traces} traces, {time.perf_counter() - t0:.0f} s")
        runs = load_runs(d, log)
        parts.append(paper_table(runs, (k + 1) * PAPER_RUN_ID_OFFSET))
        t0 = time.perf_counter()
        stretches.append(stretch_table(runs, (k + 1) * PAPER_RUN_ID_OFFSET))
        log(f"stretches of {spec.name}: {time.perf_counter() - t0:.0f} s")
    _write_table(parts, ship_to, log)
    _write_table(stretches, stretch_to, log)
    return Path(ship_to)


# --- 3. train (and cross-validate) --------------------------------------------------------------


def predict_rows(model: LoadStateModel, table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with the model's predictions alongside (``pred_`` columns)."""
    pred = model.predict_frame(table).add_prefix("pred_")
    return pd.concat([table.reset_index(drop=True), pred], axis=1)


def cross_validate(
    train: pd.DataFrame, evaluation: pd.DataFrame, n_splits: int, log: Log = _quiet
) -> pd.DataFrame:
    """Predictions for every evaluation row from a model fitted without its run."""
    from sklearn.model_selection import GroupKFold

    runs = np.unique(train["run_id"])
    parts = []
    for k, (_, test_idx) in enumerate(GroupKFold(n_splits).split(runs, groups=runs)):
        held = set(runs[test_idx])
        t0 = time.perf_counter()
        model = train_model(train[~train["run_id"].isin(held)], source=f"cv fold {k + 1}")
        ev = evaluation[evaluation["run_id"].isin(held)]
        parts.append(predict_rows(model, ev))
        log(f"cv fold {k + 1}/{n_splits}: fit {time.perf_counter() - t0:.0f} s, {len(ev)} rows")
    return pd.concat(parts, ignore_index=True)


# --- the example trace ------------------------------------------------------------------------


def write_example_trace(path: Path) -> None:
    """A measured-like trace: paper-fidelity DEM, F_r = 7000 N, clearance +8 um, 500 rad/s,
    0.1 s at 20 kHz, 0.2 % noise, 0.05 % drift, +12 uOhm offset, 0.1 uOhm steps."""
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
    generate_dataset(spec, d, workers=0)
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
    write_bytes_atomic(path, (header + body).encode())
    shutil.rmtree(d, ignore_errors=True)


# --- the whole study ----------------------------------------------------------------------------

#: Columns of the acceptance figures logged at the end of a run.
SUMMARY_COLUMNS = [
    "source",
    "n",
    "fr_mape_pct",
    "epsilon_mae",
    "clearance_mae_um",
    "regime_accuracy",
    "radial_load_n_coverage",
    "epsilon_coverage",
]


def run_study(
    out: str | Path,
    report: str | Path,
    spec_path: str | Path,
    *,
    quick: bool = False,
    reuse: bool = False,
    ship_to: str | Path | None = None,
    example_to: str | Path | None = None,
    log: Log | None = print,
) -> dict:
    """Run the study: work files in ``out``, the report in ``report``; returns the metrics
    table and the benchmark. ``quick`` (a check of the whole chain, ~30 s): 24 training and 6
    test runs of 0.1 s, 2 folds. ``reuse``: the feature tables already in ``out``."""
    log = log or _quiet
    out, report = Path(out), Path(report)
    out.mkdir(parents=True, exist_ok=True)
    report.mkdir(parents=True, exist_ok=True)
    train, evaluation, test_eval = feature_tables(out, Path(spec_path), quick, reuse, log)

    cv = cross_validate(train, evaluation, 2 if quick else 5, log)
    model = train_model(train, source="pipelines/load_state.py (features_train.parquet)")
    save_model(model, out / "load_state.model")
    test = predict_rows(model, test_eval)
    cv.to_parquet(out / "predictions_cv.parquet", index=False)
    test.to_parquet(out / "predictions_test.parquet", index=False)
    log(f"model: {model.info['n_rows']} rows, fit {model.info['fit_s']} s")

    shipped = shipped_table(train)
    default = train_default_model(shipped if quick else default_training_table(shipped))
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
    log(table[table["condition"] == "acceptance"][SUMMARY_COLUMNS].to_string())
    log(f"estimate 1 s at 50 kHz: median {bench['median_s'] * 1e3:.1f} ms")

    if ship_to is not None:
        ship_to = Path(ship_to)
        ship_to.parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(ship_to, shipped.to_parquet(index=False, compression="zstd"))
        log(f"wrote {ship_to} ({ship_to.stat().st_size / 1e3:.0f} kB, {len(shipped)} rows)")
    if example_to is not None:
        write_example_trace(Path(example_to))
        log(f"wrote {example_to}")
    return {"metrics": table, "benchmark": bench, "quick": quick}
