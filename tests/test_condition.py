"""The condition of a bearing: dataset factors and labels, the condition estimator's contract on
synthetic traces whose answers are known (tests/synthetic_traces.py), model files carrying it,
and ``signatelec estimate`` naming the condition in one line and in its JSON.

The detection figures on simulated (DEM) traces are measured by ``signatelec study diagnosis``
(docs/diagnosis), not here.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from threadpoolctl import threadpool_limits

from signatelec.config.defects import Defect
from signatelec.config.scene import Scene
from signatelec.data.design import condition_labels, condition_scene, design_traces
from signatelec.data.spec import SpecError, spec_from_dict
from signatelec.estimation.condition import CONDITIONS, ConditionEstimator, ConditionModel
from signatelec.estimation.condition_features import condition_features
from signatelec.estimation.diagnose import assess_condition, condition_line
from signatelec.estimation.features import trace_features
from signatelec.estimation.training import condition_model_features, train_condition
from tests.synthetic_traces import FS, OMEGA, spalled_trace


@pytest.fixture(autouse=True)
def _one_thread():
    with threadpool_limits(1):
        yield


# --- datasets -----------------------------------------------------------------------------------


def _spec(**factors) -> dict:
    return {
        "dataset": {"name": "diagnosis", "seed": 3, "fidelity": "quasistatic", "duration_s": 0.01},
        "design": [{"kind": "grid", "factors": factors}],
    }


def test_condition_factors_make_labelled_scenes():
    spec = spec_from_dict(
        _spec(
            condition={"values": list(CONDITIONS)},
            spall_length_m={"value": 2e-3},
            spall_depth_m={"value": 40e-6},
            unbalance_force_n={"value": 300.0},
        )
    )
    tasks = design_traces(spec)
    assert [t.factors["condition"] for t in tasks] == list(CONDITIONS)
    for task in tasks:
        scene = condition_scene(task, spec.scene)
        labels = condition_labels(scene)
        assert labels["condition"] == task.factors["condition"]
        if labels["condition"] in ("outer", "inner", "ball"):
            assert scene.defects == (
                Defect(location=labels["condition"], length_m=2e-3, depth_m=40e-6),
            )
            assert labels["spall_length_m"] == 2e-3 and labels["spall_depth_m"] == 40e-6
        else:
            assert not scene.defects and math.isnan(labels["spall_length_m"])
        assert labels["unbalance_force_n"] == (300.0 if labels["condition"] == "unbalance" else 0)


def test_labels_follow_the_base_scene():
    scene = Scene.from_dict({"defects": [{"location": "inner", "length_m": 1e-3, "depth_m": 3e-5}]})
    labels = condition_labels(scene)
    assert labels["condition"] == "inner" and labels["spall_length_m"] == 1e-3


@pytest.mark.parametrize(
    ("factors", "expected"),
    [
        ({"condition": {"value": "cracked"}}, "must be one of healthy, outer, inner, ball"),
        ({"condition": {"min": 0, "max": 1}}, "not a range"),
        ({"condition": {"value": 1.0}}, "must be one of"),
        ({"spall_length_m": {"value": 1.0}}, "spall_length_m.value = 1.0"),
        ({"spall_depth_m": {"value": -1e-6}}, "spall_depth_m.value = -1e-06"),
        ({"unbalance_force_n": {"value": 1e9}}, "unbalance_force_n.value"),
    ],
)
def test_bad_condition_factors_are_refused(factors, expected):
    with pytest.raises(SpecError, match=expected) as info:
        spec_from_dict(_spec(**factors))
    assert "\n" not in str(info.value)


# --- the estimator on synthetic traces ---------------------------------------------------------


def _synthetic_table(n_per_class: int, seed: int) -> pd.DataFrame:
    """Traces of every condition at random levels, noise (0.1-0.4 %), pulse heights and spall
    lengths (0.3-3 mm: the pulse lasts length / contact speed), with their features."""
    rng = np.random.default_rng(seed)
    rows = []
    for kind in CONDITIONS:
        for _ in range(n_per_class):
            length = float(np.exp(rng.uniform(np.log(3e-4), np.log(3e-3))))
            r = spalled_trace(
                kind,
                noise=rng.uniform(1e-3, 4e-3),
                pulse_rel=rng.uniform(0.02, 0.08),
                length_m=length,
                width_s=None,
                level=rng.uniform(1.5e-3, 4e-3),
                seed=int(rng.integers(2**31)),
                phase=None,
            )
            feats = trace_features(r, FS, OMEGA) | condition_features(r, FS, OMEGA)
            spall = kind in ("outer", "inner", "ball")
            rows.append(
                {
                    "run_id": len(rows),
                    "condition": kind,
                    "spall_length_m": length if spall else np.nan,
                    **feats,
                }
            )
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def synthetic():
    train, test = _synthetic_table(24, seed=1), _synthetic_table(8, seed=2)
    model = train_condition(
        train, estimator=ConditionEstimator(max_iter=40, n_splits=2), source="synthetic"
    )
    return model, test


def test_estimator_tells_the_conditions_apart(synthetic):
    model, test = synthetic
    frame = model.estimator.predict_frame(test[model.features])
    accuracy = float(np.mean(frame["condition"].to_numpy() == test["condition"].to_numpy()))
    # the synthetic lines stand 5-40x above their noise at 0.2 s: every condition is told
    assert accuracy >= 0.95
    proba = frame[[f"condition_probability_{c}" for c in model.estimator.classes_]].to_numpy()
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, rtol=1e-12)
    assert set(model.estimator.classes_) == set(CONDITIONS)


def test_spall_length_comes_with_an_interval(synthetic):
    model, test = synthetic
    frame = model.estimator.predict_frame(test[model.features])
    spall = test["condition"].isin(["outer", "inner", "ball"]).to_numpy()
    right = frame["condition"].to_numpy() == test["condition"].to_numpy()
    rows = spall & right
    length = test["spall_length_m"].to_numpy()[rows]
    lo, mid, hi = (frame[f"spall_length_m{k}"].to_numpy()[rows] for k in ("_low", "", "_high"))
    assert np.all((lo <= mid) & (mid <= hi))
    # nominal 90 % intervals over 24 held-out spalls: at least 75 % of them inside (binomial
    # 1st percentile of 24 draws at p = 0.9 is 18)
    assert np.mean((lo <= length) & (length <= hi)) >= 0.75
    # the pulse width is length / contact speed: the median within 30 % (median error)
    assert np.median(np.abs(mid / length - 1.0)) < 0.3
    healthy = ~spall
    assert np.all(np.isnan(frame["spall_length_m"].to_numpy()[healthy & right]))


def test_assessment_refuses_short_and_foreign_traces(synthetic):
    model, _ = synthetic
    r = spalled_trace("inner", duration_s=0.05)
    out, notes = assess_condition(r, FS, OMEGA, trace_features(r, FS, OMEGA), model)
    assert out["condition"] is None and "cage revolutions" in notes[0]
    assert condition_line(out) == "  condition = not assessed (see the notes)"
    rng = np.random.default_rng(5)
    noise = 2.5e-3 * (1.0 + 0.05 * rng.standard_normal(4000))  # 5 % white noise, no bearing
    out, notes = assess_condition(noise, FS, OMEGA, trace_features(noise, FS, OMEGA), model)
    assert out["condition"] is None and "unlike every training trace" in notes[0]
    r = spalled_trace("ball", noise=0.002, seed=9)
    out, notes = assess_condition(r, FS, OMEGA, trace_features(r, FS, OMEGA), model)
    assert out["condition"] == "ball" and out["condition_confident"]
    line = condition_line(out)
    assert line.startswith("  condition = ball  (probability ") and "spall length" in line
    assert json.loads(json.dumps(out))["condition"] == "ball"


def test_condition_model_features_are_computed():
    names = condition_model_features()
    assert len(names) == len(set(names))
    r = spalled_trace("outer")
    feats = trace_features(r, FS, OMEGA) | condition_features(r, FS, OMEGA)
    assert all(np.isfinite(feats[n]) for n in names)


# --- model files and the command line ----------------------------------------------------------

EXAMPLE = "datasets/example_trace.csv"


def _example_with(kind: str, rng, height: float) -> np.ndarray:
    """The example trace (a DEM run, 100 ms: 3.2 cage revolutions) with a synthetic condition
    added (tests/synthetic_traces.py's pulses) and 0.1 % more noise."""
    ex = pd.read_csv(EXAMPLE, comment="#")
    r = ex["resistance_ohm"].to_numpy()
    extra = spalled_trace(
        kind,
        duration_s=0.1,
        noise=0.0,
        pulse_rel=height,
        level=1.0,
        phase=None,
        seed=int(rng.integers(2**31)),
        length_m=float(rng.uniform(5e-4, 3e-3)),
        width_s=None,
    )
    # the synthetic trace's own ripple (1 + 0.1 % ...) is taken out: only the condition is added
    healthy = spalled_trace("healthy", duration_s=0.1, noise=0.0, level=1.0)
    return (r * (1.0 + (extra - healthy)) * (1.0 + 1e-3 * rng.standard_normal(r.size)), ex)


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    """A small load-state model with a condition model trained on the example trace with each
    condition added, saved to a file."""
    from signatelec.estimation.models import LoadStateEstimator
    from signatelec.estimation.persistence import save_model
    from signatelec.estimation.training import DEFAULT_TABLE, train_model

    table = pd.read_parquet(DEFAULT_TABLE)
    model = train_model(
        table[table["run_id"] % 4 == 0], estimator=LoadStateEstimator(max_iter=20, n_splits=2)
    )
    rng = np.random.default_rng(11)
    rows = []
    for kind in CONDITIONS:
        for _ in range(16):
            r, _ = _example_with(kind, rng, rng.uniform(0.02, 0.06))
            feats = trace_features(r, FS, OMEGA) | condition_features(r, FS, OMEGA)
            rows.append({"run_id": len(rows), "condition": kind, "spall_length_m": 1e-3, **feats})
    model.condition = train_condition(
        pd.DataFrame(rows), estimator=ConditionEstimator(max_iter=30, n_splits=2)
    )
    path = tmp_path_factory.mktemp("condition") / "with_condition.model"
    save_model(model, path)
    return path


def _run(args) -> int:
    from signatelec.cli import main

    try:
        main(args)
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


@pytest.mark.parametrize("kind", ["inner", "healthy"])
def test_estimate_names_the_condition(model_file, tmp_path, capsys, kind):
    rng = np.random.default_rng(21)
    r, ex = _example_with(kind, rng, 0.05)
    src = tmp_path / "trace.csv"
    pd.DataFrame({"time_s": ex["time_s"], "resistance_ohm": r}).to_csv(src, index=False)
    out = tmp_path / "estimate.json"
    code = _run(
        ["estimate", str(src), "--omega", "500", "--model", str(model_file), "--out", str(out)]
    )
    text = capsys.readouterr().out
    assert code == 0, text
    lines = [ln for ln in text.splitlines() if ln.startswith("  condition = ")]
    assert len(lines) == 1 and lines[0].startswith(f"  condition = {kind}  (probability ")
    res = json.loads(out.read_text())
    assert res["condition"] == kind
    probs = [res[f"condition_probability_{c}"] for c in CONDITIONS]
    assert sum(probs) == pytest.approx(1.0)
    for k in ("spall_length_m", "spall_length_m_low", "spall_length_m_high"):
        assert k in res
    if kind == "inner":
        # the spall's own line outgrows the ripple: named, not taken for a wrong --omega
        assert res["trace"]["ripple"] == "elsewhere"
        assert res["spall_length_m_low"] <= res["spall_length_m"] <= res["spall_length_m_high"]
    else:
        assert res["spall_length_m"] is None and "radial_load_n" in res


def test_a_model_file_of_one_condition_assesses_none(model_file, tmp_path, capsys):
    """A condition model trained on one condition (a healthy dataset's, as files written before
    such a table trained none hold) would call every trace healthy, with certainty: it is read
    as no condition model, and the estimate of a spalled trace names no condition."""
    from signatelec.estimation.persistence import load_model, save_model

    model = load_model(model_file)
    table = _synthetic_table(6, seed=5)
    healthy = table[table["condition"] == "healthy"]
    with pytest.raises(ValueError, match=r"one condition \(healthy\); a condition model"):
        train_condition(healthy)
    # such a file's model, as train_condition made it then
    features = model.condition.features
    estimator = ConditionEstimator(max_iter=10, n_splits=2)
    with threadpool_limits(1):
        estimator.fit(healthy[features], healthy[["condition"]].astype(object))
    model.condition = ConditionModel(estimator, features, {"classes": {"healthy": 6}}, None)
    assert list(model.condition.estimator.classes_) == ["healthy"]
    path = tmp_path / "one_condition.model"
    save_model(model, path)
    said = []
    assert load_model(path, log=said.append).condition is None
    assert said == [
        f"warning: model file {str(path)!r}: its condition model knows one condition (healthy); "
        "the bearing's condition is not assessed"
    ]
    r, ex = _example_with("inner", np.random.default_rng(21), 0.05)
    src = tmp_path / "trace.csv"
    pd.DataFrame({"time_s": ex["time_s"], "resistance_ohm": r}).to_csv(src, index=False)
    out = tmp_path / "estimate.json"
    _run(["estimate", str(src), "--omega", "500", "--model", str(path), "--out", str(out)])
    captured = capsys.readouterr()
    assert "condition = healthy" not in captured.out
    assert "its condition model knows one condition (healthy)" in captured.err
    if out.exists():  # (or refused: the spall's line, unexplained, is a wrong --omega)
        assert json.loads(out.read_text()).get("condition") is None


def test_estimate_reports_under_a_stated_prior(model_file, tmp_path, capsys):
    """--healthy-prior 0.9: the probabilities' odds are the training mix's (a fifth each here)
    times the ratio of the priors (Bayes' rule), the faults sharing 0.1 in the training mix's
    proportions: healthy against outer x (0.9 / 0.2) / (0.025 / 0.2) = 36, inner against outer
    x 1; the call and its confidence stay the training mix's, a note says the prior."""
    rng = np.random.default_rng(21)
    r, ex = _example_with("inner", rng, 0.05)
    src = tmp_path / "trace.csv"
    pd.DataFrame({"time_s": ex["time_s"], "resistance_ohm": r}).to_csv(src, index=False)
    res = {}
    for name, extra in (("mix", []), ("prior", ["--healthy-prior", "0.9"])):
        out = tmp_path / f"{name}.json"
        args = ["estimate", str(src), "--omega", "500", "--model", str(model_file)]
        assert _run([*args, "--out", str(out), "--quiet", *extra]) == 0
        res[name] = json.loads(out.read_text())
    p, q = ({c: r[f"condition_probability_{c}"] for c in CONDITIONS} for r in res.values())
    assert (q["healthy"] / q["outer"]) / (p["healthy"] / p["outer"]) == pytest.approx(36.0)
    assert (q["inner"] / q["outer"]) / (p["inner"] / p["outer"]) == pytest.approx(1.0)
    assert sum(q.values()) == pytest.approx(1.0)
    for key in ("condition", "condition_confident", "spall_length_m"):
        assert res["prior"][key] == res["mix"][key]
    assert res["prior"]["notes"][:-1] == res["mix"]["notes"]
    assert res["prior"]["notes"][-1].startswith("condition probabilities under P(healthy) = 0.9")
    code = _run(["estimate", str(src), "--omega", "500", "--model", str(model_file),
                 "--healthy-prior", "1.5"])  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert "--healthy-prior 1.5: must be a probability of healthy in (0, 1)" in err[0]


def test_a_healthy_call_outside_the_training_speeds_is_not_confident(model_file, tmp_path):
    """A condition model whose training speeds exclude the trace's warns that its call is an
    extrapolation, and a healthy call there is not confident however probable: outside its
    speeds the default model's confident healthy calls missed short spalls (README, Diagnosis).
    The same trace within the range: confident, no warning."""
    from signatelec.estimation.persistence import load_model, save_model

    rng = np.random.default_rng(21)
    r, ex = _example_with("healthy", rng, 0.05)
    src = tmp_path / "trace.csv"
    pd.DataFrame({"time_s": ex["time_s"], "resistance_ohm": r}).to_csv(src, index=False)
    model = load_model(model_file)
    res = {}
    for name, speeds in (("inside", [450.0, 550.0]), ("outside", [600.0, 700.0])):
        model.condition.info["ranges"] = {"omega_rad_s": speeds}
        save_model(model, tmp_path / f"{name}.model")
        out = tmp_path / f"{name}.json"
        args = ["estimate", str(src), "--omega", "500", "--model", str(tmp_path / f"{name}.model")]
        assert _run([*args, "--out", str(out), "--quiet"]) == 0
        res[name] = json.loads(out.read_text())
    assert res["inside"]["condition"] == res["outside"]["condition"] == "healthy"
    assert res["inside"]["condition_probability_healthy"] >= 0.8
    assert res["inside"]["condition_confident"] is True
    assert not any("training range 450" in n for n in res["inside"]["notes"])
    assert res["outside"]["condition_confident"] is False
    assert (
        "warning: condition: omega 500 rad/s is outside the condition model's training range "
        "600-700 rad/s: extrapolating; a healthy call there is not confident"
    ) in "\n".join(res["outside"]["notes"])


def test_the_training_speeds_are_read_with_a_margin_and_as_a_span():
    """The range is the runs' drawn speeds (300.1-698.9 rad/s of the design's 300-700): within
    1 % of it a speed is inside (the design's bounds are); a span of assessments' speeds is
    outside if any part is; a NaN speed is outside."""
    from types import SimpleNamespace

    from signatelec.estimation.diagnose import speed_warning

    model = SimpleNamespace(info={"ranges": {"omega_rad_s": [300.133, 698.892]}})
    for inside in (300.0, 700.0, (300.0, 700.0)):
        assert speed_warning(model, inside, "healthy") is None
    assert speed_warning(model, 290.0, "outer").endswith("300.133-698.892 rad/s: extrapolating")
    assert speed_warning(model, (500.0, 900.0), "healthy").startswith("omega 500-900 rad/s is")
    assert "a healthy call there is not confident" in speed_warning(model, 900.0, "healthy")
    # the same rule for a load-state model (its runs' 250.1-750.0 of 250-750 rad/s)
    from signatelec.estimation.domain import outside_speeds

    load = {"omega_rad_s": [250.148, 749.992]}
    assert outside_speeds(load, 250.0) is None and outside_speeds(load, 755.0) is None
    assert outside_speeds(load, 240.0) == (250.148, 749.992)
    assert outside_speeds(load, float("nan")) == (250.148, 749.992)
    assert outside_speeds(None, 2000.0) is None


@pytest.mark.parametrize("omega", [150.0, 1000.0])
def test_a_spall_outside_the_training_speeds_is_found_with_a_warning(omega):
    """The default condition model (300-700 rad/s) on quasi-static traces of 2 mm spalls at
    150 and 1000 rad/s, 0.2 % noise: the spall's line moves with the speed (BPFO, BPFI) and the
    model calls it confidently, with a warning that the speed is beyond its training; the
    healthy trace is not called confidently."""
    import warnings

    from signatelec.estimation.estimate import estimate
    from signatelec.estimation.persistence import default_model
    from signatelec.measurement.traces import prepare_trace

    model = default_model()
    rng = np.random.default_rng(1)
    duration = 0.6 if omega < 300.0 else 0.2
    for kind in ("outer", "inner", "healthy"):
        spall = {"location": kind, "length_m": 2e-3, "depth_m": 5e-5, "angle_rad": 0.0}
        scene = Scene.from_dict({"defects": [spall] if kind != "healthy" else []})
        scene = scene.with_overrides(fidelity="quasistatic", omega_rad_s=omega, duration_s=duration)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            clean = _steady(scene)
        r = clean * (1 + 0.002 * rng.standard_normal(clean.size))
        out = estimate(prepare_trace(np.arange(r.size) / 20000.0, r, omega), omega, model)
        warned = [n for n in out["notes"] if "outside the condition model's training range" in n]
        assert len(warned) == 1, out["notes"]
        if kind == "healthy":
            assert out["condition_confident"] is False
        else:
            assert out["condition"] == kind and out["condition_confident"] is True, out


def _steady(scene: Scene) -> np.ndarray:
    """The steady resistance of ``scene`` at 20 kHz."""
    from signatelec.engines.simulate import simulate

    return (
        simulate(scene.with_overrides(sample_rate_hz=20000.0)).steady()["resistance_ohm"].to_numpy()
    )


def test_a_defect_line_without_the_defect_is_a_wrong_speed(model_file, tmp_path, capsys):
    """A line on BPFI that the condition model does not call confidently is refused as the
    sanity layer says (a wrong --omega), exit 2."""
    ex = pd.read_csv(EXAMPLE, comment="#")
    # a pure tone at BPFI: a line, but no spall's pulses, harmonics or sidebands
    bpfi = 616.0
    t = ex["time_s"].to_numpy()
    r = ex["resistance_ohm"].to_numpy() * (1.0 + 0.01 * np.sin(2 * np.pi * bpfi * t))
    src = tmp_path / "tone.csv"
    pd.DataFrame({"time_s": t, "resistance_ohm": r}).to_csv(src, index=False)
    code = _run(["estimate", str(src), "--omega", "500", "--model", str(model_file)])
    err = capsys.readouterr().err
    assert code == 2 and "ripple at" in err and len(err.strip().splitlines()) == 1


def _shifted_spalls(n_per_class: int, seed: int, spread: dict[str, float]):
    """Numeric rows whose condition is told by feature 0 and whose log spall length is feature
    1 plus Gaussian scatter of ``spread[condition]`` (on the log scale)."""
    rng = np.random.default_rng(seed)
    kinds = np.repeat(["healthy", "outer", "inner", "ball"], n_per_class)
    centre = {"healthy": 0.0, "outer": 1.0, "inner": 2.0, "ball": 3.0}
    x = rng.uniform(-1.0, 1.0, (kinds.size, 3))
    x[:, 0] = [centre[k] for k in kinds] + 0.1 * rng.standard_normal(kinds.size)
    scatter = np.array([spread.get(k, 0.0) for k in kinds])
    length = np.exp(np.log(1e-3) + 0.5 * x[:, 1] + scatter * rng.standard_normal(kinds.size))
    length[kinds == "healthy"] = np.nan
    return x, kinds.astype(object), length


def test_length_interval_calibrated_per_spall_location():
    # trained where every location scatters by 0.1 in log length, asked where the outer-race
    # lengths scatter by 0.3 and the others by 0.05 (as the "fast" training runs against the
    # paper-fidelity runs): split-conformal margins per location on held-out windows of the
    # new kind give each location its nominal coverage (Romano et al. 2019: at least 90 %,
    # less than 90 % + 1/(n + 1) in expectation)
    train = _shifted_spalls(150, 1, dict.fromkeys(("outer", "inner", "ball"), 0.1))
    asked = {"outer": 0.3, "inner": 0.05, "ball": 0.05}
    est = ConditionEstimator(max_iter=40, n_splits=3).fit(
        train[0],
        pd.DataFrame({"condition": train[1], "spall_length_m": train[2]}),
        groups=np.arange(train[1].size),
    )
    test_x, test_kind, test_length = _shifted_spalls(600, 3, asked)

    def coverage(kind):
        frame = est.predict_frame(test_x)
        rows = (test_kind == kind) & (frame["condition"].to_numpy() == kind)
        lo, hi = (frame[f"spall_length_m{k}"].to_numpy()[rows] for k in ("_low", "_high"))
        return np.mean((lo <= test_length[rows]) & (test_length[rows] <= hi))

    before = {k: coverage(k) for k in asked}
    assert before["outer"] < 0.75 and before["inner"] > 0.97  # the out-of-fold margin misses
    est.calibrate_lengths(*_shifted_spalls(200, 2, asked))
    assert set(est.length_calibration_) == set(asked)
    assert all(n >= 190 for n, _ in est.length_calibration_.values())
    for kind in asked:
        # 600 test windows: binomial 3-sigma about 0.9 is +-0.037
        assert 0.86 <= coverage(kind) <= 0.95, kind
    # a location with too few calibration windows keeps the out-of-fold margin
    x, kind, length = _shifted_spalls(4, 4, asked)
    est.calibrate_lengths(x, kind, length)
    assert est.length_calibration_ == {}
    assert coverage("outer") == before["outer"]


#: Centres of feature 0 per condition in :func:`_gaussian_conditions`.
CENTRES = {"ball": 3.0, "healthy": 0.0, "inner": 2.0, "outer": 1.0}


def _gaussian_conditions(counts: dict[str, int], sigma: float, seed: int):
    """Rows whose feature 0 is Gaussian about its condition's centre with ``sigma`` (two more
    features of noise), ``counts[condition]`` of each, and their conditions."""
    rng = np.random.default_rng(seed)
    names = sorted(CENTRES)
    kinds = np.repeat(names, [counts[k] for k in names])
    x = rng.uniform(-1.0, 1.0, (kinds.size, 3))
    x[:, 0] = np.array([CENTRES[k] for k in kinds]) + sigma * rng.standard_normal(kinds.size)
    return x, kinds.astype(object)


def _posterior(x: np.ndarray, sigma: float, prior: dict[str, float]) -> np.ndarray:
    """Bayes posterior of each condition (sorted names) given feature 0 under ``prior``."""
    names = sorted(CENTRES)
    centre = np.array([CENTRES[k] for k in names])
    z = -0.5 * ((x[:, [0]] - centre) / sigma) ** 2 + np.log([prior[k] for k in names])
    p = np.exp(z - z.max(axis=1, keepdims=True))
    return p / p.sum(axis=1, keepdims=True)


def test_probabilities_moved_to_another_prior():
    # trained on equal numbers of each condition, asked where healthy bearings are 80 % of
    # them: the model's probabilities are posteriors under its training mix, and Bayes' rule
    # (p_k pi'_k / pi_k, renormalised; Saerens et al. 2002) moves them to the posterior under
    # the new mix. Over 4 seeds: mean |p - posterior| 0.094-0.117 as the model gives them,
    # 0.034-0.040 moved (the model's own error under its training mix: 0.050-0.065)
    names = sorted(CENTRES)
    train_x, train_kind = _gaussian_conditions(dict.fromkeys(names, 150), 0.5, 1)
    est = ConditionEstimator(max_iter=40, n_splits=3).fit(
        train_x, train_kind, groups=np.arange(train_kind.size)
    )
    model = ConditionModel(
        estimator=est,
        features=["f0", "f1", "f2"],
        info={"classes": dict.fromkeys(names, 150)},
        domain=None,
    )
    assert model.training_mix == dict.fromkeys(names, 0.25)
    prior = {"ball": 0.05, "healthy": 0.8, "inner": 0.05, "outer": 0.1}
    x, _ = _gaussian_conditions({k: int(4000 * v) for k, v in prior.items()}, 0.5, 3)
    frame = est.predict_frame(x)
    columns = [f"condition_probability_{k}" for k in names]
    truth = _posterior(x, 0.5, prior)
    before = np.abs(frame[columns].to_numpy() - truth).mean()
    moved = model.move_to_prior(frame, prior)
    after = np.abs(moved[columns].to_numpy() - truth).mean()
    assert after < 0.5 * before and after < 0.06
    assert (moved["condition"] == frame["condition"]).all()  # the call is the training mix's
    # a probability of healthy: the faults share the rest in the training mix's proportions
    by_healthy = model.move_to_prior(frame, 0.7)
    even = {k: (0.7 if k == "healthy" else 0.1) for k in names}
    assert np.allclose(by_healthy[columns], model.move_to_prior(frame, even)[columns])
    for bad, field in [
        (1.0, r"prior 1.0: must be a probability of healthy in \(0, 1\)"),
        (float("nan"), "prior nan: must be"),
        ({"healthy": 1.0}, r"prior \['healthy'\]: must name exactly"),
        (even | {"ball": 0.2}, "summing to 1"),
    ]:
        with pytest.raises(ValueError, match=field):
            model.move_to_prior(frame, bad)
    # a window not assessed (a monitor's table) stays empty; a table without the columns
    # (no condition assessed) is returned as it is, one with some of them is refused
    gaps = frame.copy()
    gaps.loc[:9, columns] = np.nan
    kept = model.move_to_prior(gaps, 0.7)
    assert kept.loc[:9, columns].isna().all().all()
    assert np.allclose(kept.loc[10:, columns], by_healthy.loc[10:, columns])
    plain = frame.drop(columns=columns)
    assert model.move_to_prior(plain, 0.7) is plain
    with pytest.raises(ValueError, match="lacks the probability columns"):
        model.move_to_prior(frame.drop(columns=columns[0]), 0.7)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_spalls_line_at_no_harmonic_is_read_past_when_the_fault_is_called(seed):
    """A 0.73 mm outer-race spall of the seed's bearing in the load zone (7780 N, a 10 um
    clearance, 571 rad/s; the fast DEM, 0.2 s after 30 ms of settling, 0.2 % noise) puts a
    line at 3.76 f_bp, at no harmonic of the ball-pass frequency, above the ripple (17 of 100
    such traces over the condition model's training design had been refused as a speed ~2-4
    times the true one). The ripple stands where the speed puts it all the same, and the
    default condition model calls outer confidently: the trace is read, the line read past
    with a note. Given 0.8 times its speed, the trace stays refused (the ripple is not where
    that speed puts it)."""
    import warnings

    from signatelec.engines.fidelity import apply_fidelity
    from signatelec.estimation.estimate import estimate
    from signatelec.estimation.persistence import default_model
    from signatelec.measurement.ripple import find_ripple
    from signatelec.measurement.traces import TraceError, prepare_trace

    omega = 571.1
    spall = {"location": "outer", "length_m": 0.73e-3, "depth_m": 54e-6, "angle_rad": -0.663}
    scene = Scene.from_dict({"defects": [spall]}).with_overrides(
        radial_load_n=7780.0, clearance_m=9.97e-6, omega_rad_s=omega
    )
    scene = apply_fidelity(scene, "fast")
    scene = scene.with_overrides(duration_s=scene.setup_time_s + 0.23)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        clean = _steady(scene)[-4000:]
    r = clean * (1 + 0.002 * np.random.default_rng(seed).standard_normal(clean.size))
    t = np.arange(r.size) / 20000.0
    line = find_ripple(r, 20000.0, omega)
    ratio = line.frequency_hz / line.expected_hz
    # the case: a line elsewhere, at no harmonic, beside the ripple found where it should be
    assert line.status == "elsewhere" and abs(ratio - round(ratio)) > 0.1, line
    assert line.near is not None and line.near.frequency_hz == pytest.approx(
        line.expected_hz, rel=0.005
    )
    model = default_model()
    out = estimate(prepare_trace(t, r, omega), omega, model)
    assert out["condition"] == "outer" and out["condition_confident"] is True
    assert [n for n in out["notes"] if "read past" in n], out["notes"]
    assert out["trace"]["ripple"] == "found" and out["trace"]["ripple_hz"] == pytest.approx(
        line.expected_hz, rel=0.005
    )
    with pytest.raises(TraceError, match="speed is about"):
        estimate(prepare_trace(t, r, 0.8 * omega), 0.8 * omega, model)
