"""The diagnosis study: how well the condition model tells a spall or an unbalance from a healthy
bearing, on held-out paper-fidelity DEM runs.

:func:`run_study` (``signatelec study diagnosis --out DIR``) runs it:

1. **generate**, for the seed's bearing and the catalogue's 6205: the training runs of
   ``datasets/diagnosis.toml`` (DEM at the "fast" preset; 0.2 s of steady trace after 30 ms of
   settling, clean signal at 20 kHz) and :data:`TEST_RUNS` held-out runs per condition of the
   same design with another seed at the paper's fidelity (velocity Verlet, dt = 1e-7 s, every
   effect); generation resumes where it stopped;
2. **features**: every run measured through
   :class:`~signatelec.measurement.model.MeasurementModel` (training: :data:`TRAIN_DRAWS` draws
   of white noise 0.05-1 % log-uniform, drift up to 0.1 %; test: the acceptance condition,
   0.2 % noise over the whole 0.2 s, and the noise scan :data:`NOISE_SCAN`), load-state and
   condition features of each;
3. **train** the condition model on every training window (both bearings), calibrate its
   spall-length interval per spall location on :data:`CALIBRATION_RUNS` held-out
   paper-fidelity runs per location and bearing (:func:`calibration_rows`), predict the test
   windows; the shipped default load-state model predicts F_r on them;
4. **false alarms** (:mod:`signatelec.studies.diagnosis_alarms`): held-out healthy runs
   enough to bound the false-alarm rate (Clopper-Pearson), each measured once;
5. **evaluate and report** (:mod:`signatelec.studies.diagnosis_report`): the acceptance table
   (healthy runs flagged, spalls at least the Hertz contact width detected and typed right,
   F_r MAPE with and without a defect, with bootstrap intervals per spall location), the
   false alarms, detection against spall length and against noise,
   Parquet, Markdown and PNG into the report directory, and the README's figures (a trace and
   its envelope spectrum per condition).

``ship_to`` writes the default condition model's training and calibration tables
(``signatelec/estimation/data/condition_features.parquet``, ``condition_calibration.parquet``).
"""

from __future__ import annotations

import time
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from threadpoolctl import threadpool_limits

from signatelec.config.catalogue import catalogue_bearing
from signatelec.config.constraints import HEALTHY
from signatelec.config.scene import Scene
from signatelec.data import generate as generate_dataset
from signatelec.data import spec_from_dict
from signatelec.estimation.condition import SPALLS
from signatelec.estimation.condition_features import condition_features
from signatelec.estimation.features import trace_features
from signatelec.measurement.model import MeasurementModel
from signatelec.studies.load_state import (
    QUANTISATION_OHM,
    fixed_draw,
    load_runs,
    train_draw,
)
from signatelec.studies.load_state_metrics import ACCEPT_NOISE

#: The bearings of the study: the seed's 6208 and a catalogue bearing of another size.
BEARINGS = ("seed", "6205")
#: Held-out paper-fidelity runs per condition and bearing.
TEST_RUNS = {HEALTHY: 40, "outer": 15, "inner": 15, "ball": 15, "unbalance": 10}
#: Acceptance windows per test run: the whole 0.2 s measured with independent noise draws
#: (the runs, not the windows, are independent draws of the load state and the defect).
ACCEPT_DRAWS = 3
#: Measured windows per training run, each its own draw of the load-state study's training
#: measurement (white noise 0.05-1 % log-uniform, drift up to 0.1 %, offset +-20 uOhm).
TRAIN_DRAWS = 2
#: The acceptance condition is the load-state study's (ACCEPT_NOISE, ACCEPT_DRIFT: 0.2 % white
#: noise, 0.05 % drift), here over 0.2 s at 20 kHz.
NOISE_SCAN = (5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2)
#: First spawn-key words of the measurement draws (training, acceptance, noise scan).
TRAIN_KEY, ACCEPT_KEY, SCAN_KEY = 500, 501, 600
#: Held-out healthy runs per bearing for the false-alarm rate (2 x 175 = 350 runs: with none
#: flagged the one-sided 95 % upper bound is 0.85 %, :mod:`signatelec.studies.diagnosis_alarms`).
ALARM_RUNS = 175
#: Runs per bearing of the quick variant (fast preset): a pipeline check.
QUICK_ALARM_RUNS = 2
#: Spawn-key word of the false-alarm runs' measurement draws.
ALARM_KEY = 700
#: Seed offset of the false-alarm runs (their draws share none with the training or test runs).
ALARM_SEED_OFFSET = 1000
#: Held-out runs per spall location and bearing on which the spall-length interval is
#: calibrated (the paper's fidelity, like the runs it is asked about; their own seed).
CALIBRATION_RUNS = 40
#: Runs per spall location and bearing of the quick variant.
QUICK_CALIBRATION_RUNS = 2
#: Seed offset of the calibration runs, and the spawn-key word of their measurement draws.
CALIBRATION_SEED_OFFSET, CALIBRATION_KEY = 2000, 800
SHIPPED_COLUMNS = ("run_id", "bearing", "noise_fraction", "radial_load_n", "condition")
#: The load-state labels the shipped table carries too: the default load-state model learns
#: from these runs (signatelec.estimation.training.faulty_load_rows); F_r is the static load.
LOAD_COLUMNS = ("length_s", "epsilon", "clearance_m", "regime", "omega_rad_s")
#: The steady window of every run (datasets/diagnosis.toml dataset.duration_s), s.
DURATION_S = 0.2
#: The training design (a file of the source tree, beside the package).
DEFAULT_SPEC = Path(__file__).resolve().parents[2] / "datasets" / "diagnosis.toml"

Log = Callable[[str], None]


def _quiet(msg: str) -> None:
    pass


def _rng(*key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence(14, spawn_key=tuple(int(k) for k in key)))


# --- 1. generate ------------------------------------------------------------------------------


def study_spec(
    spec_path: Path,
    bearing: str,
    test: bool,
    quick: bool,
    healthy_runs: int | None = None,
    spall_runs: int | None = None,
):
    """The dataset spec of a bearing's training runs (``test``: its held-out paper-fidelity
    runs); ``quick``: 3 training runs (test: 1) per condition, all at the "fast" preset.
    ``healthy_runs``: instead, that many held-out healthy runs of their own seed (the
    false-alarm runs of :mod:`signatelec.studies.diagnosis_alarms`); ``spall_runs``: that many
    held-out runs per spall location of their own seed (the spall-length calibration runs of
    :func:`calibration_rows`)."""
    data = tomllib.loads(Path(spec_path).read_text())
    ds = data["dataset"]
    index = BEARINGS.index(bearing) if bearing in BEARINGS else len(BEARINGS)
    ds["name"] = f"{ds['name']}_{bearing}" + ("_test" if test else "")
    ds["seed"] = ds["seed"] + 2 * index + (1 if test else 0)
    if healthy_runs is not None:
        blocks = data["design"]
        data["design"] = [b for b in blocks if b["factors"]["condition"]["value"] == HEALTHY]
        ds["name"] = f"{ds['name']}_alarms"
        ds["seed"] += ALARM_SEED_OFFSET
    elif spall_runs is not None:
        blocks = data["design"]
        data["design"] = [b for b in blocks if b["factors"]["condition"]["value"] in SPALLS]
        ds["name"] = f"{ds['name']}_calibration"
        ds["seed"] += CALIBRATION_SEED_OFFSET
    if test and not quick:
        ds["fidelity"] = "dem"
    if bearing != "seed":
        data.setdefault("scene", {})["bearing"] = {"designation": bearing}
        ratio = (
            catalogue_bearing(bearing).dynamic_load_rating_n / Scene().bearing.dynamic_load_rating_n
        )
    for block in data["design"]:
        condition = block["factors"]["condition"]["value"]
        if bearing != "seed" and "unbalance_force_n" in block["factors"]:
            f = block["factors"]["unbalance_force_n"]
            f["min"], f["max"] = f["min"] * ratio, f["max"] * ratio
        if healthy_runs is not None:
            block["n_traces"] = healthy_runs
        elif spall_runs is not None:
            block["n_traces"] = spall_runs
        elif quick:
            block["n_traces"] = 1 if test else 3
        elif test:
            block["n_traces"] = TEST_RUNS[condition]
    return spec_from_dict(data, str(spec_path))


def generate(
    out: Path, spec_path: Path, quick: bool, workers: int = 0, log: Log = _quiet
) -> dict[tuple[str, bool], Path]:
    """Generate (or resume) every bearing's training and test runs: their directories."""
    dirs = {}
    for bearing in BEARINGS:
        for test in (False, True):
            spec = study_spec(spec_path, bearing, test, quick)
            d = out / f"runs_{bearing}" / ("test" if test else "train")
            t0 = time.perf_counter()
            summary = generate_dataset(spec, d, workers=workers, progress=log is not _quiet)
            log(
                f"generate {spec.name}: {summary.generated} new traces, {summary.n_traces} in "
                f"all, {time.perf_counter() - t0:.0f} s"
            )
            dirs[(bearing, test)] = d
    return dirs


# --- 2. features -------------------------------------------------------------------------------


#: Run labels carried into the feature rows.
RUN_LABELS = (
    "radial_load_n",
    "epsilon",
    "clearance_m",
    "regime",
    "omega_rad_s",
    "condition",
    "spall_length_m",
    "spall_depth_m",
    "spall_angle_rad",
    "unbalance_force_n",
    "max_ball_load_n",
)


def measured_rows(runs: pd.DataFrame, bearing: str, draws: int, draw, key: int) -> list[dict]:
    """Each run measured ``draws`` times with ``draw(rng)`` over its whole window: rows of
    labels, load-state and condition features."""
    b = Scene().bearing if bearing == "seed" else catalogue_bearing(bearing)
    meter = MeasurementModel(sample_rate_hz=20000.0, quantisation_ohm=QUANTISATION_OHM)
    rows = []
    for run in runs.itertuples(index=False):
        clean = np.asarray(run.resistance_clean_ohm, dtype=float)
        fs, omega = float(run.sample_rate_hz), float(run.omega_rad_s)
        for w in range(draws):
            rng = _rng(key, BEARINGS.index(bearing), run.trace_id, w)
            d = draw(rng)
            r = meter.measure(clean, d, rng)
            feats = trace_features(r, fs, omega) | condition_features(r, fs, omega, bearing=b)
            labels = {k: getattr(run, k) for k in RUN_LABELS}
            rows.append(
                {
                    "run_id": f"{bearing}-{run.trace_id}",
                    "bearing": bearing,
                    "window": w,
                    "noise_fraction": d.noise_fraction,
                    **labels,
                    **feats,
                }
            )
    return rows


def feature_tables(
    out: Path, spec_path: Path, quick: bool, reuse: bool, workers: int = 0, log: Log = _quiet
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(training, test) rows: read from ``out`` when ``reuse`` and there, else generated,
    measured and written to ``out``. Test rows carry ``scan_noise`` (the noise they were
    measured at; the acceptance rows at :data:`ACCEPT_NOISE` have ``acceptance`` True)."""
    paths = [out / f"features_{n}.parquet" for n in ("train", "test")]
    if reuse and all(p.is_file() for p in paths):
        log(f"features: reused {', '.join(p.name for p in paths)}")
        return pd.read_parquet(paths[0]), pd.read_parquet(paths[1])
    dirs = generate(out, spec_path, quick, workers, log)
    t0 = time.perf_counter()
    train, test = [], []
    for bearing in BEARINGS:
        runs = load_runs(dirs[(bearing, False)], log)
        train += measured_rows(runs, bearing, TRAIN_DRAWS, train_draw, TRAIN_KEY)
        test_runs = load_runs(dirs[(bearing, True)], log)
        accept = measured_rows(
            test_runs, bearing, ACCEPT_DRAWS, fixed_draw(ACCEPT_NOISE), ACCEPT_KEY
        )
        test += [{**row, "scan_noise": ACCEPT_NOISE, "acceptance": True} for row in accept]
        for i, noise in enumerate(NOISE_SCAN):
            if noise == ACCEPT_NOISE:
                continue
            rows = measured_rows(test_runs, bearing, 1, fixed_draw(noise), SCAN_KEY + i)
            test += [{**row, "scan_noise": noise, "acceptance": False} for row in rows]
    tables = (pd.DataFrame(train), pd.DataFrame(test))
    for table, path in zip(tables, paths, strict=True):
        table.to_parquet(path, index=False)
    log(
        f"features: {len(tables[0])} training, {len(tables[1])} test windows in "
        f"{time.perf_counter() - t0:.0f} s"
    )
    return tables


# --- 3. train and predict -----------------------------------------------------------------------


def hertz_contact_width_m(bearing, ball_load_n: float, race: str) -> float:
    """Width of the Hertz contact of a ball carrying ``ball_load_n`` on ``race`` along the rolling
    direction, 2 a (Hamrock-Brewe ellipse of seed eqs 17-18, a along the in-plane radius r1 of
    seed eqs 12-13), m. A spall shorter than it is bridged by the contact."""
    from signatelec.config.bearing import raceway_radii
    from signatelec.physics.conductance import contact_ellipse

    _, _, radius_eq_m, alpha = raceway_radii(bearing)[race]
    modulus = bearing.ball_material.plane_strain_modulus_pa
    a_m, _, _ = contact_ellipse(ball_load_n, radius_eq_m, alpha, modulus)
    return 2.0 * float(a_m)


def contact_widths_m(table: pd.DataFrame) -> np.ndarray:
    """The Hertz contact width each row's spall is compared with: on its race at the run's
    largest ball load (the DEM's mean); for a ball's spall the wider of its two contacts."""
    out = np.full(len(table), np.nan)
    bearings = {b: Scene().bearing if b == "seed" else catalogue_bearing(b) for b in BEARINGS}
    for i, row in enumerate(table[["bearing", "condition", "max_ball_load_n"]].itertuples()):
        b, q = bearings[row.bearing], float(row.max_ball_load_n)
        if row.condition in ("outer", "inner"):
            out[i] = hertz_contact_width_m(b, q, row.condition)
        elif row.condition == "ball":
            out[i] = max(hertz_contact_width_m(b, q, r) for r in ("inner", "outer"))
    return out


def predict_rows(model, table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with the condition model's predictions alongside (``pred_`` columns)."""
    pred = model.estimator.predict_frame(table[model.features]).add_prefix("pred_")
    return pd.concat([table.reset_index(drop=True), pred], axis=1)


def load_predictions(table: pd.DataFrame) -> np.ndarray:
    """F_r of each seed-bearing row by the default load-state model, as ``signatelec
    estimate`` answers: its ``faulty`` model where the condition model called a fault (NaN
    for other bearings: the shipped load-state model knows the seed's bearing only)."""
    from signatelec.estimation.persistence import default_model

    model = default_model()
    out = np.full(len(table), np.nan)
    seed = (table["bearing"] == "seed").to_numpy()
    fault = (table["pred_condition"].astype(str) != HEALTHY).to_numpy()
    for rows, m in ((seed & ~fault, model), (seed & fault, model.faulty or model)):
        if rows.any():
            out[rows] = m.predict_frame(table[rows])["radial_load_n"].to_numpy()
    return out


def held_out_rows(
    out: Path,
    spec_path: Path,
    kind: str,
    runs_per_block: int,
    *,
    draws: int,
    draw,
    key: int,
    quick: bool = False,
    reuse: bool = True,
    workers: int = 0,
    log: Log | None = None,
) -> pd.DataFrame:
    """Held-out paper-fidelity runs (``quick``: the "fast" preset) of their own seed,
    generated (or resumed) into ``out/runs_<bearing>/<kind>`` and measured ``draws`` times
    each with ``draw``: ``kind`` "alarms", ``runs_per_block`` healthy runs per bearing;
    "calibration", that many per spall location and bearing. The measured rows are cached in
    ``out/features_<kind>.parquet`` (read again when ``reuse`` and complete)."""
    log = log or _quiet
    path = out / f"features_{kind}.parquet"
    spec_kw = {"healthy_runs" if kind == "alarms" else "spall_runs": runs_per_block}
    blocks = 1 if kind == "alarms" else len(SPALLS)
    n = runs_per_block * blocks * draws * len(BEARINGS)
    rows = pd.read_parquet(path) if reuse and path.is_file() else None
    if rows is None or len(rows) != n:
        parts = []
        for bearing in BEARINGS:
            spec = study_spec(spec_path, bearing, True, quick, **spec_kw)
            d = out / f"runs_{bearing}" / kind
            t0 = time.perf_counter()
            summary = generate_dataset(spec, d, workers=workers)
            log(
                f"generate {spec.name}: {summary.generated} new runs, {summary.n_traces} in all, "
                f"{time.perf_counter() - t0:.0f} s"
            )
            parts += measured_rows(load_runs(d, log), bearing, draws, draw, key)
        rows = pd.DataFrame(parts)
        rows.to_parquet(path, index=False)
    return rows


def alarm_predictions(
    out: Path,
    spec_path: Path,
    model,
    *,
    quick: bool,
    reuse: bool = True,
    workers: int = 0,
    log: Log | None = None,
) -> pd.DataFrame:
    """Generate (or resume) the false-alarm runs, measure each once at the acceptance
    condition and ask the condition ``model``: one row per run with its labels, features and
    ``pred_`` columns (cached as :func:`held_out_rows` says)."""
    n = QUICK_ALARM_RUNS if quick else ALARM_RUNS
    rows = held_out_rows(
        out,
        spec_path,
        "alarms",
        n,
        draws=1,
        draw=fixed_draw(ACCEPT_NOISE),
        key=ALARM_KEY,
        quick=quick,
        reuse=reuse,
        workers=workers,
        log=log,
    )
    return predict_rows(model, rows)


def calibration_rows(
    out: Path,
    spec_path: Path,
    *,
    quick: bool,
    reuse: bool = True,
    workers: int = 0,
    log: Log | None = None,
) -> pd.DataFrame:
    """The spall-length calibration windows: :data:`CALIBRATION_RUNS` held-out spalled runs
    per location and bearing at the paper's fidelity (the design's spall lengths, depths and
    positions, their own seed), each measured :data:`TRAIN_DRAWS` times as the training runs
    are (white noise 0.05-1 %): the runs the default model is asked about, not its "fast"
    training runs, so the conformal margin holds on them
    (:meth:`~signatelec.estimation.condition.ConditionEstimator.calibrate_lengths`)."""
    n = QUICK_CALIBRATION_RUNS if quick else CALIBRATION_RUNS
    return held_out_rows(
        out,
        spec_path,
        "calibration",
        n,
        draws=TRAIN_DRAWS,
        draw=train_draw,
        key=CALIBRATION_KEY,
        quick=quick,
        reuse=reuse,
        workers=workers,
        log=log,
    )


def shipped_calibration_table(rows: pd.DataFrame) -> pd.DataFrame:
    """The default condition model's calibration table: the calibration windows' labels and
    condition features, numbers as float32."""
    from signatelec.estimation.training import condition_model_features

    keep = ["run_id", "bearing", "window", "noise_fraction", "condition", "spall_length_m"]
    out = rows[keep + condition_model_features()].reset_index(drop=True).copy()
    numbers = [c for c in out.columns if c not in ("run_id", "bearing", "condition")]
    out[numbers] = out[numbers].astype(np.float32)
    for c in ("bearing", "condition"):
        out[c] = out[c].astype("category")
    return out


def shipped_condition_table(train: pd.DataFrame) -> pd.DataFrame:
    """The default condition model's training table: the first measured window of every
    training run, its labels and the condition and load-state models' features, numbers as
    float32."""
    from signatelec.estimation.training import condition_model_features, model_features

    rows = train[train["window"] == 0].assign(length_s=DURATION_S)
    keep = [*SHIPPED_COLUMNS, "spall_length_m", *LOAD_COLUMNS]
    feats = [c for c in condition_model_features() + model_features() if c not in keep]
    out = rows[keep + list(dict.fromkeys(feats))].reset_index(drop=True).copy()
    labels = ("run_id", "bearing", "condition", "regime")
    numbers = [c for c in out.columns if c not in labels]
    out[numbers] = out[numbers].astype(np.float32)
    for c in labels[1:]:
        out[c] = out[c].astype("category")
    return out


def calibration_check(model, calibration: pd.DataFrame) -> dict[str, tuple[int, float]]:
    """Coverage of the calibrated length interval on calibration runs it was not calibrated
    on: the runs split in two halves, each half's windows answered by ``model``'s estimator
    calibrated on the other half; per spall location, (windows detected and typed right,
    share of true lengths inside)."""
    import copy

    runs = np.unique(calibration["run_id"])
    half = calibration["run_id"].isin(runs[::2]).to_numpy()
    hits: dict[str, list[bool]] = {}
    for fit_rows in (half, ~half):
        est = copy.deepcopy(model.estimator)
        cal = calibration[fit_rows]
        est.calibrate_lengths(
            cal[model.features], cal["condition"].astype(str), cal["spall_length_m"]
        )
        rows = calibration[~fit_rows]
        frame = est.predict_frame(rows[model.features])
        truth = rows["condition"].astype(str).to_numpy()
        length = rows["spall_length_m"].to_numpy()
        inside = (frame["spall_length_m_low"] <= length) & (length <= frame["spall_length_m_high"])
        for c in SPALLS:
            right = (truth == c) & (frame["condition"].to_numpy() == c)
            hits.setdefault(c, []).extend(inside.to_numpy()[right])
    return {c: (len(h), float(np.mean(h)) if h else float("nan")) for c, h in hits.items()}


def _calibration_text(model, calibration: pd.DataFrame) -> str:
    """The length interval's margins, per spall location and out of fold, and their check on
    held-out halves of the calibration runs (:func:`calibration_check`), in words."""
    estimator = model.estimator
    per = "; ".join(
        f"{c} {m:+.3f} ({n} windows)" for c, (n, m) in estimator.length_calibration_.items()
    )
    oof = estimator.severity_.margin_ if estimator.severity_ is not None else float("nan")
    check = "; ".join(
        f"{c} {100 * v:.1f} % of {n}" for c, (n, v) in calibration_check(model, calibration).items()
    )
    return (
        f"margins on the log length: {per or 'none (too few windows)'}; out of fold on the "
        f"training runs {oof:+.3f}. Calibrated on half of these runs and asked about the other "
        f"half, the true length falls inside for {check} windows"
    )


def run_study(
    out: Path,
    report_dir: Path,
    spec_path: Path,
    *,
    quick: bool = False,
    reuse: bool = True,
    workers: int = 0,
    ship_to: Path | None = None,
    log: Log = _quiet,
) -> dict:
    """The whole study (module docstring); returns the acceptance figures. ``ship_to``: the
    directory the default condition model's training and calibration tables are written to
    (:data:`~signatelec.estimation.training.CONDITION_TABLE`,
    :data:`~signatelec.estimation.training.CALIBRATION_TABLE`)."""
    from signatelec.estimation.condition import ConditionEstimator
    from signatelec.estimation.training import (
        CALIBRATION_TABLE,
        CONDITION_TABLE,
        train_condition,
    )
    from signatelec.io import write_bytes_atomic
    from signatelec.studies.diagnosis_report import report

    t_start = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    train, test = feature_tables(out, spec_path, quick, reuse, workers, log)
    shipped = shipped_condition_table(train)
    # one thread: OpenMP threads spinning on a shared, busy machine only burn its CPU
    calibration = shipped_calibration_table(
        calibration_rows(out, spec_path, quick=quick, reuse=reuse, workers=workers, log=log)
    )
    t0 = time.process_time()
    with threadpool_limits(1):
        model = train_condition(
            shipped,
            estimator=ConditionEstimator(),
            source=f"{spec_path.name} (study)",
            calibration=calibration,
        )
        fit_cpu_s = time.process_time() - t0
        log(f"train: {len(shipped)} runs, {fit_cpu_s:.0f} s CPU")
        pred = predict_rows(model, test)
        pred["hertz_width_m"] = contact_widths_m(pred)
        pred["pred_load_radial_load_n"] = load_predictions(pred)
        alarms = alarm_predictions(
            out, spec_path, model, quick=quick, reuse=reuse, workers=workers, log=log
        )
    pred.to_parquet(out / "predictions_test.parquet", index=False)
    alarms.to_parquet(out / "predictions_alarms.parquet", index=False)
    if ship_to is not None:
        import io

        for table, name in ((shipped, CONDITION_TABLE.name), (calibration, CALIBRATION_TABLE.name)):
            buf = io.BytesIO()
            table.to_parquet(buf, index=False)
            path = Path(ship_to) / name
            write_bytes_atomic(path, buf.getvalue())
            log(f"shipped {path} ({path.stat().st_size / 1e3:.0f} kB, {len(table)} rows)")
    figures = report(
        pred,
        report_dir,
        out,
        info={
            "train_runs": int(shipped["run_id"].nunique()),
            "calibration_runs": int(calibration["run_id"].nunique()),
            "calibration": _calibration_text(model, calibration),
            "fit_cpu_s": fit_cpu_s,
            "quick": quick,
            "elapsed_s": time.perf_counter() - t_start,
        },
        model=model,
        alarms=alarms,
    )
    log(f"report: {report_dir}")
    return figures
