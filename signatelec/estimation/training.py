"""Training the load-state estimator, and the recipe of the default model.

:func:`train_model` fits a :class:`~signatelec.estimation.models.LoadStateEstimator` on a feature
table with labels (:func:`features_from_dataset` makes one from a ``signatelec generate``
directory). The default model, which ``signatelec estimate`` uses without ``--model``, is
:func:`train_default_model`: the default estimator on the feature table shipped in
``signatelec/estimation/data`` (:data:`DEFAULT_TABLE`), whose rows :func:`shipped_table` picks
from the training windows of :mod:`signatelec.studies.load_state` (``python
pipelines/load_state.py --ship`` writes it).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pandas as pd
import sklearn

from signatelec._version import __version__
from signatelec.config.bearing import Bearing, same_bearing
from signatelec.estimation.analysis import analyse_trace
from signatelec.estimation.condition import (
    CONDITION_LABELS,
    CONDITION_TARGET,
    SEVERITY_TARGET,
    ConditionEstimator,
    ConditionModel,
)
from signatelec.estimation.condition_features import (
    condition_feature_names,
    condition_features,
)
from signatelec.estimation.domain import Domain, domain_features
from signatelec.estimation.features import trace_feature_names, trace_features
from signatelec.estimation.models import (
    CLASS_TARGET,
    LEVEL_FEATURE,
    TARGETS,
    LoadStateEstimator,
    LoadStateModel,
)
from signatelec.measurement.band import N_HARMONICS
from signatelec.measurement.sanity import explains, screen_trace
from signatelec.measurement.traces import TraceError, prepare_trace

#: The trace features the model reads. The others are redundant for it (the median and the
#: IQR repeat the mean and the MAD, the band powers around the harmonics and the harmonic
#: fractions repeat the amplitudes, the folded waveform is a noisier synthesised one, the raw
#: moments and the white-noise estimate are noise-led) or describe the meter, not the bearing
#: (the drift): with all 52 the held-out errors are the same (F_r 0.49 %, epsilon 0.023,
#: regime 80.7 % against 0.50 %, 0.024, 80.2 %; training runs of pipelines/load_state.py).
MODEL_FEATURES = (
    "level_mean_ohm",
    "level_mad_rel",
    "psd_sub_rel",
    "psd_high_rel",
    "omega_rad_s",
    "ball_pass_slip",
    "harmonic_snr",
    "duration_ball_passes",
    "h1_amp_ohm",
    "h1_rel",
    "h2_rel",
    "h3_rel",
    "h4_rel",
    "h2_even_rel",
    "h3_even_rel",
    "h4_even_rel",
    "h2_odd_rel",
    "noise_rms_rel",
    "noise_density_rel",
    "noise_colour",
    "noise_sub_fraction",
    "noise_kurtosis",
    "ripple_crest",
    "ripple_skew",
    "ripple_kurtosis",
    "ripple_asymmetry",
)
#: The trace features the condition model reads beside every condition feature: the speed
#: and the ball-pass ripple's size and shape (an outer-race spall adds to them) and the noise.
CONDITION_TRACE_FEATURES = (
    "omega_rad_s",
    "h1_rel",
    "h2_rel",
    "h3_rel",
    "h4_rel",
    "noise_rms_rel",
    "ripple_crest",
    "ripple_kurtosis",
)
#: Condition features not scored by the condition model's domain: they grow with the trace's
#: length by design (a steady line's height over the floor grows as sqrt(T)).
CONDITION_LENGTH_DEPENDENT = ("cage_revolutions",)
#: Shipped training table of the default model (features + labels): :func:`shipped_table`.
DEFAULT_TABLE = Path(__file__).parent / "data" / "load_state_features.parquet"
#: Shipped training table of the default condition model (features + condition labels).
CONDITION_TABLE = Path(__file__).parent / "data" / "condition_features.parquet"
#: Shipped calibration windows of the spall-length interval (features, condition, length):
#: held-out paper-fidelity runs (:func:`signatelec.studies.diagnosis.calibration_rows`).
CALIBRATION_TABLE = Path(__file__).parent / "data" / "condition_calibration.parquet"
#: Shipped training rows of paper-fidelity runs (velocity Verlet, dt = 1e-7 s), one 50 ms and
#: one 200 ms window each (:func:`shipped_rows`; ``python pipelines/load_state.py --ship-paper``
#: writes it): 1200 runs of the same design (``datasets/load_state_paper.toml``), 600 placed
#: where that model misread the regime (``datasets/load_state_paper_boundary.toml``: within
#: 6 um of the +-1 um boundaries, at the fold of R(epsilon) near epsilon 0.35 and the
#: first-harmonic null near 0.53-0.56) and 600 more at the fold (0.31-0.39) and the null
#: (0.52-0.61), where the stretch model erred most (``datasets/load_state_paper_fold.toml``).
#: The default model trains on them beside
#: :data:`DEFAULT_TABLE`. On the monitoring study's design states (paper fidelity, 0.2 s
#: windows at 0.2 % noise) the fast-only model erred alike on fast-preset runs of those
#: states, and its error fell with the runs: regime of a state's windows combined 86 % with
#: half of the 1200 fast runs, 90 % with all, 94 % with the uniform paper-fidelity runs too
#: (F_r within 1 %: 89 % -> 94 %); the paper-fidelity rows also teach the records' own
#: signature (the cage slip differs between the fidelities). The states it still misread
#: differ from their nearest twins of the other regime by 5-23 noise standard deviations of a
#: 2 s stretch (docs/monitor/twins.md): separable, and the placed runs took the design
#: records' regime from 94.6 to 97.9 % of stretches. docs/monitor/model_error.md,
#: pipelines/monitor_bias.py, pipelines/monitor_twins.py.
PAPER_TABLE = Path(__file__).parent / "data" / "load_state_paper_features.parquet"
#: Shipped training rows of the default model's ``stretch`` model: the mean features of
#: stretches of 3-40 windows of 50-200 ms, 12 per run of :data:`PAPER_TABLE`
#: (:func:`signatelec.studies.load_state.stretch_table`; ``python pipelines/load_state.py
#: --ship-paper`` writes it). A stretch of windows averages the noise away and keeps the
#: ripple's shape, which separates the states the window model misreads from their twins of
#: the other regime (docs/monitor/twins.md); on the monitoring study's design stretches this
#: model, asked about their mean features, halves the F_r and epsilon errors of the windows'
#: estimates combined (docs/monitor/model_error.md).
STRETCH_TABLE = Path(__file__).parent / "data" / "load_state_stretch_features.parquet"
#: Version of :func:`train_default_model`'s recipe, raised whenever it trains differently
#: from the same shipped tables (2: the faulty model on the condition model's runs alone, the
#: length interval calibrated per spall location; 3: the paper-fidelity rows of
#: :data:`PAPER_TABLE` beside the shipped table; 4: the stretch model on :data:`STRETCH_TABLE`;
#: 5: the stretch model's intervals from a model of its own out-of-fold error), so that a
#: cached default model is rebuilt.
DEFAULT_RECIPE = 5
#: Where the default model says it was trained.
DEFAULT_SOURCE = f"signatelec/estimation/data/{DEFAULT_TABLE.name} + {PAPER_TABLE.name}"
STRETCH_SOURCE = f"signatelec/estimation/data/{STRETCH_TABLE.name}"
CONDITION_SOURCE = f"signatelec/estimation/data/{CONDITION_TABLE.name}"
#: The shipped table holds, per training run, one window of this length (the acceptance
#: condition's) and one window of another length drawn with :data:`SHIPPED_SEED`.
SHIPPED_LENGTH_S = 0.05
SHIPPED_SEED = 7
#: Label and condition columns of the shipped table, before the features.
SHIPPED_COLUMNS = (
    "run_id",
    "length_s",
    "noise_fraction",
    "radial_load_n",
    "epsilon",
    "clearance_m",
    "regime",
    "omega_rad_s",
)


def model_features() -> list[str]:
    """The features the estimator reads, in order (:data:`MODEL_FEATURES`)."""
    return list(MODEL_FEATURES)


def condition_model_features() -> list[str]:
    """The features the condition estimator reads, in order."""
    return list(CONDITION_TRACE_FEATURES) + condition_feature_names()


def condition_domain_features(features) -> list[str]:
    """The condition features the in-domain score reads: not the speed (checked apart), nor
    those that grow with the length (the cage revolutions, each line's height over its floor)."""
    skip = (*CONDITION_LENGTH_DEPENDENT, "omega_rad_s")
    return [f for f in features if f not in skip and not f.endswith("_snr")]


def train_condition(
    table: pd.DataFrame,
    *,
    estimator: ConditionEstimator | None = None,
    source: str = "",
    calibration: pd.DataFrame | None = None,
) -> ConditionModel:
    """Fit a :class:`ConditionEstimator` on a feature table with a ``condition`` column (and
    ``spall_length_m``), grouped by ``run_id`` (or ``trace_id``); ``calibration``: held-out
    windows (the same columns) on which the spall-length interval is calibrated per spall
    location (:meth:`ConditionEstimator.calibrate_lengths`)."""
    features = condition_model_features()
    missing = [c for c in features if c not in table.columns]
    if missing:
        raise ValueError(
            f"feature table lacks {len(missing)} condition features, e.g. {missing[:3]}"
        )
    y = table[[c for c in (CONDITION_TARGET, SEVERITY_TARGET) if c in table.columns]].copy()
    y[CONDITION_TARGET] = y[CONDITION_TARGET].astype(str).to_numpy(dtype=object)
    if y[CONDITION_TARGET].nunique() < 2:
        raise ValueError(
            f"feature table holds one condition ({', '.join(y[CONDITION_TARGET].unique())}); "
            "a condition model learns two or more (of one, it would call every trace that one)"
        )
    group_col = "run_id" if "run_id" in table.columns else "trace_id"
    groups = table[group_col].to_numpy() if group_col in table.columns else None
    est = estimator or ConditionEstimator()
    t0 = time.perf_counter()
    est.fit(table[features], y, groups=groups)
    counts = y[CONDITION_TARGET].value_counts()
    info = {
        "trained_on": source,
        "n_rows": int(len(table)),
        "n_runs": int(len(np.unique(groups))) if groups is not None else int(len(table)),
        "classes": {str(k): int(v) for k, v in sorted(counts.items())},
        "coverage": est.coverage,
        "fit_s": round(time.perf_counter() - t0, 2),
        "ranges": {
            c: [float(table[c].min()), float(table[c].max())]
            for c in (SEVERITY_TARGET, "omega_rad_s", "cage_revolutions")
            if c in table.columns and table[c].notna().any()
        },
    }
    if calibration is not None:
        est.calibrate_lengths(
            calibration[features],
            calibration[CONDITION_TARGET].astype(str).to_numpy(dtype=object),
            calibration[SEVERITY_TARGET].to_numpy(dtype=np.float64),
        )
        info["length_calibration"] = {
            c: {"windows": n, "margin_log": round(m, 4)}
            for c, (n, m) in est.length_calibration_.items()
        }
    domain = Domain.fit(table, condition_domain_features(features))
    return ConditionModel(estimator=est, features=features, info=info, domain=domain)


def labels_of(table: pd.DataFrame) -> pd.DataFrame:
    """The label columns of a feature table (those of ``TARGETS`` and ``regime`` present), the
    regime as plain strings (a categorical column would pass its categories on)."""
    y = table[[c for c in (*TARGETS, CLASS_TARGET) if c in table.columns]].copy()
    if CLASS_TARGET in y:
        y[CLASS_TARGET] = y[CLASS_TARGET].astype(str).to_numpy(dtype=object)
    return y


def train_model(
    table: pd.DataFrame,
    *,
    estimator: LoadStateEstimator | None = None,
    source: str = "",
    bearing=None,
) -> LoadStateModel:
    """Fit a :class:`LoadStateEstimator` on a feature table with label columns.

    ``table`` holds :func:`model_features`, the labels present among ``TARGETS`` and
    ``regime``, and ``run_id`` (or ``trace_id``) grouping the rows of one simulation run;
    ``bearing``: the bearing of its traces, whose ball-pass line their features were read at
    (None: the seed's; :func:`table_bearing` reads it from a table of
    :func:`features_from_dataset`).
    """
    features = model_features()
    missing = [c for c in features if c not in table.columns]
    if missing:
        raise ValueError(f"feature table lacks {len(missing)} features, e.g. {missing[:3]}")
    y = labels_of(table)
    if y.columns.empty:
        raise ValueError(f"feature table has none of the labels {', '.join(TARGETS)}, regime")
    group_col = "run_id" if "run_id" in table.columns else "trace_id"
    groups = table[group_col].to_numpy() if group_col in table.columns else None
    est = estimator or LoadStateEstimator()
    t0 = time.perf_counter()
    est.fit(table[features], y, groups=groups)
    info = {
        "trained_on": source,
        "signatelec": __version__,
        "scikit_learn": sklearn.__version__,
        "n_rows": int(len(table)),
        "n_runs": int(len(np.unique(groups))) if groups is not None else int(len(table)),
        "targets": list(y.columns),
        "coverage": est.coverage,
        "fit_s": round(time.perf_counter() - t0, 2),
        "ranges": {
            c: [float(table[c].min()), float(table[c].max())]
            for c in ("radial_load_n", "epsilon", "clearance_m", "omega_rad_s", LEVEL_FEATURE)
            if c in table.columns
        },
    }
    domain = Domain.fit(table, domain_features(features))
    condition = None
    # (a table of one condition, a healthy dataset's, teaches no condition: it would call
    # every trace that one)
    if CONDITION_TARGET in table.columns and table[CONDITION_TARGET].nunique() > 1:
        condition = train_condition(table, source=source)
    if bearing is not None:
        info["bearing"] = bearing.name
    return LoadStateModel(
        estimator=est,
        features=features,
        info=info,
        domain=domain,
        condition=condition,
        bearing=bearing,
    )


# --- the default model ------------------------------------------------------------------------


def shipped_table(windows: pd.DataFrame) -> pd.DataFrame:
    """The default model's training table from measured training windows (one row each, with
    ``run_id``, ``window``, ``length_s``, the labels and the trace features): per run the first
    window of :data:`SHIPPED_LENGTH_S` and one window of another length, the numbers as float32
    (340 kB for 1200 runs)."""
    rng = np.random.default_rng(SHIPPED_SEED)
    parts = [windows[(windows["length_s"] == SHIPPED_LENGTH_S) & (windows["window"] == 0)]]
    other = windows[windows["length_s"] != SHIPPED_LENGTH_S]
    picks = [rng.choice(ix) for _, ix in sorted(other.groupby("run_id").indices.items())]
    parts.append(other.iloc[picks])
    return shipped_rows(pd.concat(parts, ignore_index=True))


def shipped_rows(windows: pd.DataFrame) -> pd.DataFrame:
    """Windows as a shipped table holds them: :data:`SHIPPED_COLUMNS` and the model's
    features, the numbers as float32, the regime categorical."""
    out = windows.reset_index(drop=True)
    keep = list(SHIPPED_COLUMNS)
    feats = [c for c in model_features() if c not in keep]
    out = out[keep + feats].copy()
    numbers = [c for c in keep + feats if c not in ("run_id", "regime")]
    out[numbers] = out[numbers].astype(np.float32)
    out["regime"] = out["regime"].astype("category")
    return out


def faulty_load_rows(condition_table: pd.DataFrame, first_run_id: int) -> pd.DataFrame | None:
    """The load-state training rows of the condition model's runs of the seed's bearing
    (healthy, spalled and unbalanced; their F_r is the static load), run ids numbered from
    ``first_run_id``; None when the table lacks the load-state labels or features.

    They alone train the ``faulty`` model: the load state of a trace the condition model calls
    faulty. Such a trace spans at least 95 % of the cage revolutions of the shortest training
    window (3.6: 0.19 s at 300 rad/s, 83 ms at 700 rad/s): on held-out outer-spall runs cut to 0.15
    and 0.1 s (one 0.2 % noise draw each, 150 runs) its F_r MAPE is 0.42 % against 0.48-0.51 %
    with the healthy windows in its training.
    A spall's events move the level and the ball-pass harmonics, and not alike everywhere:
    within 0.35 rad of the load direction they pull the mean resistance 0.36 % below its
    median, beyond 0.9 rad (the load zone's edge) not at all (+0.02 %; held-out outer-spall
    runs at the paper's fidelity), and F_r, learnt as log F_r + 3/4 log R, reads the mean.
    Among the load-state study's 2400 healthy windows these 540 runs (420 spalled or
    unbalanced, 19 outer spalls beyond 0.9 rad) were too few to teach that: the edge-of-zone
    spalls were answered like healthy traces, F_r 0.66 % low on average, the more so the
    further the mean stood above the median (correlation -0.53). Trained on these runs alone
    the faulty model's F_r error there is that of the middle of the zone, and its epsilon and
    clearance errors are smaller too (docs/diagnosis/outer_spall_load.md)."""
    cols = [*SHIPPED_COLUMNS, *(c for c in model_features() if c not in SHIPPED_COLUMNS)]
    if any(c not in condition_table.columns for c in cols):
        return None
    rows = condition_table[condition_table["bearing"] == "seed"]
    out = rows[cols].reset_index(drop=True)
    out["run_id"] = first_run_id + np.arange(len(out))
    out["regime"] = out["regime"].astype(str)
    return out


def default_training_table(table: pd.DataFrame | None = None) -> pd.DataFrame:
    """The default model's load-state rows: ``table`` (default :data:`DEFAULT_TABLE`, or a
    fresh :func:`shipped_table`), then :data:`PAPER_TABLE` (when shipped)."""
    parts = [pd.read_parquet(DEFAULT_TABLE) if table is None else table]
    if PAPER_TABLE.is_file():
        parts.append(pd.read_parquet(PAPER_TABLE))
    table = pd.concat(parts, ignore_index=True)
    table["regime"] = table["regime"].astype(str)
    return table


def train_default_model(table: pd.DataFrame | None = None) -> LoadStateModel:
    """The default model: the default :class:`LoadStateEstimator` on the shipped tables
    (:func:`default_training_table`, or ``table``, e.g. a part of it or a fresh
    :func:`shipped_table` with the paper-fidelity rows),
    with the ``stretch`` model on :data:`STRETCH_TABLE`, the default :class:`ConditionEstimator`
    on :data:`CONDITION_TABLE` beside it (unless
    ``table`` holds condition labels itself), its spall-length interval calibrated on
    :data:`CALIBRATION_TABLE`, and the ``faulty`` load-state model, trained on the condition
    model's runs of the seed's bearing (:func:`faulty_load_rows`), which answers where the
    condition model calls a fault."""
    if table is None:
        table = default_training_table()
    model = train_model(table, estimator=LoadStateEstimator(), source=DEFAULT_SOURCE)
    if STRETCH_TABLE.is_file():
        stretches = pd.read_parquet(STRETCH_TABLE)
        stretches["regime"] = stretches["regime"].astype(str)
        model.stretch = train_model(
            stretches, estimator=LoadStateEstimator(interval="residual"), source=STRETCH_SOURCE
        )
    if model.condition is not None or not CONDITION_TABLE.is_file():
        return model
    conditions = pd.read_parquet(CONDITION_TABLE)
    calibration = pd.read_parquet(CALIBRATION_TABLE) if CALIBRATION_TABLE.is_file() else None
    model.condition = train_condition(conditions, source=CONDITION_SOURCE, calibration=calibration)
    faulty = faulty_load_rows(conditions, int(table["run_id"].max()) + 1)
    if faulty is not None:
        model.faulty = train_model(faulty, estimator=LoadStateEstimator(), source=CONDITION_SOURCE)
    return model


# --- feature tables -----------------------------------------------------------------------------


def features_frame(
    traces, sample_rates_hz, omegas_rad_s, n_harmonics: int = N_HARMONICS, bearing=None
) -> pd.DataFrame:
    """Features of many traces (any lengths) of one bearing (default: the seed's, whose
    ball-pass line they are read at), one row each."""
    rows = [
        trace_features(
            r, analysis=analyse_trace(r, fs, om, n_harmonics=n_harmonics, bearing=bearing)
        )
        for r, fs, om in zip(traces, sample_rates_hz, omegas_rad_s, strict=True)
    ]
    return pd.DataFrame(rows, columns=trace_feature_names(n_harmonics))


def condition_frame(traces, sample_rates_hz, omegas_rad_s, bearing=None) -> pd.DataFrame:
    """Condition features of many traces of one bearing (any lengths), one row each."""
    rows = [
        condition_features(r, fs, om, bearing=bearing)
        for r, fs, om in zip(traces, sample_rates_hz, omegas_rad_s, strict=True)
    ]
    return pd.DataFrame(rows, columns=condition_feature_names())


def _dataset_bearing(path: Path):
    """The bearing of a dataset directory's base scene (None: the seed's, or a table)."""
    import json

    from signatelec.config.scene import Scene
    from signatelec.data.store import SPEC_FILE

    spec_file = Path(path) / SPEC_FILE
    if not spec_file.is_file():
        return None
    stored = json.loads(spec_file.read_text())
    scene = stored.get("spec", stored).get("scene", {})  # (the spec as the job read it)
    bearing = Scene.from_dict({"bearing": scene.get("bearing", {})}).bearing
    return None if same_bearing(bearing, None) else bearing


def screened_traces(
    table: pd.DataFrame, bearing=None
) -> tuple[list[np.ndarray], list[int], list[str]]:
    """The traces of a dataset table through the sanity layer
    (:func:`signatelec.measurement.sanity.screen_trace`): the (trimmed) traces kept, their row
    numbers, and one line per trace refused (a ball-pass line away from the labelled speed, a
    constant trace, a level that is not steady: labels that do not fit the trace). A trace
    labelled with a condition may show that condition's own line instead of the ripple.
    ``bearing``: the traces' (default: the seed's), whose geometry places the lines."""
    kept, rows, refused = [], [], []
    conditions = table[CONDITION_TARGET].to_numpy() if CONDITION_TARGET in table else None
    for i, (r, fs, om) in enumerate(
        zip(table["resistance_ohm"], table["sample_rate_hz"], table["omega_rad_s"], strict=True)
    ):
        name = f"trace {table['trace_id'].iloc[i]}" if "trace_id" in table else f"row {i}"
        label = conditions[i] if conditions is not None else None
        try:
            trace = prepare_trace(np.arange(len(r)) / fs, r, om, source=name, bearing=bearing)
            screened = screen_trace(trace, om, defect_lines=label is not None, bearing=bearing)
            if screened.defect_line is not None and not explains(screened.defect_line[0], label):
                raise TraceError(f"{name}: {screened.ripple.problem()}")
            kept.append(screened.trace.resistance_ohm)
            rows.append(i)
        except TraceError as exc:
            refused.append(str(exc))
    return kept, rows, refused


def features_from_dataset(path: str | Path) -> pd.DataFrame:
    """Feature table of a :mod:`signatelec.data` directory (or a Parquet feature table).

    A dataset holds one measured trace per row (``resistance_ohm`` as a list column, its
    ``sample_rate_hz`` and labels); each trace gives one row of features, grouped by trace_id.
    Failed traces are skipped, and so are traces the sanity layer refuses
    (:func:`screened_traces`; their one-line reasons in ``table.attrs["refused"]``). A dataset
    of another signal (its ``signal`` column: ``capacitance_f`` or ``impedance_ohm``) gives the
    features of that trace; the sanity layer, whose rules are a resistance's, is not applied.
    """
    path = Path(path)
    if path.is_file():
        table = pd.read_parquet(path)
        if "resistance_ohm" not in table.columns:
            return table
    else:
        from signatelec.data import read_dataset

        table = read_dataset(path)
    if "status" in table.columns:
        table = table[table["status"] == "ok"]
    signal = table["signal"].iloc[0] if "signal" in table.columns and len(table) else None
    column = signal or "resistance_ohm"
    lengths = table[column].map(len)
    table = table[lengths > 0].reset_index(drop=True)
    bearing = _dataset_bearing(path)  # (None: the seed's)
    if column == "resistance_ohm":
        traces, rows, refused = screened_traces(table, bearing)
    else:
        traces, rows, refused = [np.asarray(x) for x in table[column]], list(range(len(table))), []
    table = table.iloc[rows].reset_index(drop=True)
    rates, omegas = table["sample_rate_hz"].to_numpy(), table["omega_rad_s"].to_numpy()
    parts = [features_frame(traces, rates, omegas, bearing=bearing)]
    if CONDITION_TARGET in table:
        parts.append(condition_frame(traces, rates, omegas, bearing))
    keep = [
        c
        for c in ("trace_id", *TARGETS, CLASS_TARGET, "noise_fraction", *CONDITION_LABELS)
        if c in table
    ]
    out = pd.concat([table[keep].reset_index(drop=True), *parts], axis=1)
    out.attrs["refused"] = refused
    # as a dict, which a Parquet file of the table keeps (pandas writes attrs as JSON)
    out.attrs["bearing"] = None if bearing is None else bearing.to_dict()
    return out


def table_bearing(table: pd.DataFrame) -> Bearing | None:
    """The bearing whose ball-pass line a feature table's features were read at, as
    :func:`features_from_dataset` names it in ``table.attrs`` (kept by a Parquet file of the
    table); None: the seed's, or a table that does not say (pipelines/load_state.py's)."""
    stored = table.attrs.get("bearing")
    if stored is None or isinstance(stored, Bearing):
        return stored
    if not isinstance(stored, dict):
        raise ValueError(f"attrs.bearing = {stored!r}: must be a table of the bearing's fields")
    return Bearing.from_dict(stored, section="attrs.bearing")
