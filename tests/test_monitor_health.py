"""The bearing's health over a long record: a condition assessed now and then, and its change.

Records are tiled from the quasi-static tier (as in tests/test_monitor.py) with 0.2 % white
noise; a spall adds the rectangular pulses of tests/synthetic_traces.py at its characteristic
line (Randall and Antoni 2011, eqs 1-4: BPFO for the outer race, BPFI modulated by the load
zone at the shaft speed for the inner), lasting the time the contact takes to cross it. The
condition model is trained on 0.2 s windows of the same tiles with each condition added.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from threadpoolctl import threadpool_limits

from signatelec.config.bearing import Bearing
from signatelec.config.scene import Scene
from signatelec.engines.simulate import simulate
from signatelec.estimation import envelope
from signatelec.estimation.condition import ConditionEstimator
from signatelec.estimation.condition_features import condition_features
from signatelec.estimation.evidence import stretches_and_changes
from signatelec.estimation.features import trace_features
from signatelec.estimation.models import LoadStateEstimator
from signatelec.estimation.monitor import MonitorSettings, monitor_trace
from signatelec.estimation.persistence import save_model
from signatelec.estimation.training import DEFAULT_TABLE, train_condition, train_model
from signatelec.physics.kinematics import characteristic_frequencies_hz
from signatelec.studies.monitor_records import whole_passes
from tests.cli_run import run_main
from tests.synthetic_traces import spalled_trace

FS = 20000.0
OMEGA = 500.0
NOISE = 0.002
KINDS = ("healthy", "outer", "inner")


@pytest.fixture(autouse=True)
def _one_thread():
    with threadpool_limits(1):
        yield


@pytest.fixture(scope="module")
def tile():
    """One ball-pass-periodic tile of the quasi-static tier: zero clearance at 5000 N."""
    scene = Scene().with_overrides(fidelity="quasistatic", radial_load_n=5000.0, duration_s=0.06)
    sig = simulate(scene).signals
    return whole_passes(sig.loc[sig["phase"] == "steady", "resistance_ohm"].to_numpy(), FS, OMEGA)


def _tiled(tile, seconds: float, offset: int = 0) -> np.ndarray:
    n = int(round(seconds * FS))
    return np.tile(tile, n // tile.size + 2)[offset : offset + n]


def _spall(kind: str, seconds: float, seed: int, height: float = 0.04, bearing=None) -> np.ndarray:
    """The relative change a spall of ``kind`` makes (0 for healthy), 1 mm long, at the lines
    of ``bearing`` (default: the seed's)."""
    if kind == "healthy":
        return np.zeros(int(round(seconds * FS)))
    pulses = spalled_trace(
        kind, duration_s=seconds, noise=0.0, pulse_rel=height, level=1.0, length_m=1e-3,
        width_s=None, phase=None, seed=seed, bearing=bearing,
    )  # fmt: skip
    healthy = spalled_trace("healthy", duration_s=seconds, noise=0.0, level=1.0, bearing=bearing)
    return pulses - healthy


@pytest.fixture(scope="module")
def model_file(tile, tmp_path_factory):
    """A small load-state model (the shipped table, 40 rounds) with a condition model trained
    on 0.2 s windows of the tile with each condition of :data:`KINDS` added (60 each: the
    condition model's domain has 60 features)."""
    table = pd.read_parquet(DEFAULT_TABLE)
    rng = np.random.default_rng(3)
    rows = []
    with threadpool_limits(1):
        model = train_model(table, estimator=LoadStateEstimator(max_iter=40, n_splits=2))
        for kind in KINDS:
            for _ in range(60):
                base = _tiled(tile, 0.2, int(rng.integers(tile.size)))
                extra = _spall(kind, 0.2, int(rng.integers(2**31)), rng.uniform(0.02, 0.06))
                r = base * (1.0 + extra) * (1.0 + NOISE * rng.standard_normal(base.size))
                feats = trace_features(r, FS, OMEGA) | condition_features(r, FS, OMEGA)
                rows.append({"run_id": len(rows), "condition": kind, "spall_length_m": 1e-3})
                rows[-1].update(feats)
        model.condition = train_condition(
            pd.DataFrame(rows), estimator=ConditionEstimator(max_iter=30, n_splits=2)
        )
    path = tmp_path_factory.mktemp("health") / "with_condition.model"
    save_model(model, path)
    return path


def _record(tile, plan, path, seed=0, bearing=None):
    """[(condition, seconds)] tiled with each stretch's spall (at the lines of ``bearing``) and
    0.2 % noise."""
    rng = np.random.default_rng(seed)
    parts = [
        _tiled(tile, s) * (1.0 + _spall(kind, s, seed + i, bearing=bearing))
        for i, (kind, s) in enumerate(plan)
    ]
    r = np.concatenate(parts)
    r = r * (1.0 + NOISE * rng.standard_normal(r.size))
    pd.DataFrame({"time_s": np.arange(r.size) / FS, "resistance_ohm": r}).to_parquet(path)
    return path


def _monitor(path, model_file, every_s):
    from signatelec.estimation.persistence import load_model

    model = load_model(model_file)
    settings = MonitorSettings(omega_rad_s=OMEGA, condition_every_s=every_s)
    windows = monitor_trace(path, model, settings).frame()
    return windows, stretches_and_changes(windows, settings.hop)


@pytest.mark.parametrize("kind", ["outer", "inner"])
def test_a_spall_that_appears_is_a_condition_change(model_file, tile, tmp_path, kind):
    """60 s healthy, then 60 s with a spall: one window in every 2 s is assessed, and the
    record's last (the others' condition is empty), the change is found within the
    assessments' cadence of its onset, alarmed as a condition change with its probability, and
    nothing else changes (the load is the same on both sides)."""
    path = _record(tile, [("healthy", 60.0), (kind, 60.0)], tmp_path / "spall.parquet")
    windows, (stretches, changes, alarms) = _monitor(path, model_file, 2.0)
    assessed = windows["condition_probability_healthy"].notna()
    # one window per 2 s block (60 of the 600), then the record's last, 1.8 s after
    starts = windows.loc[assessed, "start_s"].to_numpy()
    assert starts.size == 61 and starts[-1] == windows["start_s"].max() == pytest.approx(119.8)
    assert np.allclose(np.diff(starts[:-1]), 2.0)
    assert [s["condition"] for s in stretches] == ["healthy", kind]
    assert stretches[1]["condition_probability"] > 0.9
    assert len(changes) == 1 and changes[0]["time_s"] == pytest.approx(60.0, abs=2.0)
    kinds = [a["kind"] for a in alarms]
    assert kinds == ["condition"] and alarms[0]["what"] == f"condition healthy -> {kind}"
    assert alarms[0]["probability"] > 0.9
    # the line that names it: the envelope's peak at the kinematic defect frequency (Harris &
    # Kotzalas 2006, ch. 8), to within the 0.2 s window's resolution of 5 Hz
    line = {"outer": "bpfo", "inner": "bpfi"}[kind]
    faulty = windows[assessed & (windows["start_s"] > 62.0)]
    assert (faulty["condition_line"] == line).all()
    expected = characteristic_frequencies_hz(OMEGA, Bearing())[line]
    assert faulty["condition_line_hz"].to_numpy() == pytest.approx(expected, rel=1e-9)
    assert np.median(np.abs(faulty["condition_line_found_hz"] - expected)) < 5.0


def test_a_healthy_record_raises_no_condition_change(model_file, tile, tmp_path):
    path = _record(tile, [("healthy", 120.0)], tmp_path / "healthy.parquet", seed=5)
    windows, (stretches, changes, alarms) = _monitor(path, model_file, 2.0)
    assert changes == [] and alarms == []
    assert [s["condition"] for s in stretches] == ["healthy"]


def test_a_condition_that_is_off_costs_nothing(model_file, tile, tmp_path, monkeypatch):
    """Without assessments the envelope analysis is never run and no condition column is
    written; the load-state estimates are the same as with them."""
    path = _record(tile, [("healthy", 20.0)], tmp_path / "off.parquet", seed=6)
    with_condition, _ = _monitor(path, model_file, 2.0)
    calls = []
    real = envelope.analyse_envelope

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr("signatelec.estimation.diagnose.analyse_envelope", counted)
    without, _ = _monitor(path, model_file, None)
    assert calls == []
    assert not [c for c in without.columns if c.startswith("condition")]
    pd.testing.assert_series_equal(with_condition["radial_load_n"], without["radial_load_n"])


@pytest.mark.parametrize(
    ("option", "value", "allowed"),
    [
        ("--condition-every", "-1", ""),
        ("--condition-every", "0.1", ""),
        ("--condition-every", "nan", ""),
        *[
            ("--healthy-prior", v, ": must be a probability of healthy in (0, 1)")
            for v in ("0", "1", "nan", "-0.5")
        ],
    ],
)
def test_bad_condition_option_is_refused(
    model_file, tile, tmp_path, capsys, option, value, allowed
):
    """One line naming the option, its value (and what is allowed), exit 2, nothing written."""
    path = _record(tile, [("healthy", 2.0)], tmp_path / "short.parquet")
    out = tmp_path / "out"
    code = run_main(
        ["monitor", str(path), "--out", str(out), "--omega", "500", "--model", str(model_file),
         option, value, "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and f"{option} {float(value)!r}{allowed}" in err[0]
    assert not out.exists()


def _command(path, model_file, capsys) -> tuple[dict, str]:
    """(summary.json, printed text) of ``signatelec monitor`` on ``path``, one assessment every
    2 s, into ``out`` beside it."""
    import json

    out = path.parent / "out"
    code = run_main(
        ["monitor", str(path), "--out", str(out), "--omega", "500", "--model", str(model_file),
         "--condition-every", "2"]
    )  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0, text
    return json.loads((out / "summary.json").read_text()), text


def test_the_command_reports_the_condition(model_file, tile, tmp_path, capsys):
    """``signatelec monitor``: the stretches carry their condition, the alarm is printed, and
    the table, summary and picture are written."""
    path = _record(tile, [("healthy", 40.0), ("inner", 40.0)], tmp_path / "rec.parquet", seed=9)
    summary, text = _command(path, model_file, capsys)
    out = path.parent / "out"
    assert [s["condition"] for s in summary["stretches"]] == ["healthy", "inner"]
    assert summary["settings"]["condition_every_s"] == 2.0
    assert summary["settings"]["bearing"] is None and summary["settings"]["load_state"]
    assert [a["kind"] for a in summary["alarms"]] == ["condition"]
    assert "condition healthy -> inner" in text
    windows = pd.read_parquet(out / "windows.parquet")
    assert windows["condition"].notna().sum() == pytest.approx(40, abs=1)
    assert (out / "monitor.png").stat().st_size > 0


def test_a_condition_called_outside_its_training_speeds_is_warned_apart(
    model_file, tile, tmp_path, capsys
):
    """A condition model whose training speeds exclude the record's: each stretch's condition
    carries a warning of its own (``condition_warnings``, a note, "extrapolated" in the printed
    line; a healthy call is not confident there, ``condition_confident``, README, Diagnosis),
    and the load state's warnings and confidence are those of the same record within the
    range."""
    from signatelec.estimation.persistence import load_model, save_model

    model = load_model(model_file)
    runs = {}
    for name, speeds in (("inside", [450.0, 550.0]), ("outside", [600.0, 700.0])):
        model.condition.info["ranges"] = {"omega_rad_s": speeds}
        save_model(model, tmp_path / f"{name}.model")
        (tmp_path / name).mkdir()
        runs[name] = _command(
            _record(tile, [("healthy", 20.0), ("inner", 20.0)], tmp_path / name / "r.parquet", 9),
            tmp_path / f"{name}.model",
            capsys,
        )
    inside, outside = (runs[n][0]["stretches"] for n in ("inside", "outside"))
    assert [s["condition"] for s in outside] == ["healthy", "inner"]
    assert all(s["condition_warnings"] == [] for s in inside)
    healthy, inner = (s["condition_warnings"] for s in outside)
    assert healthy == [
        "condition: omega 500 rad/s is outside the condition model's training range 600-700 "
        "rad/s: extrapolating; a healthy call there is not confident (a short spall may be "
        "missed)"
    ]
    assert inner == [healthy[0].split(";")[0]]
    assert outside[0]["condition_speeds_rad_s"] == pytest.approx([OMEGA, OMEGA])
    assert [s["condition_confident"] for s in inside] == [True, True]
    assert [s["condition_confident"] for s in outside] == [False, True]
    for a, b in zip(inside, outside, strict=True):
        assert (a["warnings"], a["regime_confident"]) == (b["warnings"], b["regime_confident"])
    notes = runs["outside"][0]["notes"]
    assert sum("outside the condition model's training range" in n for n in notes) == 2
    assert runs["outside"][1].count("extrapolated") == 2 and "extrapolated" not in runs["inside"][1]


def test_a_fault_gone_into_a_healthy_call_beyond_the_training_speeds_is_not_confident():
    """A condition alarm into a healthy stretch whose assessments' speeds leave the condition
    model's range (500-900 rad/s of 300-700) is not confident (a healthy call there missed
    short spalls); the alarm into the fault is."""
    from types import SimpleNamespace

    from signatelec.estimation.monitor_report import qualify, qualify_alarms

    model = SimpleNamespace(info={"ranges": {"omega_rad_s": [300.0, 700.0]}})
    speeds = ([500.0, 520.0], [500.0, 650.0], [600.0, 900.0])
    stretches = [
        {
            "start_s": 60.0 * i,
            "end_s": 60.0 * (i + 1),
            "condition": c,
            "condition_probability": 0.97,
            "condition_speeds_rad_s": v,
        }
        for i, (c, v) in enumerate(zip(("healthy", "inner", "healthy"), speeds, strict=True))
    ]
    alarms = [
        {"time_s": 60.0, "kind": "condition", "what": "condition healthy -> inner"},
        {"time_s": 120.0, "kind": "condition", "what": "condition inner -> healthy"},
    ]
    notes = qualify(stretches, condition_model=model)
    qualify_alarms(alarms, stretches)
    assert [bool(s["condition_warnings"]) for s in stretches] == [False, False, True]
    assert [s["condition_confident"] for s in stretches] == [True, True, False]
    assert len(notes) == 1 and notes[0].startswith("stretch 120-180 s: condition: omega 600-900")
    assert [a["confident"] for a in alarms] == [True, False]


def test_a_stretch_condition_is_confident_as_estimate_calls_one():
    """A stretch's ``condition_confident`` follows ``estimate``'s rule for one trace: the call's
    probability (the mean of its assessments', on the training mix) at least
    CONFIDENT_CONDITION, and not a healthy call beyond the condition model's training speeds (a
    fault called there keeps its confidence); the printed line says "uncertain"."""
    from types import SimpleNamespace

    from signatelec.estimation.diagnose import CONFIDENT_CONDITION
    from signatelec.estimation.monitor_report import format_summary, qualify

    model = SimpleNamespace(info={"ranges": {"omega_rad_s": [300.0, 700.0]}})
    cases = [  # (call, probability, speeds, confident)
        ("healthy", CONFIDENT_CONDITION + 0.01, [500.0, 500.0], True),
        ("healthy", CONFIDENT_CONDITION - 0.01, [500.0, 500.0], False),
        ("outer", CONFIDENT_CONDITION - 0.01, [500.0, 500.0], False),
        ("outer", 0.99, [900.0, 950.0], True),
        ("healthy", 0.99, [900.0, 950.0], False),
    ]
    stretches = [
        {
            "start_s": 10.0 * i,
            "end_s": 10.0 * (i + 1),
            "condition": c,
            "condition_probability": p,
            "condition_speeds_rad_s": v,
        }
        for i, (c, p, v, _) in enumerate(cases)
    ]
    qualify(stretches, condition_model=model)
    assert [s["condition_confident"] for s in stretches] == [c[-1] for c in cases]
    summary = {
        "trace": {
            "n_samples": 2500000,
            "sample_rate_hz": 5e4,
            "duration_s": 50.0,
            "windows": 250,
            "windows_without_estimate": 0,
            "first_refusal": None,
        },
        "settings": {},
        "notes": [],
        "stretches": stretches,
        "alarms": [],
    }
    lines = format_summary(summary).splitlines()[-len(cases) :]
    assert [line.endswith("uncertain") for line in lines] == [not c[-1] for c in cases]
    # under a stated prior the probability shown is the prior's, the confidence the mix's
    summary["settings"] = {"healthy_prior": 0.9}
    lines = format_summary(summary).splitlines()[-len(cases) :]
    assert [line.endswith("uncertain on the training mix") for line in lines] == [
        not c[-1] for c in cases
    ]


def test_assessments_unlike_the_condition_model_s_traces_are_told_in_their_stretch():
    """Windows whose condition was not assessed because they are unlike every training trace
    of the condition model (an in-domain score, no call: an outer spall of a 6208 read by the
    seed's model from 24 s on) are counted in their stretch, with the first's time, warned of,
    and a healthy call there is not confident (a fault call is); without such windows, no
    key and no warning."""
    from signatelec.estimation.health import refused_assessments
    from signatelec.estimation.monitor_report import qualify

    start = np.arange(0.0, 40.0, 2.0)
    windows = pd.DataFrame(
        {
            "start_s": start,
            "end_s": start + 0.2,
            "condition": ["healthy" if t < 24.0 else None for t in start],
            "condition_in_domain_score": [0.5 if t < 24.0 else 1e-9 for t in start],
        }
    )
    assert refused_assessments(windows, 0.0, 24.0) == {}
    assert refused_assessments(windows, 0.0, 40.2) == {
        "condition_refused": 8,
        "condition_refused_first_s": 24.0,
    }
    stretches = [
        {"start_s": 0.0, "end_s": 40.2, "condition": c, "condition_probability": 0.95}
        | {"condition_assessments": 12}
        | refused_assessments(windows, 0.0, 40.2)
        for c in ("healthy", "outer")
    ]
    notes = qualify(stretches)
    assert [s["condition_confident"] for s in stretches] == [False, True]
    assert len(notes) == 2 and "8 of its 20 assessments (the first at 24 s)" in notes[0]


def test_a_stated_prior_moves_the_reported_probabilities_only(model_file, tile, tmp_path):
    """--healthy-prior P: each window's condition odds are the training mix's (a third each
    here) times the ratio of the priors (Bayes' rule), the faults sharing 1 - P in the training
    mix's proportions: healthy against outer x (0.95 / (1/3)) / (0.025 / (1/3)) = 38, inner
    against outer x 1; a stretch's mean probabilities move alike, a condition alarm's
    probability is its change's times 1 - sum_k p_k(before) p_k(after) of the moved means; the
    calls, changes, warnings and alarms found stay those of the training mix."""
    import json

    path = _record(tile, [("healthy", 40.0), ("inner", 40.0)], tmp_path / "rec.parquet", seed=9)
    runs = {}
    for name, extra in (("mix", []), ("prior", ["--healthy-prior", "0.95"])):
        out = tmp_path / name
        args = ["monitor", str(path), "--out", str(out), "--omega", "500", "--model"]
        code = run_main([*args, str(model_file), "--condition-every", "2", "--quiet", *extra])
        assert code == 0
        runs[name] = (
            pd.read_parquet(out / "windows.parquet"),
            json.loads((out / "summary.json").read_text()),
        )
    (mix, mix_summary), (prior, prior_summary) = runs["mix"], runs["prior"]
    ratio = {"healthy": 38.0, "inner": 1.0, "outer": 1.0}
    assessed = mix["condition_probability_healthy"].notna()
    assert assessed.sum() >= 39
    for k in ("healthy", "inner"):
        p, q = (w.loc[assessed, f"condition_probability_{k}"] for w in (mix, prior))
        p_o, q_o = (w.loc[assessed, "condition_probability_outer"] for w in (mix, prior))
        np.testing.assert_allclose((q / q_o) / (p / p_o), ratio[k])
    pd.testing.assert_series_equal(prior["condition"], mix["condition"])
    settings = prior_summary["settings"]
    assert settings["healthy_prior"] == 0.95 and mix_summary["settings"]["healthy_prior"] is None
    assert settings["condition_training_mix"] == pytest.approx(dict.fromkeys(KINDS, 1 / 3))

    def moved(stretch):
        p = {k: stretch[f"condition_probability_{k}"] * ratio[k] for k in KINDS}
        return {k: v / sum(p.values()) for k, v in p.items()}

    for a, b in zip(mix_summary["stretches"], prior_summary["stretches"], strict=True):
        assert (a["condition"], a["start_s"], a["warnings"]) == (
            b["condition"],
            b["start_s"],
            b["warnings"],
        )
        expected = moved(a)
        for k in KINDS:
            assert b[f"condition_probability_{k}"] == pytest.approx(expected[k], rel=1e-9)
        assert b["condition_probability"] == pytest.approx(expected[b["condition"]], rel=1e-9)
    assert mix_summary["changes"] == prior_summary["changes"]
    (alarm,) = prior_summary["alarms"]
    (before, after), (change,) = prior_summary["stretches"], prior_summary["changes"]
    assert alarm["kind"] == "condition" and alarm["time_s"] == mix_summary["alarms"][0]["time_s"]
    same = sum(
        before[f"condition_probability_{k}"] * after[f"condition_probability_{k}"] for k in KINDS
    )
    assert alarm["probability"] == pytest.approx(change["probability"] * (1.0 - same), rel=1e-9)
    assert alarm["confident"] == mix_summary["alarms"][0]["confident"]


def test_prior_moves_each_alarm_by_its_own_change():
    """report_under_prior pairs a condition alarm with the change that raised it (``change``
    i: stretches i and i + 1), even where two changes share a time (a zero-length stretch
    between them), and moves each stretch's mean probabilities by Bayes' rule."""
    from signatelec.estimation.condition import ConditionModel
    from signatelec.estimation.evidence import report_under_prior

    model = ConditionModel(
        estimator=ConditionEstimator(), features=[], info={"classes": dict.fromkeys(KINDS, 10)},
        domain=None,
    )  # fmt: skip
    model.estimator.classes_ = np.array(sorted(KINDS), dtype=object)
    probs = [(0.6, 0.3, 0.1), (0.1, 0.2, 0.7), (0.2, 0.7, 0.1)]  # healthy, inner, outer
    calls = ["healthy", "outer", "inner"]
    stretches = [
        {"start_s": a, "end_s": b, "condition": c, "condition_probability": max(p)}
        | {
            f"condition_probability_{k}": v
            for k, v in zip(("healthy", "inner", "outer"), p, strict=True)
        }
        for (a, b), c, p in zip([(0, 10), (10, 10), (10, 20)], calls, probs, strict=True)
    ]
    changes = [{"time_s": 10.0, "probability": 0.5}, {"time_s": 10.0, "probability": 0.8}]
    alarms = [
        {"time_s": 10.0, "kind": "condition", "change": 0, "probability": None},
        {"time_s": 10.0, "kind": "condition", "change": 1, "probability": None},
    ]
    report_under_prior(stretches, changes, alarms, model, 0.9)
    ratio = {"healthy": 0.9 * 3, "inner": 0.05 * 3, "outer": 0.05 * 3}

    def moved(p):
        q = {k: v * ratio[k] for k, v in zip(("healthy", "inner", "outer"), p, strict=True)}
        return {k: v / sum(q.values()) for k, v in q.items()}

    m = [moved(p) for p in probs]
    for s, mk, c in zip(stretches, m, calls, strict=True):
        assert s["condition_probability"] == pytest.approx(mk[c])
    for a, (i, p) in zip(alarms, [(0, 0.5), (1, 0.8)], strict=True):
        same = sum(m[i][k] * m[i + 1][k] for k in KINDS)
        assert a["probability"] == pytest.approx(p * (1.0 - same))


def test_a_record_of_a_spalled_bearing_answers_its_condition(model_file, tile, tmp_path, capsys):
    """From the first block on, the inner race's line is the strongest (not the ball-pass
    ripple): a wrong speed, unless the condition model confidently calls that very defect, as
    ``estimate`` rules; here it does, the windows are kept, and the stretch is answered by its
    condition alone (the spall takes the load features out of the load model's domain)."""
    path = _record(tile, [("inner", 12.0)], tmp_path / "inner.parquet", seed=4)
    summary, text = _command(path, model_file, capsys)
    (stretch,) = summary["stretches"]
    assert stretch["condition"] == "inner" and "radial_load_n" not in stretch
    assert "no load estimate" in text


@pytest.mark.parametrize("every_s", [0.4, 0.3])
def test_assessments_follow_a_cadence_shorter_than_a_block(model_file, tile, tmp_path, every_s):
    """--condition-every below the 2 s block assesses that often: every second 0.2 s window;
    a cadence between two windows (1.5 hops) takes the later, not every window."""
    path = _record(tile, [("healthy", 10.0)], tmp_path / "dense.parquet", seed=2)
    windows, _ = _monitor(path, model_file, every_s)
    assessed = windows.loc[windows["condition_probability_healthy"].notna(), "start_s"]
    assert len(assessed) == 25 and np.allclose(np.diff(assessed), 0.4)


@pytest.mark.parametrize(
    ("end", "last"),
    [
        ("past whole blocks", 9.8),
        ("last sample missing", 9.6),
        ("last speeds missing", 9.6),
        ("last block refused", 9.8),
        ("a gap, then less than a window", 9.8),
    ],
)
def test_the_records_last_usable_window_is_assessed(model_file, tile, tmp_path, end, last):
    """The record's last window that can be assessed is, if more than a hop after the last
    assessed, however the record ends: 0.15 s past its last whole 2 s block (fewer samples
    than a window), its last window cut short by the repair of a missing sample, refused for
    its missing speeds (the one before it, then), in a 2 s block refused as an open circuit,
    or in a gap followed by less than a window of samples (the last before them, then)."""
    seconds = {"past whole blocks": 10.15, "last block refused": 12.0}.get(end, 10.0)
    if end == "a gap, then less than a window":
        seconds = 11.1
    path = _record(tile, [("healthy", seconds)], tmp_path / "end.parquet", seed=3)
    frame = pd.read_parquet(path)
    settings = MonitorSettings(omega_rad_s=OMEGA, condition_every_s=3.0)
    if end == "last sample missing":
        frame.loc[frame.index[-1], "resistance_ohm"] = np.nan
    if end == "last speeds missing":
        frame["speed"] = np.where(frame["time_s"] >= 9.8, np.nan, OMEGA)
        settings = MonitorSettings(omega_rad_s=None, speed_column="speed", condition_every_s=3.0)
    if end == "last block refused":
        frame.loc[frame["time_s"] >= 10.0, "resistance_ohm"] = -1.0
    if end == "a gap, then less than a window":
        frame = frame[(frame["time_s"] < 10.0) | (frame["time_s"] >= 11.0)]
    frame.to_parquet(path)
    from signatelec.estimation.persistence import load_model

    windows = monitor_trace(path, load_model(model_file), settings).frame()
    # the record's last window (the refused block's, the gap's) comes after the last usable
    assert windows["start_s"].max() == pytest.approx({12.0: 11.8, 11.1: 10.8}.get(seconds, 9.8))
    starts = windows.loc[windows["condition"].notna(), "start_s"].to_numpy()
    assert starts == pytest.approx([0.0, 3.0, 6.0, 9.0, last])


def test_a_tracked_speed_does_not_follow_a_ball_spalls_line(model_file, tile, tmp_path):
    """A 3 mm ball spall whose line 2 BSF (10.6 % below the seed's ball pass) outshines the
    ripple, tracked from an --omega 1 % low: the screen's line is not a move of the speed
    (beyond the 5 % a tracked speed follows), so the record is refused as a wrong speed, as
    for --omega alone; it had been followed to 447 rad/s, every window out of domain."""
    from signatelec.estimation.persistence import load_model
    from signatelec.measurement.traces import TraceError

    seconds = 12.0
    pulses = spalled_trace("ball", duration_s=seconds, noise=0.0, pulse_rel=0.04, level=1.0,
                           length_m=3e-3, width_s=None, phase=None, seed=4)  # fmt: skip
    healthy = spalled_trace("healthy", duration_s=seconds, noise=0.0, level=1.0)
    r = _tiled(tile, seconds) * (1.0 + pulses - healthy)
    r = r * (1.0 + NOISE * np.random.default_rng(4).standard_normal(r.size))
    path = tmp_path / "ball.parquet"
    pd.DataFrame({"time_s": np.arange(r.size) / FS, "resistance_ohm": r}).to_parquet(path)
    model = load_model(model_file)
    for track in (False, True):
        settings = MonitorSettings(omega_rad_s=0.99 * OMEGA, track_speed=track)
        with pytest.raises(TraceError, match="the trace's speed is about 44"):
            monitor_trace(path, model, settings)


def test_a_defect_line_is_a_wrong_speed_when_the_condition_is_not_assessed(
    model_file, tile, tmp_path
):
    """With the condition off, nothing confirms a defect's line: the spalled record's first
    block is refused as a wrong speed, as it is for a model without a condition model."""
    from signatelec.estimation.persistence import load_model
    from signatelec.measurement.traces import TraceError

    path = _record(tile, [("inner", 4.0)], tmp_path / "inner.parquet", seed=4)
    settings = MonitorSettings(omega_rad_s=OMEGA, condition_every_s=None)
    with pytest.raises(TraceError, match="ripple at"):
        monitor_trace(path, load_model(model_file), settings)


# --- the condition's changes among the load's, on window tables of known content ------------


def _table(load_of, condition_of, every_s: float, seconds: float, seed: int = 0):
    """Windows of 0.2 s: load state ``load_of(t)`` (F_r in N, None: out of the load model's
    domain) with 0.2 % scatter, the level R ~ F_r^(-4/3) (Hertz); the condition
    ``condition_of(t)`` assessed every ``every_s`` with probability 0.95."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(int(round(seconds / 0.2))):
        t = 0.2 * i
        load = load_of(t)
        row = {"start_s": t, "end_s": t + 0.2, "status": "ok" if load else "out of domain"}
        if load:
            f = load * (1.0 + 0.002 * rng.standard_normal())
            row |= {
                "radial_load_n": f, "radial_load_n_low": 0.99 * f, "radial_load_n_high": 1.01 * f,
                "epsilon": 0.5 + 0.002 * rng.standard_normal(), "epsilon_low": 0.49,
                "epsilon_high": 0.51, "clearance_m": 0.0, "clearance_m_low": -1e-6,
                "clearance_m_high": 1e-6, "h1_rel": 1e-3 + 1e-5 * rng.standard_normal(),
                "h2_rel": 3e-4 + 1e-5 * rng.standard_normal(),
                "level_mean_ohm": 3e-3 * (load / 5000.0) ** (-4 / 3)
                * (1.0 + 0.002 * rng.standard_normal()),
            }  # fmt: skip
        if abs(t / every_s - round(t / every_s)) < 1e-6:
            called = condition_of(t)
            row |= {f"condition_probability_{k}": 0.95 if k == called else 0.025 for k in KINDS}
            row["condition"] = called
        rows.append(row)
    return pd.DataFrame(rows)


def test_a_spall_that_takes_the_load_out_of_domain_is_a_condition_change():
    """Usable load windows until 60 s, none after (the spall's pulses): one change, a condition
    alarm, the second stretch answered by its condition alone."""
    w = _table(lambda t: 5000.0 if t < 60.0 else None, lambda t: KINDS[2 * (t >= 60.0)], 2.0, 120)
    stretches, changes, alarms = stretches_and_changes(w, 0.2)
    assert [s["condition"] for s in stretches] == ["healthy", "inner"]
    assert "radial_load_n" in stretches[0] and "radial_load_n" not in stretches[1]
    assert [a["kind"] for a in alarms] == ["condition"]
    assert changes[0]["time_s"] == pytest.approx(60.0, abs=1.0)


def test_a_spall_out_of_the_load_models_domain_ends_the_stretch_with_few_assessments():
    """As above, the condition assessed every 20 s: three assessments a side, too few at the
    record's ends for the condition's own detector (the code before reported one stretch over
    the record, the load state of its first half and, on a tie of calls, healthy, without an
    alarm). The run of windows the load model cannot read is a stretch of its own: the change
    at its first window, the condition alarm there, each stretch with its own assessments."""
    w = _table(lambda t: 5000.0 if t < 60.0 else None, lambda t: KINDS[2 * (t >= 60.0)], 20.0, 120)
    stretches, changes, alarms = stretches_and_changes(w, 0.2)
    assert [s["condition"] for s in stretches] == ["healthy", "inner"]
    assert [s["condition_assessments"] for s in stretches] == [3, 3]
    assert "radial_load_n" in stretches[0] and "radial_load_n" not in stretches[1]
    assert [c["time_s"] for c in changes] == [60.0]
    assert changes[0]["what"].startswith("the load model cannot read the windows from here")
    assert [(a["kind"], a["time_s"]) for a in alarms] == [("condition", 60.0)]


@pytest.mark.parametrize("unread_s", [4.8, 5.0])
def test_a_span_the_load_model_cannot_read_is_a_stretch_from_5_s(unread_s):
    """A healthy bearing at 5000 N whose windows from 30 s lie out of the load model's domain
    for 4.8 or 5 s (a disturbance of the trace): shorter than 5 s the stretch spans it; from
    5 s it is a stretch of its own without a load estimate, between two changes (its first
    window, the first window read again) that raise no alarm (the condition is the same)."""
    w = _table(
        lambda t: None if 30.0 <= t < 30.0 + unread_s - 1e-9 else 5000.0,
        lambda t: KINDS[0],
        2.0,
        90,
    )
    stretches, changes, alarms = stretches_and_changes(w, 0.2)
    assert alarms == []
    if unread_s < 5.0:
        assert len(stretches) == 1 and changes == []
        return
    assert [c["time_s"] for c in changes] == pytest.approx([30.0, 35.0])
    assert [("radial_load_n" in s) for s in stretches] == [True, False, True]
    assert [s["condition"] for s in stretches] == ["healthy"] * 3


def test_a_spall_whose_windows_fall_in_and_out_of_the_domain_is_one_stretch():
    """Inner from 60 s, its windows out of the load model's domain in runs of 10 s every 20 s
    (as a tiled DEM ball spall's are, by how its pulses fall in the windows): one change, at
    the onset; the runs do not cut the spall's stretch (a rule that cut at every run's ends
    made 25 stretches of it, most without an assessment)."""
    w = _table(
        lambda t: None if t >= 60.0 and int((t - 60.0) // 10.0) % 2 == 0 else 5000.0,
        lambda t: KINDS[2 * (t >= 60.0)],
        2.0,
        300,
    )
    stretches, changes, alarms = stretches_and_changes(w, 0.2)
    assert [s["condition"] for s in stretches] == ["healthy", "inner"]
    assert [round(c["time_s"]) for c in changes] == [60]
    assert [a["kind"] for a in alarms] == ["condition"]


def test_condition_changes_without_a_usable_window_between_are_kept_apart():
    """No usable load window at all; healthy, inner from 100 s, healthy again from 170 s: two
    changes, three stretches."""
    w = _table(lambda t: None, lambda t: KINDS[2 * (100.0 <= t < 170.0)], 2.0, 240)
    stretches, changes, alarms = stretches_and_changes(w, 0.2)
    assert [s["condition"] for s in stretches] == ["healthy", "inner", "healthy"]
    assert [round(c["time_s"]) for c in changes] == [99, 169]
    assert [a["what"] for a in alarms] == [
        "condition healthy -> inner",
        "condition inner -> healthy",
    ]


def test_a_condition_change_among_load_steps_is_alarmed_at_the_nearest_one():
    """Load steps of 10 % every 20 s, the condition assessed once a minute, inner from 300 s:
    the condition change lies between the assessments at 240 and 300 s and is merged into the
    load step nearest its midpoint (280 s); every stretch after carries the spall."""
    w = _table(
        lambda t: 5000.0 * (1.1 if int(t // 20) % 2 else 1.0),
        lambda t: KINDS[2 * (t >= 290.0)],
        60.0,
        600,
    )
    stretches, changes, alarms = stretches_and_changes(w, 0.2)
    (alarm,) = [a for a in alarms if a["kind"] == "condition"]
    assert alarm["time_s"] == pytest.approx(280.0, abs=0.3)
    assert len(changes) == 29  # the load steps, no change of its own for the condition
    assert {s["condition"] for s in stretches if s["start_s"] >= 280.0 - 0.3} == {"inner"}
    assert {s["condition"] for s in stretches if s["end_s"] <= 280.0 + 0.3} == {"healthy"}


def test_a_healthy_stretch_whose_assessments_lean_to_a_spall_stays_healthy():
    """Every assessment of the first ten minutes gives the inner race the larger probability
    (0.5 against 0.3) but is called healthy by the condition model's own rule (its healthy
    threshold): the stretch is healthy with the assessments' mean probability, however many
    there are (their error is shared, not independent evidence); the spall from 600 s is
    alarmed."""
    w = _table(lambda t: 5000.0, lambda t: KINDS[2 * (t >= 600.0)], 60.0, 1200)
    early = w["start_s"] < 600.0
    w.loc[early, "condition_probability_healthy"] = 0.3
    w.loc[early, "condition_probability_inner"] = 0.5
    w.loc[early, "condition_probability_outer"] = 0.2
    stretches, _, alarms = stretches_and_changes(w, 0.2)
    assert [s["condition"] for s in stretches] == ["healthy", "inner"]
    assert stretches[0]["condition_probability"] == pytest.approx(0.3)
    assert stretches[0]["condition_probability_inner"] == pytest.approx(0.5)
    (alarm,) = [a for a in alarms if a["kind"] == "condition"]
    assert alarm["what"] == "condition healthy -> inner"
    assert alarm["time_s"] == pytest.approx(570.0, abs=30.0)


class _HertzLoadModel:
    """A load-state model of one feature: F_r from the level, R ~ F_r^(-4/3) (Hertz), with a
    +-1 % interval; the stand-in of a model trained on faulty bearings."""

    features = ("level_mean_ohm",)
    domain = None

    def predict_columns(self, x):
        f = 5000.0 * (x[:, 0] / 3e-3) ** (-0.75)
        return {
            "radial_load_n": f, "radial_load_n_low": 0.99 * f, "radial_load_n_high": 1.01 * f,
            "epsilon": np.full(len(f), 0.5), "epsilon_low": np.full(len(f), 0.49),
            "epsilon_high": np.full(len(f), 0.51), "clearance_m": np.zeros(len(f)),
            "clearance_m_low": np.full(len(f), -1e-6), "clearance_m_high": np.full(len(f), 1e-6),
        }  # fmt: skip


def test_a_stretch_called_faulty_is_answered_by_the_faulty_load_model():
    """Inner from 60 s, every window of the spall out of the healthy load model's domain but
    measured (its level kept): with a faulty load model the spalled stretch has its F_r back
    (Hertz: the level of 6000 N), marked ``load_model`` faulty; without one it has none, and a
    healthy stretch never takes the faulty model's answer."""
    w = _table(lambda t: 5000.0 if t < 60.0 else None, lambda t: KINDS[2 * (t >= 60.0)], 2.0, 120)
    late = w["start_s"] >= 60.0
    rng = np.random.default_rng(3)
    w.loc[late, "level_mean_ohm"] = (
        3e-3 * (6000.0 / 5000.0) ** (-4 / 3) * (1.0 + 0.002 * rng.standard_normal(int(late.sum())))
    )
    plain, _, _ = stretches_and_changes(w, 0.2)
    assert "radial_load_n" not in plain[1]
    stretches, _, alarms = stretches_and_changes(w, 0.2, faulty_model=_HertzLoadModel())
    assert [s["condition"] for s in stretches] == ["healthy", "inner"]
    assert stretches[1]["load_model"] == "faulty"
    assert stretches[1]["radial_load_n"] == pytest.approx(6000.0, rel=1e-3)
    assert "load_model" not in stretches[0]
    assert stretches[0]["radial_load_n"] == pytest.approx(5000.0, rel=1e-3)
    assert {a["kind"] for a in alarms} == {"condition", "load"}


def test_a_tie_between_healthy_and_a_fault_is_healthy():
    """Two assessments, one called healthy (leaning to inner, as the model's own rule still
    calls healthy) and one inner: a fault needs more calls than healthy."""
    from signatelec.estimation.health import stretch_condition

    w = pd.DataFrame(
        {
            "condition": ["healthy", "inner"],
            "condition_probability_healthy": [0.3, 0.05],
            "condition_probability_inner": [0.6, 0.9],
            "condition_probability_outer": [0.1, 0.05],
        }
    )
    out = stretch_condition(w)
    assert out["condition"] == "healthy"
    assert out["condition_probability_inner"] == pytest.approx(0.75)
    assert (out["condition_assessments"], out["condition_faulty_share"]) == (2, 0.5)
    alone = stretch_condition(w.iloc[1:])
    assert alone["condition"] == "inner" and alone["condition_faulty_share"] == 1.0


def test_a_load_alarm_between_two_load_models_is_not_confident():
    """A load alarm where the healthy model answers one side and the faulty model the other
    compares two models' errors: not confident; the condition alarm at the same change is."""
    from signatelec.estimation.monitor_report import qualify_alarms

    stretches = [{"start_s": 0.0, "end_s": 60.0}, {"start_s": 60.0, "end_s": 120.0}]
    stretches[1]["load_model"] = "faulty"
    alarms = [{"time_s": 60.0, "kind": "load"}, {"time_s": 60.0, "kind": "condition"}]
    qualify_alarms(alarms, stretches)
    assert [a["confident"] for a in alarms] == [False, True]
    del stretches[1]["load_model"]
    qualify_alarms(alarms, stretches)
    assert [a["confident"] for a in alarms] == [True, True]


@pytest.mark.parametrize(("every_s", "shares"), [(20.0, [0.05, 0.05]), (60.0, [0.1, 0.0])])
def test_the_false_alarm_rate_is_the_whole_records(monkeypatch, every_s, shares):
    """The load state's and the condition's change series share the record's false-alarm rate
    (Bonferroni over the two: their false changes together stay within it); a condition series
    too short to hold a change (fewer than 6 assessments: 5 at one a minute over 5 min) leaves
    the whole rate to the load."""
    import signatelec.estimation.evidence as evidence
    import signatelec.estimation.health as health

    asked = {}

    def spy(name, detector):
        def call(windows, hop_s, false_alarm_per_hour, **kwargs):
            asked[name] = false_alarm_per_hour
            return detector(windows, hop_s, false_alarm_per_hour, **kwargs)

        return call

    monkeypatch.setattr(evidence, "change_points", spy("load", evidence.change_points))
    monkeypatch.setattr(health, "change_points", spy("condition", health.change_points))
    w = _table(lambda t: 5000.0, lambda t: KINDS[0], every_s, 300)
    stretches_and_changes(w, 0.2, false_alarm_per_hour=0.1)
    assert [asked["load"], asked.get("condition", 0.0)] == pytest.approx(shares)


class _Typical:
    """The domain of a stand-in faulty model: every window as typical as its training traces."""

    features = ("level_mean_ohm",)

    def scores(self, x):
        return np.full(len(x), 0.5)


def test_a_stretch_answered_by_the_faulty_model_is_qualified_by_its_windows():
    """The healthy load model's windows are atypical (in-domain score 0.001) and at a speed
    beyond its training range (700 rad/s against 250-650); the spalled stretch the faulty
    model answers is judged by that model's windows (typical, 700 rad/s within its 250-750):
    no warning, where the healthy stretch carries both."""
    from signatelec.estimation.monitor_report import qualify

    w = _table(lambda t: 5000.0, lambda t: KINDS[2 * (t >= 60.0)], 2.0, 120)
    w = w.assign(in_domain_score=0.001, omega_rad_s=700.0, ripple="found")
    faulty = _HertzLoadModel()
    faulty.domain = _Typical()
    stretches, _, _ = stretches_and_changes(w, 0.2, faulty_model=faulty)
    assert [s.get("load_model") for s in stretches] == [None, "faulty"]
    qualify(stretches, {"omega_rad_s": (250.0, 650.0)}, None, {"omega_rad_s": (250.0, 750.0)})
    healthy, spalled = stretches
    assert any("training range 250-650" in x for x in healthy["warnings"])
    assert any("in-domain score 0.001" in x for x in healthy["warnings"])
    assert spalled["warnings"] == []
    assert spalled["in_domain_score"] == 0.5 and spalled["omega_rad_s"] == 700.0


def test_the_last_faulty_stretch_runs_to_the_records_end():
    """Inner from 100 s, assessed every 20 s (the last at 180 s), the record 190 s long and
    every window of the spall refused by the healthy model: the spalled stretch the faulty
    model answers runs to 190 s and takes the windows after the last assessment too."""
    w = _table(
        lambda t: 5000.0 if t < 100.0 else None, lambda t: KINDS[2 * (t >= 100.0)], 20.0, 190
    )
    late = w["start_s"] >= 100.0
    w.loc[late, "level_mean_ohm"] = 3e-3 * (6000.0 / 5000.0) ** (-4 / 3)
    stretches, _, _ = stretches_and_changes(w, 0.2, faulty_model=_HertzLoadModel())
    assert [s["condition"] for s in stretches] == ["healthy", "inner"]
    assert stretches[-1]["load_model"] == "faulty"
    assert stretches[-1]["end_s"] == pytest.approx(190.0)
    assert stretches[-1]["n_windows"] >= int((190.0 - 100.0) / 0.2) - 2


def test_a_load_step_within_a_faulty_stretch_is_found():
    """Inner from 60 s, every window of the spall refused by the healthy model, and a 20 %
    load step at 150 s within the spall (Hertz: the level falls by 1.2^(4/3)): the faulty
    model's windows are segmented too, so the spalled time is two stretches of 6000 and 7200 N,
    both inner, with a load alarm at 150 s (and the change at 60 s); without the step it
    stays one."""
    for step in (1.2, 1.0):
        w = _table(
            lambda t: 5000.0 if t < 60.0 else None, lambda t: KINDS[2 * (t >= 60.0)], 2.0, 240
        )
        rng = np.random.default_rng(4)
        late = (w["start_s"] >= 60.0).to_numpy()
        load = np.where(w["start_s"] >= 150.0, 6000.0 * step, 6000.0)[late]
        noise = 1.0 + 0.002 * rng.standard_normal((late.sum(), 3))
        w.loc[late, "level_mean_ohm"] = 3e-3 * (load / 5000.0) ** (-4 / 3) * noise[:, 0]
        w.loc[late, "h1_rel"] = 1e-3 * noise[:, 1]
        w.loc[late, "h2_rel"] = 3e-4 * noise[:, 2]
        stretches, changes, alarms = stretches_and_changes(w, 0.2, faulty_model=_HertzLoadModel())
        backwards = stretches_and_changes(w.iloc[::-1], 0.2, faulty_model=_HertzLoadModel())
        assert backwards[0] == stretches  # the windows are put in time order
        spalled = [s for s in stretches if s["condition"] == "inner"]
        assert all(s["load_model"] == "faulty" for s in spalled)
        if step == 1.0:
            assert len(spalled) == 1 and len(changes) == 1
            continue
        assert [round(s["radial_load_n"], -2) for s in spalled] == [6000.0, 7200.0]
        assert [round(c["time_s"]) for c in changes] == [60, 150]
        at_step = [a for a in alarms if a["time_s"] > 100.0]
        assert [a["kind"] for a in at_step] == ["load"]
        assert at_step[0]["time_s"] == pytest.approx(150.0, abs=0.2)


def test_a_faulty_stretch_is_segmented_at_its_share_of_the_rate(monkeypatch):
    """The faulty model's windows are segmented at the load state's share of the rate times
    the part of them the healthy model did not answer (the record's detector read the others):
    half refused, half the share; a table without the detector's columns (no ripple harmonics)
    is answered unsegmented."""
    import signatelec.estimation.evidence as evidence

    rates = []

    def spy(windows, hop_s, false_alarm_per_hour, series=None):
        rates.append(false_alarm_per_hour)
        return []

    monkeypatch.setattr(evidence, "change_points", spy)
    w = _table(lambda t: 5000.0, lambda t: KINDS[2 * (t >= 100.0)], 20.0, 200)
    refused = (w["start_s"] >= 100.0) & (np.arange(len(w)) % 2 == 0)
    w.loc[refused, "status"] = "out of domain"
    stretches, _, _ = stretches_and_changes(w, 0.2, 0.1, faulty_model=_HertzLoadModel())
    assert stretches[-1]["load_model"] == "faulty"
    assert rates == pytest.approx([0.05, 0.025], rel=0.02)
    monkeypatch.undo()
    bare = _table(lambda t: None, lambda t: KINDS[2], 20.0, 200).assign(level_mean_ohm=3e-3)
    assert "h1_rel" not in bare
    (stretch,) = stretches_and_changes(bare, 0.2, 0.1, faulty_model=_HertzLoadModel())[0]
    assert stretch["load_model"] == "faulty"
    assert stretch["radial_load_n"] == pytest.approx(5000.0)


# --- another bearing than the seed's: its condition alone ------------------------------------

#: CWRU's drive-end SKF 6205-2RS JEM: the outer race's defect line is 3.5848 times the shaft
#: frequency (Case Western Reserve University Bearing Data Center, bearing information: ball
#: diameter 7.94 mm, pitch diameter 39.04 mm, 9 balls), where the seed's bearing's is 5.148.
CWRU_BPFO_PER_SHAFT = 3.5848


@pytest.fixture(scope="module")
def other_bearing():
    from signatelec.config.catalogue import catalogue_bearing

    return catalogue_bearing("6205")


@pytest.fixture(scope="module")
def other_tile(other_bearing):
    """A ball-pass-periodic tile of the 6205's quasi-static tier at 2500 N."""
    scene = Scene.from_dict({"bearing": {"designation": "6205"}}).with_overrides(
        fidelity="quasistatic", radial_load_n=2500.0, duration_s=0.06
    )
    sig = simulate(scene).signals
    steady = sig.loc[sig["phase"] == "steady", "resistance_ohm"].to_numpy()
    return whole_passes(steady, FS, OMEGA, other_bearing)


@pytest.fixture(scope="module")
def other_model_file(model_file, other_tile, other_bearing, tmp_path_factory):
    """``model_file``'s load-state model (the seed's bearing) with a condition model trained on
    0.2 s windows of the 6205's tile with each condition of :data:`KINDS` at its own lines
    (load features read at the seed's geometry, as ``estimate`` reads them; condition
    features at the 6205's)."""
    from signatelec.estimation.persistence import load_model

    model = load_model(model_file)
    rng = np.random.default_rng(13)
    rows = []
    for kind in KINDS:
        for _ in range(60):
            base = _tiled(other_tile, 0.2, int(rng.integers(other_tile.size)))
            extra = _spall(
                kind, 0.2, int(rng.integers(2**31)), rng.uniform(0.02, 0.06), other_bearing
            )
            r = base * (1.0 + extra) * (1.0 + NOISE * rng.standard_normal(base.size))
            feats = trace_features(r, FS, OMEGA) | condition_features(
                r, FS, OMEGA, bearing=other_bearing
            )
            rows.append({"run_id": len(rows), "condition": kind, "spall_length_m": 1e-3} | feats)
    with threadpool_limits(1):
        model.condition = train_condition(
            pd.DataFrame(rows), estimator=ConditionEstimator(max_iter=30, n_splits=2)
        )
    path = tmp_path_factory.mktemp("other") / "6205.model"
    save_model(model, path)
    return path


def test_another_bearing_is_monitored_for_its_condition_alone(
    other_model_file, other_tile, other_bearing, tmp_path, monkeypatch
):
    """A 6205 read with its geometry: 40 s healthy, then 40 s with an outer-race spall (pulses
    at its own BPFO, 285 Hz at 500 rad/s, where the seed's bearing's is 410 Hz). The change is
    found within the cadence of its onset, the faulty windows named by the envelope's line at
    CWRU's published BPFO of the 6205; no window carries a load state (the load-state model
    learnt the seed's bearing only), and only the windows assessed are analysed: the load state
    is off and costs nothing. Read at the seed's geometry, the same record is refused as a
    wrong speed, its ripple named at the 6205's BPFO."""
    from signatelec.estimation import monitor as monitor_module
    from signatelec.estimation.persistence import load_model
    from signatelec.measurement.traces import TraceError

    path = _record(
        other_tile, [("healthy", 40.0), ("outer", 40.0)], tmp_path / "6205.parquet", 3,
        other_bearing,
    )  # fmt: skip
    model = load_model(other_model_file)
    analysed = []
    real = monitor_module.analyse_windows
    monkeypatch.setattr(
        monitor_module,
        "analyse_windows",
        lambda x, *a, **k: analysed.append(len(x)) or real(x, *a, **k),
    )
    settings = MonitorSettings(omega_rad_s=OMEGA, condition_every_s=2.0, bearing=other_bearing)
    windows = monitor_trace(path, model, settings).frame()
    stretches, changes, alarms = stretches_and_changes(windows, settings.hop)
    assessed = windows["condition"].notna()
    # every 2 s and the record's last window: 41 assessed, and only those analysed
    assert assessed.sum() == 41 and sum(analysed) == 41
    assert windows.loc[assessed, "start_s"].max() == pytest.approx(79.8)
    assert windows.loc[assessed, "level_mean_ohm"].notna().all()  # the last one's too
    assert windows["status"].str.startswith("no load state").all()
    assert "radial_load_n" not in windows and windows["resistance_max_ohm"].notna().all()
    assert [s["condition"] for s in stretches] == ["healthy", "outer"]
    assert not any("radial_load_n" in s for s in stretches)
    assert len(changes) == 1 and changes[0]["time_s"] == pytest.approx(40.0, abs=2.0)
    assert [a["what"] for a in alarms] == ["condition healthy -> outer"]
    faulty = windows[assessed & (windows["start_s"] > 42.0)]
    bpfo = CWRU_BPFO_PER_SHAFT * OMEGA / (2.0 * np.pi)
    assert (faulty["condition_line"] == "bpfo").all()
    assert faulty["condition_line_hz"].to_numpy() == pytest.approx(bpfo, rel=1e-4)
    assert np.median(np.abs(faulty["condition_line_found_hz"] - bpfo)) < 5.0
    seed = MonitorSettings(omega_rad_s=OMEGA, condition_every_s=2.0)
    with pytest.raises(TraceError, match=r"ripple at 28[45]\.\d Hz"):
        monitor_trace(path, model, seed)


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--bearing", "6205x"], "--bearing '6205x': unknown bearing; known: seed,"),
        (["--bearing", "6205", "--condition-every", "0"], "--condition-every 0: no condition"),
        (["--bearing", "6205", "--track-speed"], "--track-speed: tracks the ball-pass line of"),
        (["--bearing", "6205", "--model", "load-only"], "--bearing: the model knows the load"),
        # 3.17 cage revolutions of the 6205 at 500 rad/s, where the training windows span 6.3
        (["--bearing", "6205", "--window", "0.1"], "--window 0.1: 3.17 cage revolutions"),
    ],
)
def test_another_bearing_without_a_condition_to_assess_is_refused(
    model_file, other_tile, other_model_file, other_bearing, tmp_path, capsys, extra, expected
):
    """One line naming the option and the bearing, exit 2, nothing written, before the record
    is read: an unknown designation, another bearing with nothing to say of it (no condition
    assessed, a model without a condition model, or windows too short for the condition
    model), or its speed tracked from the seed's line."""
    from signatelec.estimation.persistence import load_model

    path = _record(other_tile, [("healthy", 2.0)], tmp_path / "short.parquet", 0, other_bearing)
    if "load-only" in extra:
        model = load_model(model_file)
        model.condition = None
        save_model(model, tmp_path / "load-only.model")
        extra = [str(tmp_path / "load-only.model") if e == "load-only" else e for e in extra]
    else:
        extra = [*extra, "--model", str(other_model_file)]
    out = tmp_path / "out"
    code = run_main(["monitor", str(path), "--out", str(out), "--omega", "500", "--quiet", *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and expected in err[0], err
    assert not out.exists()


def test_the_command_monitors_another_bearing(
    other_model_file, other_tile, other_bearing, tile, tmp_path, capsys
):
    """``signatelec monitor --bearing 6205``: the summary names the bearing and says the load
    state is not estimated, the stretch carries its condition, the picture is written. The
    block at 10 s is of the seed's bearing (its ripple at 410 Hz, not the 6205's 285 Hz): its
    screen refuses it, and that refusal is the first one named."""
    import json

    path = _record(other_tile, [("healthy", 10.0)], tmp_path / "rec.parquet", 1, other_bearing)
    r = pd.read_parquet(path)["resistance_ohm"].to_numpy()
    r = np.concatenate([r, _tiled(tile, 2.0), _tiled(other_tile, 2.0)])
    pd.DataFrame({"time_s": np.arange(r.size) / FS, "resistance_ohm": r}).to_parquet(path)
    out = tmp_path / "out"
    code = run_main(
        ["monitor", str(path), "--out", str(out), "--omega", "500", "--bearing", "6205",
         "--model", str(other_model_file), "--condition-every", "2"]
    )  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0, text
    assert "load state not estimated  condition healthy" in text
    summary = json.loads((out / "summary.json").read_text())
    assert summary["settings"]["bearing"] == other_bearing.name
    assert summary["settings"]["load_state"] is False
    assert any(n.startswith("load state not estimated") for n in summary["notes"])
    assert summary["trace"]["first_refusal"].startswith("refused: ")
    assert "ripple at 409" in summary["trace"]["first_refusal"]
    assert [s["condition"] for s in summary["stretches"]] == ["healthy"]
    assert "radial_load_n" not in summary["stretches"][0]
    assert (out / "monitor.png").stat().st_size > 0


def test_another_bearing_tracked_is_refused_before_the_default_model(
    other_tile, other_bearing, tmp_path, capsys, monkeypatch
):
    """The default model learnt the seed's bearing: --track-speed with --bearing 6205 is refused
    in one line before it is built or loaded (its first build takes minutes)."""
    import signatelec.estimation.persistence as persistence

    def unwanted(**_):
        raise AssertionError("the default model was asked for")

    monkeypatch.setattr(persistence, "default_model", unwanted)
    path = _record(other_tile, [("healthy", 2.0)], tmp_path / "short.parquet", 0, other_bearing)
    out = tmp_path / "out"
    args = ["monitor", str(path), "--out", str(out), "--omega", "500", "--bearing", "6205"]
    code = run_main([*args, "--track-speed", "--quiet"])
    (err,) = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "--track-speed: tracks the ball-pass line of the seed's bearing" in err
    assert not out.exists()


def _fast_dem_steady(defects: list, seconds: float) -> np.ndarray:
    """The seed's bearing at 7780 N, a 10 um clearance and 571.1 rad/s (the fast DEM, 0.3 s
    after 30 ms of settling, 20 kHz), with ``defects``, tiled at whole ball passes over
    ``seconds``."""
    import warnings

    from signatelec.engines.fidelity import apply_fidelity

    scene = Scene.from_dict({"defects": defects}).with_overrides(
        radial_load_n=7780.0, clearance_m=9.97e-6, omega_rad_s=571.1
    )
    scene = apply_fidelity(scene, "fast")
    scene = scene.with_overrides(duration_s=scene.setup_time_s + 0.33, sample_rate_hz=FS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        steady = simulate(scene).steady()["resistance_ohm"].to_numpy()[-6000:]
    one = whole_passes(steady, FS, 571.1)
    return np.tile(one, int(np.ceil(seconds * FS / one.size)))[: int(seconds * FS)]


#: The 0.73 mm outer-race spall in the load zone of the monitored spall records.
SPALL = {"location": "outer", "length_m": 0.73e-3, "depth_m": 54e-6, "angle_rad": -0.663}


def _monitored_spall(tmp_path, healthy_s: float, spalled_s: float, seed: int, *options):
    """(summary, windows) of ``signatelec monitor`` (``options`` added) on ``healthy_s`` of
    :func:`_fast_dem_steady` healthy, then ``spalled_s`` with :data:`SPALL`, 0.2 % noise."""
    r = np.concatenate([_fast_dem_steady([], healthy_s), _fast_dem_steady([SPALL], spalled_s)])
    r = r * (1 + NOISE * np.random.default_rng(seed).standard_normal(r.size))
    path = tmp_path / "spall.parquet"
    pd.DataFrame({"time_s": np.arange(r.size) / FS, "resistance_ohm": r}).to_parquet(path)
    out = tmp_path / "out"
    args = ["monitor", str(path), "--omega", "571.1", *options, "--out", str(out), "--quiet"]
    assert run_main(args) == 0
    return json.loads((out / "summary.json").read_text()), pd.read_parquet(out / "windows.parquet")


def test_a_spall_whose_impacts_put_a_line_at_no_harmonic_is_alarmed(tmp_path):
    """10 s of the seed's bearing healthy, then 10 s with a 0.73 mm outer-race spall in the
    load zone (the fast DEM, 0.2 % noise): the spall puts a line at 3.76 f_bp, at no harmonic
    of the ball-pass frequency, above the ripple, and the monitor with the default model had
    refused the record from the spall on as a speed ~3.8 times the true one (no alarm). The
    ripple still stands where the speed puts it and the condition model calls outer: the
    spall's stretch is outer, alarmed within the assessments' 1 s cadence of its onset, and no
    window is refused."""
    summary, windows = _monitored_spall(tmp_path, 10.0, 10.0, 3, "--condition-every", "1")
    assert not windows["status"].astype(str).str.startswith("refused").any()
    assert summary["stretches"][-1]["condition"] == "outer"
    alarms = [a for a in summary["alarms"] if a["kind"] == "condition"]
    assert len(alarms) == 1 and alarms[0]["what"] == "condition healthy -> outer"
    assert alarms[0]["time_s"] == pytest.approx(10.0, abs=1.0)


def test_a_spall_that_takes_the_windows_out_of_the_load_models_domain_ends_the_stretch(tmp_path):
    """9 s of the seed's bearing healthy, then 9 s with the same outer-race spall (the fast DEM,
    0.2 % noise), the condition assessed every 3 s: every window of the spall lies out of the
    load model's domain. The stretch ends at the spall's first window: the healthy one's F_r
    within 1 % of the run's 7780 N (measured -0.3 %) from its own three assessments, the
    spall's stretch outer from its four (the first at the onset), answered by the faulty load
    model, and the condition alarm at the onset within one window (0.2 s)."""
    summary, windows = _monitored_spall(tmp_path, 9.0, 9.0, 4, "--condition-every", "3")
    spalled = windows["start_s"] >= 9.0
    assert windows.loc[spalled, "status"].str.startswith("out of domain").all()
    first, last = summary["stretches"][0], summary["stretches"][-1]
    assert first["condition"] == "healthy" and last["condition"] == "outer"
    assert (first["condition_assessments"], last["condition_assessments"]) == (3, 4)
    assert last["load_model"] == "faulty"
    assert first["end_s"] == pytest.approx(9.0, abs=0.2)
    assert first["radial_load_n"] == pytest.approx(7780.0, rel=0.01)
    alarms = [a for a in summary["alarms"] if a["kind"] == "condition"]
    assert len(alarms) == 1 and alarms[0]["what"] == "condition healthy -> outer"
    assert alarms[0]["time_s"] == pytest.approx(9.0, abs=0.2)


def test_the_last_window_assessed_after_its_batch_was_filed_may_name_a_line(tmp_path):
    """200 s of the seed's bearing (1000 windows, one batch), the outer-race spall in its last
    10 s, the condition assessed once a minute: the record's last window is assessed after
    its batch was filed, and its spall's line (bpfo) went into a column that every earlier
    assessment had left empty (healthy: no line): pandas refused a string into that float
    column and the monitor ended in a traceback. It reads the record through, the line named
    in the last window's row."""
    _, windows = _monitored_spall(tmp_path, 190.0, 10.0, 5)
    assessed = windows[windows["condition"].notna()]
    assert assessed["start_s"].tolist() == pytest.approx([0.0, 60.0, 120.0, 180.0, 199.8])
    assert assessed["condition_line"].iloc[:-1].isna().all()
    assert assessed["condition_line"].iloc[-1] == "bpfo"
