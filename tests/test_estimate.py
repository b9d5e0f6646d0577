"""Load-state estimation: estimators, model files, and ``signatelec estimate/train``.

Accuracy on held-out runs is measured by ``pipelines/load_state.py`` (docs/load_state), not
here; these tests check the contract: scikit-learn conformance, uncertainty that widens where
labels overlap, model version refusal, and the command line on good and bad traces.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import sklearn
from threadpoolctl import threadpool_limits

from signatelec.cli import main
from signatelec.estimation import persistence
from signatelec.estimation.estimate import estimate
from signatelec.estimation.features import FEATURE_SET_VERSION
from signatelec.estimation.models import IntervalRegressor, LoadStateEstimator, RegimeClassifier
from signatelec.estimation.persistence import ModelError, load_model, read_model_header, save_model
from signatelec.estimation.report import format_estimate
from signatelec.estimation.training import (
    DEFAULT_TABLE,
    MODEL_FEATURES,
    PAPER_TABLE,
    default_training_table,
    model_features,
    train_default_model,
)
from signatelec.physics.kinematics import expected_ball_pass_hz
from signatelec.physics.quasistatic import epsilon_from_shift
from signatelec.physics.regimes import REGIME_TOLERANCE_M, REGIMES, regime_of

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "datasets" / "example_trace.csv"


@pytest.fixture(autouse=True)
def _one_thread():
    """Gradient boosting with one thread: two pytest workers on two cores do not fight."""
    with threadpool_limits(1):
        yield


# --- uncertainty ---------------------------------------------------------------------------


def _overlap_data(n=1200, seed=0):
    """x < 0.5: class "a" and y = 0 + small noise; x > 0.5: classes a/b at random and y = +-1.
    The right half is what two load states with one signature look like."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 1, n)
    right = x > 0.5
    cls = np.where(right & (rng.uniform(size=n) < 0.5), "b", "a").astype(object)
    y = np.where(right, rng.choice([-1.0, 1.0], n), 0.0) + rng.normal(0, 0.02, n)
    X = np.column_stack([x, rng.normal(size=n)])
    groups = np.arange(n) // 4
    return X, y, cls, groups


def test_split_probabilities_where_signatures_overlap():
    X, _, cls, groups = _overlap_data()
    clf = RegimeClassifier(max_iter=60, n_splits=3).fit(X, cls, groups=groups)
    p = clf.predict_proba(np.array([[0.2, 0.0], [0.8, 0.0]]))
    b = list(clf.classes_).index("b")
    assert p[0, b] < 0.1  # one state: confident
    assert 0.3 < p[1, b] < 0.7  # two states, one signature: split, not a guess


def test_wide_interval_where_labels_overlap():
    X, y, _, groups = _overlap_data()
    reg = IntervalRegressor(max_iter=60, n_splits=3).fit(X, y, groups=groups)
    band = reg.predict_interval(np.array([[0.2, 0.0], [0.8, 0.0]]))
    assert band[0, 1] - band[0, 0] < 0.3
    assert band[1, 0] < -0.8 and band[1, 1] > 0.8  # spans both states
    # out-of-sample coverage near nominal
    Xt, yt, _, _ = _overlap_data(seed=1)
    bt = reg.predict_interval(Xt)
    assert 0.8 < np.mean((yt >= bt[:, 0]) & (yt <= bt[:, 1])) <= 1.0


def _rough_data(seed: int, runs: int = 300, rows: int = 4):
    """Runs of one state s each, y = s where s < 0.5 and 0.3 sin(60 s) above: a median that
    never saw a run errs little on the smooth half and much on the rough one."""
    rng = np.random.default_rng(seed)
    s = rng.uniform(0.0, 1.0, runs)
    truth = np.repeat(np.where(s > 0.5, 0.3 * np.sin(60.0 * s), s), rows)
    state = np.repeat(s, rows)
    X = np.column_stack([state + rng.normal(0, 0.002, state.size), rng.normal(size=state.size)])
    return X, truth + rng.normal(0, 0.01, state.size), np.repeat(np.arange(runs), rows)


def test_residual_interval_follows_the_out_of_fold_error():
    """Locally weighted split conformal (Lei et al. 2018, sec. 5.2): the interval covers new
    runs at least near nominal in the rough half and in the smooth half alike, and it is
    narrow where a median that never saw a run errs little. The quantile models, fitted on
    every run, see only the rows' own noise there and keep one margin everywhere."""
    X, y, groups = _rough_data(0)
    Xt, yt, _ = _rough_data(1)
    rough = Xt[:, 0] > 0.5
    width, covered = {}, {}
    for mode in ("quantile", "residual"):
        reg = IntervalRegressor(max_iter=60, n_splits=3, interval=mode).fit(X, y, groups=groups)
        band = reg.predict_interval(Xt)
        hit = (yt >= band[:, 0]) & (yt <= band[:, 1])
        covered[mode] = (hit[rough].mean(), hit[~rough].mean())
        w = band[:, 1] - band[:, 0]
        width[mode] = (np.median(w[rough]), np.median(w[~rough]))
    np.testing.assert_array_equal(reg.predict(Xt), reg.median_.predict(Xt))
    # measured 0.978 and 0.964 (nominal 0.90; cross-fitted errors are a little pessimistic)
    assert min(covered["residual"]) > 0.85
    # widths measured: rough 0.31, smooth 0.066 (residual); 0.31, 0.23 (quantile)
    assert width["residual"][0] > 3.0 * width["residual"][1]
    assert width["residual"][1] < 0.5 * width["quantile"][1]
    with pytest.raises(ValueError, match="interval = 'width'"):
        IntervalRegressor(interval="width").fit(X, y)


def test_load_state_estimator_table():
    """Targets named like the dataset's: the load through log F_r + 0.75 log R, a frame out."""
    rng = np.random.default_rng(2)
    n = 400
    load = np.exp(rng.uniform(np.log(2500), np.log(12500), n))
    eps = rng.uniform(0.3, 0.6, n)
    level = 0.1 * load ** (-4 / 3) * (1.1 - 0.2 * eps)
    X = pd.DataFrame({"level_mean_ohm": level, "h1_rel": np.sin(20 * eps), "h2": eps**2})
    regime = np.where(eps < 0.45, "clearance", np.where(eps > 0.55, "preload", "zero"))
    y = pd.DataFrame(
        {"radial_load_n": load, "epsilon": eps, "clearance_m": 1e-5 * (0.5 - eps), "regime": regime}
    )
    est = LoadStateEstimator(max_iter=80, n_splits=3).fit(X, y, groups=np.arange(n) // 2)
    out = est.predict_frame(X)
    assert set(out.columns) >= {
        "radial_load_n",
        "radial_load_n_low",
        "radial_load_n_high",
        "epsilon_low",
        "clearance_m_high",
        "regime",
        "regime_probability_zero",
    }
    assert np.median(np.abs(out["radial_load_n"] / load - 1)) < 0.02
    assert np.all(out["radial_load_n_low"] <= out["radial_load_n"])
    probs = out[[f"regime_probability_{r}" for r in REGIMES]].to_numpy()
    np.testing.assert_allclose(probs.sum(axis=1), 1.0)
    assert isinstance(est.predict(X), pd.DataFrame)


def test_flat_forest_matches_scikit_learn():
    """The compiled walk of the trees gives scikit-learn's predictions to the last bit (the
    same sums in the same order), for one row and for many, with missing values sent where
    the trees send them."""
    X, y, cls, groups = _overlap_data(n=300)
    reg = IntervalRegressor(max_iter=30, n_splits=2).fit(X, y, groups=groups)
    clf = RegimeClassifier(max_iter=30, n_splits=2).fit(X, cls, groups=groups)
    for rows in (X[:1], X):
        np.testing.assert_array_equal(reg.predict(rows), reg.median_.predict(rows))
        np.testing.assert_array_equal(reg._quantiles(rows)[:, 2], reg.upper_.predict(rows))
        np.testing.assert_array_equal(clf.predict_proba(rows), clf._proba(rows))
        np.testing.assert_array_equal(
            clf.model_._loss.predict_proba(clf.forest_.raw(rows)), clf.model_.predict_proba(rows)
        )
    holed = X.copy()
    holed[::7, 0] = np.nan
    models = (reg.median_, reg.lower_, reg.upper_)
    np.testing.assert_array_equal(
        reg.forest_.raw(holed), np.hstack([m._raw_predict(holed) for m in models])
    )
    np.testing.assert_array_equal(clf.forest_.raw(holed), clf.model_._raw_predict(holed))


def test_model_features_are_trace_features():
    from signatelec.estimation.features import trace_feature_names

    assert set(MODEL_FEATURES) <= set(trace_feature_names())
    assert len(set(MODEL_FEATURES)) == len(MODEL_FEATURES)


# --- model files ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def recipe(tmp_path_factory):
    """The default model's recipe on a third of the shipped runs, and the rows of another third
    (runs it never saw). Trained once per test run (~90 s of a core): the workers of a parallel
    run read the first one's, saved in their shared temporary directory under a lock."""
    table = pd.read_parquet(DEFAULT_TABLE)
    runs = np.unique(table["run_id"])
    held_out = table[table["run_id"].isin(runs[1::3])]

    def train():
        with threadpool_limits(1):
            return train_default_model(table[table["run_id"].isin(runs[::3])])

    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return train(), held_out
    run = os.environ.get("PYTEST_XDIST_TESTRUNUID", "run")  # one file per test run
    path = tmp_path_factory.getbasetemp().parent / f"default-recipe-third-{run}.model"
    with persistence._build_lock(path):
        if not path.is_file():
            save_model(train(), path)
    return load_model(path), held_out


@pytest.fixture(scope="module")
def small_model(recipe, tmp_path_factory):
    """That model, saved to a file."""
    path = tmp_path_factory.mktemp("model") / "small.model"
    save_model(recipe[0], path)
    return path


@pytest.mark.slow
@pytest.mark.validation
def test_stretch_model_on_held_out_dem_states_where_windows_erred(recipe):
    """The default recipe's stretch model on held-out paper-fidelity DEM states (500 rad/s) of
    the regions where the window model misread the monitoring study's states
    (docs/monitor/model_error.md), drawn from a fixed seed: two at the fold of R(epsilon)
    (0.33-0.37), two at the first-harmonic null (0.53-0.56), a preload and a clearance 1.5-3 um
    beyond the +-1 um boundary. Each a 2 s stretch: the mean features of 10 windows of 0.2 s at
    0.2 % white noise. The monitor's acceptance asks the regime right and F_r within 1 %.
    Measured: five right (probability 0.80-1.00); the clearance at the fold at 11.7 kN (37.9 um,
    epsilon 0.369) called preload (0.81), its F_r 1.20 % low (the windows' evidence combined
    calls it clearance, 1.02 % low); F_r error 0.03-1.20 %, mean 0.39 %. Over 18 more states
    of three other seeds: all right, F_r within 0.94 %."""
    from signatelec.config.bearing import Bearing
    from signatelec.estimation.features import trace_features
    from signatelec.physics.quasistatic import clearance_for_epsilon
    from signatelec.studies.monitor_records import run_state, whole_passes

    stretch, fs, omega = recipe[0].stretch, 20000.0, 500.0
    rng = np.random.default_rng(20261124)
    n = int(0.2 * fs)
    regions = [("fold", 0.33, 0.37)] * 2 + [("null", 0.53, 0.56)] * 2
    regions += [("gap", -3e-6, -1.5e-6), ("gap", 1.5e-6, 3e-6)]
    right, errors = [], []
    for kind, lo, hi in regions:
        load = float(np.exp(rng.uniform(np.log(2500.0), np.log(12500.0))))
        eps = float(rng.uniform(lo, hi))
        clearance = eps if kind == "gap" else clearance_for_epsilon(Bearing(), load, omega, eps)
        steady = run_state({"radial_load_n": load, "clearance_m": float(clearance)})
        tile = whole_passes(steady["resistance_ohm"].to_numpy(), fs, omega)
        reps, level = np.tile(tile, n // tile.size + 2), float(np.median(tile))
        rows = []
        for _ in range(10):
            o = int(rng.integers(tile.size))
            window = reps[o : o + n] + 0.002 * level * rng.standard_normal(n)
            rows.append(trace_features(window, fs, omega))
        got = stretch.predict_one(pd.DataFrame(rows)[stretch.features].mean().to_dict())
        right.append(got["regime"] == regime_of(float(clearance)))
        errors.append(abs(got["radial_load_n"] / load - 1.0))
    assert sum(right) >= 5, right
    assert max(errors) < 0.015 and np.mean(errors) < 0.006, errors


@pytest.mark.slow
def test_default_recipe_on_held_out_runs(recipe):
    """What the default model's recipe must achieve on runs it never saw, with a third of the
    shipped runs: windows of 12.5-200 ms, white noise 0.05-1 %. Measured: F_r MAPE 0.61 %,
    epsilon MAE 0.038, clearance MAE 7.0 um, regime 70 % (chance: 33 %), 90 % intervals
    covering 89-91 %. The whole table gives 0.61 %, 0.032, 6.0 um and 77 % on paper-fidelity
    test runs at 0.2 % noise, 50 ms (docs/load_state)."""
    model, held = recipe
    assert set(model.estimator.estimators_["regime"].classes_) == set(REGIMES)
    pred = model.predict_frame(held)
    truth = {c: held[c].to_numpy(dtype=float) for c in ("radial_load_n", "epsilon", "clearance_m")}
    assert np.mean(np.abs(pred["radial_load_n"] / truth["radial_load_n"] - 1)) < 0.01
    assert np.mean(np.abs(pred["epsilon"] - truth["epsilon"])) < 0.05
    assert np.mean(np.abs(pred["clearance_m"] - truth["clearance_m"])) < 10e-6
    assert np.mean(pred["regime"].to_numpy() == held["regime"].astype(str).to_numpy()) > 0.6
    for name, true in truth.items():
        inside = (pred[f"{name}_low"] <= true) & (true <= pred[f"{name}_high"])
        assert 0.85 < np.mean(inside) < 0.95, name


def test_regimes_follow_epsilon():
    """The regime of a clearance (physics.regimes.regime_of) agrees with the load
    parameter (seed eq. 15): epsilon > 0.5 under a preload, 0.5 at zero clearance, < 0.5 with
    a clearance; within +-REGIME_TOLERANCE_M of zero the bearing counts as zero-clearance."""
    tol = REGIME_TOLERANCE_M
    for clearance in (-5e-6, -2 * tol, -0.5 * tol, 0.0, 0.5 * tol, 2 * tol, 5e-6):
        eps = float(epsilon_from_shift(2e-5, clearance))
        regime = regime_of(clearance)
        assert regime in REGIMES
        if abs(clearance) <= tol:
            assert regime == "zero" and abs(eps - 0.5) < 0.5 * tol / 2e-5
        else:
            assert regime == ("preload" if eps > 0.5 else "clearance")


def test_paper_rows_follow_their_clearance():
    """The default model's paper-fidelity rows: runs of their own (ids apart from the fast
    runs'), one 50 ms and one 200 ms window each, F_r over the design's 0.086-0.43 C_r
    (2500-12500 N), labelled with the regime of their clearance, and the DEM's epsilon on the
    side of 0.5 that clearance asks for (seed eq. 15: < 0.5 with a clearance, > 0.5 under a
    preload; within 0.015 of 0.5 in the zero regime: by quasi-static theory,
    physics.quasistatic.clearance_for_epsilon, the +-1 um tolerance spans epsilon 0.4865-0.513
    at 2500 N; measured 0.4875-0.5131)."""
    paper, fast = pd.read_parquet(PAPER_TABLE), pd.read_parquet(DEFAULT_TABLE)
    assert not set(paper["run_id"]) & set(fast["run_id"])
    lengths = paper.groupby("run_id")["length_s"].agg(
        lambda x: tuple(sorted(round(float(v), 3) for v in x))
    )
    assert set(lengths) == {(0.05, 0.2)}
    assert paper["radial_load_n"].between(2500 * 0.999, 12500 * 1.001).all()
    regime = paper["regime"].astype(str)
    assert (regime == [regime_of(float(c)) for c in paper["clearance_m"]]).all()
    eps = paper["epsilon"].to_numpy(float)
    assert np.all(eps[regime == "clearance"] < 0.5) and np.all(eps[regime == "preload"] > 0.5)
    assert np.all(np.abs(eps[regime == "zero"] - 0.5) < 0.015)
    both = default_training_table()
    assert len(both) == len(paper) + len(fast) and set(both["regime"]) == set(REGIMES)


def test_model_round_trip(small_model):
    model = load_model(small_model)
    header = read_model_header(small_model)
    assert header["scikit_learn"] == sklearn.__version__
    assert header["feature_set"] == FEATURE_SET_VERSION
    assert model.features == model_features()


def _with_header(src: Path, dst: Path, **changes) -> Path:
    raw = src.read_bytes()
    line, body = raw.split(b"\n", 1)
    header = json.loads(line)
    header.update(changes)
    dst.write_bytes(json.dumps(header).encode() + b"\n" + body)
    return dst


@pytest.mark.parametrize(
    ("changes", "expected"),
    [
        ({"scikit_learn": "0.20.4"}, "scikit-learn 0.20.4"),
        ({"signatelec": "9.1.0"}, "signatelec 9.1.0"),
        ({"feature_set": 0}, "feature set 0"),
        ({"format_version": 2}, "model format 2"),  # no training domain in it
    ],
)
def test_model_refused_across_versions(small_model, tmp_path, capsys, changes, expected):
    bad = _with_header(small_model, tmp_path / "old.model", **changes)
    with pytest.raises(ModelError, match="retrain"):
        load_model(bad)
    code = _run(["estimate", str(EXAMPLE), "--omega", "500", "--model", str(bad)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert expected in err[0] and "retrain" in err[0]


def test_not_a_model(tmp_path, capsys):
    junk = tmp_path / "junk.model"
    junk.write_bytes(b"\x80\x04not json\n")
    code = _run(["estimate", str(EXAMPLE), "--omega", "500", "--model", str(junk)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "not a signatelec load-state model" in err[0]


def _damaged(src: Path, dst: Path, where: str, n_bytes: int = 0) -> Path:
    """A copy of a model file with ``n_bytes`` bytes flipped (XOR 0xFF) at its ``start``,
    ``middle`` or ``end``, or ``truncated`` to half its length."""
    raw = bytearray(src.read_bytes())
    if where == "truncated":
        raw = raw[: len(raw) // 2]
    else:
        first = {"start": 0, "middle": len(raw) // 2, "end": len(raw) - n_bytes}[where]
        for i in range(first, first + n_bytes):
            raw[i] ^= 0xFF
    dst.write_bytes(bytes(raw))
    return dst


MISMATCH = "checksum mismatch (corrupted or edited); retrain or delete it"


@pytest.mark.parametrize(
    ("where", "n_bytes", "expected"),
    [
        ("middle", 8, MISMATCH),
        ("middle", 64, MISMATCH),
        ("end", 8, MISMATCH),
        ("end", 64, MISMATCH),
        ("start", 8, MISMATCH),  # in the header
        ("truncated", 0, "truncated"),
    ],
)
def test_damaged_model_refused(
    small_model, tmp_path, capsys, monkeypatch, where, n_bytes, expected
):
    """Flipped bytes or a cut file: refused in one line, exit 2, before anything is unpickled."""
    bad = _damaged(small_model, tmp_path / "bad.model", where, n_bytes)

    def never(*args, **kwargs):
        raise AssertionError("a damaged model file was unpickled")

    monkeypatch.setattr(persistence.pickle, "loads", never)
    with pytest.raises(ModelError, match="retrain or delete it"):
        load_model(bad)
    out = tmp_path / "never.json"
    args = ["estimate", str(EXAMPLE), "--omega", "500", "--model", str(bad), "--out", str(out)]
    code = _run(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"signatelec: error: model file {str(bad)!r}: ")
    assert expected in err[0] and err[0].endswith("; retrain or delete it")
    assert not out.exists()


@pytest.fixture
def builds(small_model, tmp_path, monkeypatch) -> list:
    """The default model's cache in ``tmp_path``, its build a stand-in for the recipe (~100 s of
    two cores) that reads the small model: the list of the builds made. A build lasts 0.5 s, so
    that a second ask comes while the first builds."""
    import time

    monkeypatch.setenv("SIGNATELEC_CACHE_DIR", str(tmp_path / "cache"))
    made = []

    def build():
        made.append(1)
        time.sleep(0.5)
        return load_model(small_model)

    monkeypatch.setattr(persistence, "train_default_model", build)
    return made


def test_damaged_default_model_rebuilt(small_model, builds, capsys):
    """A damaged cache entry of the default model is never used: one warning line, rebuilt,
    cached again."""
    cached = persistence.default_model_path()
    cached.parent.mkdir(parents=True, exist_ok=True)
    _damaged(small_model, cached, "middle", 64)
    assert _run(["estimate", str(EXAMPLE), "--omega", "500", "--quiet"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("signatelec: warning: "), err
    assert "checksum mismatch" in err[0] and "rebuilding it" in err[0]
    assert builds == [1]
    load_model(cached)  # sound again
    assert _run(["estimate", str(EXAMPLE), "--omega", "500", "--quiet"]) == 0
    assert capsys.readouterr().err == "" and builds == [1]


def test_the_default_model_is_built_once_when_asked_together(builds):
    """Two asking for the default model at once (a test run's workers, jobs started together):
    the second waits for the first's build and reads it; one build, not two."""
    import threading

    got = []
    asks = [threading.Thread(target=lambda: got.append(persistence.default_model())) for _ in "ab"]
    for t in asks:
        t.start()
    for t in asks:
        t.join()
    assert builds == [1] and len(got) == 2


# --- the command line ----------------------------------------------------------------------


def _run(args: list[str]) -> int:
    try:
        main(args)
    except SystemExit as exc:
        return int(exc.code or 0)
    return 0


def _example() -> pd.DataFrame:
    return pd.read_csv(EXAMPLE, comment="#")


def test_estimate_example_json(small_model, tmp_path, capsys):
    out = tmp_path / "estimate.json"
    code = _run(
        ["estimate", str(EXAMPLE), "--omega", "500", "--model", str(small_model), "--out", str(out)]
    )
    text = capsys.readouterr().out
    assert code == 0, text
    assert "radial load F_r" in text and "regime" in text
    res = json.loads(out.read_text())
    for key in ("radial_load_n", "epsilon", "clearance_m", "regime"):
        assert key in res
    for key in ("radial_load_n", "epsilon", "clearance_m"):
        assert res[f"{key}_low"] <= res[key] <= res[f"{key}_high"]
    probs = [res[f"regime_probability_{r}"] for r in REGIMES]
    assert sum(probs) == pytest.approx(1.0)
    assert res["radial_load_n"] == pytest.approx(7000.0, rel=0.05)  # the example's load


def test_an_atypical_trace_calls_no_regime_confidently(small_model, monkeypatch):
    """Features as atypical as the 1 % most atypical training traces (in-domain score below
    WARN_SCORE, above the refusal): the answer is given with its warning, and a regime call of
    0.99 is not confident, as the monitor's stretches are not."""
    from signatelec.estimation.domain import REFUSE_SCORE, WARN_SCORE
    from signatelec.measurement.files import read_trace
    from signatelec.measurement.traces import prepare_trace

    model = load_model(small_model)
    predict_one = model.predict_one

    def sure(features):
        return predict_one(features) | {
            f"regime_probability_{r}": float(r == "zero") for r in REGIMES
        }

    monkeypatch.setattr(model, "predict_one", sure)
    t, r, _ = read_trace(EXAMPLE)
    trace = prepare_trace(t, r, 500.0)
    assert estimate(trace, 500.0, model)["regime_confident"] is True
    low = (REFUSE_SCORE * WARN_SCORE) ** 0.5

    class Atypical:  # the model's domain, every trace scored ``low``
        def __getattr__(self, name):
            return getattr(domain, name)

        def score(self, features):
            return low

    domain = model.domain
    monkeypatch.setattr(model, "domain", Atypical())
    result = estimate(trace, 500.0, model)
    assert result["regime_confident"] is False and result["in_domain_score"] == low
    assert any("extrapolation, so no regime call is confident" in n for n in result["notes"])


@pytest.mark.parametrize(
    ("probabilities", "confident"), [((0.9, 0.06, 0.04), True), ((0.52, 0.08, 0.40), False)]
)
def test_uncertain_regime_is_said(small_model, monkeypatch, probabilities, confident):
    """Below CONFIDENT_PROBABILITY the estimate flags the regime and names the rivals."""
    from signatelec.measurement.files import read_trace
    from signatelec.measurement.traces import prepare_trace

    model = load_model(small_model)
    predict_one = model.predict_one

    def split(features):
        out = predict_one(features)
        for regime, q in zip(REGIMES, probabilities, strict=True):
            out[f"regime_probability_{regime}"] = q
        out["regime"] = REGIMES[int(np.argmax(probabilities))]
        return out

    monkeypatch.setattr(model, "predict_one", split)
    t, r, _ = read_trace(EXAMPLE)
    trace = prepare_trace(t, r, 500.0)
    result = estimate(trace, 500.0, model)
    text = format_estimate(result)
    assert result["regime_confident"] is confident
    if confident:
        assert "uncertain" not in text
    else:
        assert "regime uncertain: preload or clearance" in text and ", uncertain)" in text
        assert "zero" not in result["notes"][0]


def test_estimate_parquet_and_columns(small_model, tmp_path, capsys):
    df = _example().rename(columns={"time_s": "t", "resistance_ohm": "R"})
    src = tmp_path / "trace.parquet"
    df.to_parquet(src)
    out = tmp_path / "estimate.parquet"
    args = ["estimate", str(src), "--omega", "500", "--model", str(small_model)]
    args += ["--out", str(out), "--time-column", "t", "--resistance-column", "R", "--quiet"]
    assert _run(args) == 0
    res = pd.read_parquet(out)
    assert len(res) == 1 and {"radial_load_n", "epsilon_high", "regime"} <= set(res.columns)


def _formats(df: pd.DataFrame, tmp: Path) -> dict[str, Path]:
    """The trace ``df`` (time_s in seconds) as spreadsheets and loggers write it: separated by
    semicolons or tabs with decimal commas (a European locale's export), its time as Parquet
    timestamps (without a zone, in Paris time, as elapsed durations), as ISO 8601 text or a time
    of day (with a comma fraction, a zero one dropped in the first row; or past midnight), as
    text in Parquet (its first missing), and compressed by gzip, bzip2 or xz."""
    stamps = pd.Timestamp("2026-11-24 10:00:00") + pd.to_timedelta(
        np.round(df["time_s"].to_numpy() * 1e9).astype(np.int64), unit="ns"
    )
    paths = {}
    for name, sep in (("semicolons.csv", ";"), ("tabs.tsv", "\t")):
        df.to_csv(tmp / name, sep=sep, decimal=",", index=False)
        paths[name] = tmp / name
    for name, time in (
        ("stamps.parquet", stamps),
        ("paris.parquet", stamps.tz_localize("Europe/Paris")),
        ("elapsed.parquet", stamps - stamps[0]),
    ):
        df.assign(time_s=time).to_parquet(tmp / name)
        paths[name] = tmp / name
    df.assign(time_s=stamps.strftime("%Y-%m-%dT%H:%M:%S.%fZ")).to_csv(tmp / "iso.csv", index=False)
    paths["iso.csv"] = tmp / "iso.csv"
    # a European export: a comma fraction in the timestamp, decimal commas, semicolons
    comma = df.assign(time_s=stamps.strftime("%Y-%m-%d %H:%M:%S,%f"))
    comma.loc[0, "time_s"] = comma.loc[0, "time_s"].split(",")[0]  # a zero fraction dropped
    comma.to_csv(tmp / "european.csv", sep=";", decimal=",", index=False)
    paths["european.csv"] = tmp / "european.csv"
    clock = df.assign(time_s=stamps.strftime("%H:%M:%S,%f"))
    clock.loc[0, "time_s"] = clock.loc[0, "time_s"].split(",")[0]
    clock.to_csv(tmp / "clock.csv", sep=";", decimal=",", index=False)
    paths["clock.csv"] = tmp / "clock.csv"
    # a logger's time of day, no date, running past midnight 0.1 s after its first sample
    late = stamps - stamps[0] + pd.Timestamp("2026-11-24 23:59:59.9")
    df.assign(time_s=late.strftime("%H:%M:%S.%f")).to_csv(tmp / "midnight.csv", index=False)
    paths["midnight.csv"] = tmp / "midnight.csv"
    # seconds as text in Parquet, the first missing (pandas' NA, not NaN)
    text = df.assign(time_s=df["time_s"].map(repr).astype("string"))
    text.loc[0, "time_s"] = pd.NA
    text.to_parquet(tmp / "text.parquet")
    paths["text.parquet"] = tmp / "text.parquet"
    for compression in ("gz", "bz2", "xz"):  # a logger's compressed CSV
        df.to_csv(tmp / f"packed.csv.{compression}", index=False)
        paths[f"packed.csv.{compression}"] = tmp / f"packed.csv.{compression}"
    return paths


def test_estimate_reads_spreadsheet_and_logger_formats(small_model, tmp_path, capsys):
    """The example written with decimal commas, or with timestamps for its time, gives the
    example's estimate (the decimal commas had been refused as text in the time column; a
    Parquet timestamp had been read as nanoseconds for seconds, "sampled at 2e-05 Hz"), and so
    does the example less one sample: timestamps are read as seconds after the first, exact
    (as seconds since 1970 they round to 0.24 us, and the step read past a missing sample
    was off: resampled at 19972.9 Hz); a timestamp column with a cell that is no timestamp is
    refused naming it."""
    args = ["--omega", "500", "--model", str(small_model), "--quiet"]
    answers = {}
    for name, path in {"example": EXAMPLE, **_formats(_example(), tmp_path)}.items():
        out = tmp_path / f"{name}.json"
        assert _run(["estimate", str(path), *args, "--out", str(out)]) == 0, capsys.readouterr()
        answers[name] = json.loads(out.read_text())["radial_load_n"]
    # (the text's first time is missing: the example less its first sample)
    _example().iloc[1:].to_csv(tmp_path / "later.csv", index=False)
    out = tmp_path / "later.json"
    assert _run(["estimate", str(tmp_path / "later.csv"), *args, "--out", str(out)]) == 0
    later = json.loads(out.read_text())["radial_load_n"]
    assert answers.pop("text.parquet") == pytest.approx(later, rel=1e-9)
    assert answers == pytest.approx(dict.fromkeys(answers, answers["example"]), rel=1e-9)
    holed = _example().drop(index=500)
    holed.to_csv(tmp_path / "holed.csv", index=False)
    _formats(holed, tmp_path)  # (the stamps' files written again, less the sample)
    for name in ("holed.csv", "stamps.parquet", "iso.csv"):
        out = tmp_path / f"holed_{name}.json"
        assert _run(["estimate", str(tmp_path / name), *args, "--out", str(out)]) == 0
        answers[f"holed_{name}"] = json.loads(out.read_text())["radial_load_n"]
    assert answers["holed_stamps.parquet"] == pytest.approx(answers["holed_holed.csv"], rel=1e-9)
    assert answers["holed_iso.csv"] == pytest.approx(answers["holed_holed.csv"], rel=1e-9)
    # a logger's note column in its own code page (Latin-1): not read, no matter
    noted = _example().assign(note="Lager \xe4")
    noted.to_csv(tmp_path / "noted.csv", index=False, encoding="latin-1")
    out = tmp_path / "noted.json"
    assert _run(["estimate", str(tmp_path / "noted.csv"), *args, "--out", str(out)]) == 0
    assert json.loads(out.read_text())["radial_load_n"] == answers["example"]
    bad = pd.read_csv(tmp_path / "iso.csv")
    bad.loc[700, "time_s"] = "soon"
    bad.to_csv(tmp_path / "bad.csv", index=False)
    assert _run(["estimate", str(tmp_path / "bad.csv"), *args]) == 2
    err = capsys.readouterr().err
    assert (
        "column 'time_s' holds text at row 700 ('soon'); seconds or ISO 8601 timestamps only" in err
    )


def test_estimate_repairs(small_model, tmp_path, capsys):
    """Isolated NaN and open-circuit samples, a short gap and jittered times are repaired."""
    df = _example()
    rng = np.random.default_rng(0)
    r = df["resistance_ohm"].to_numpy().copy()
    r[[100, 700, 1500]] = np.nan
    r[900] = np.inf
    r[1200:1204] = np.nan
    t = df["time_s"].to_numpy() + rng.uniform(0, 0.3, len(df)) / 20000.0
    path = tmp_path / "repair.csv"
    pd.DataFrame({"time_s": t, "resistance_ohm": r}).to_csv(path, index=False)
    out = tmp_path / "e.json"
    code = _run(
        ["estimate", str(path), "--omega", "500", "--model", str(small_model), "--out", str(out)]
    )
    text = capsys.readouterr().out
    assert code == 0
    assert "interpolated" in text and "resampled" in text
    res = json.loads(out.read_text())
    assert res["radial_load_n"] == pytest.approx(7000.0, rel=0.05)


def _bad_traces(tmp: Path) -> dict[str, tuple[Path, str]]:
    df = _example()
    t, r = df["time_s"].to_numpy(), df["resistance_ohm"].to_numpy()
    n_min = int(5 / expected_ball_pass_hz(500.0) * 20000.0)
    cases = {}

    def write(name, tt, rr, expected, suffix=".csv"):
        p = tmp / f"{name}{suffix}"
        pd.DataFrame({"time_s": tt, "resistance_ohm": rr}).to_csv(p, index=False)
        cases[name] = (p, expected)

    write("too_short", t[: n_min - 5], r[: n_min - 5], "too short")
    back = t.copy()
    back[50] = back[40]
    write("non_monotone", back, r, "does not increase")
    nan = r.copy()
    nan[::2] = np.nan
    write("mostly_nan", t, nan, "missing or not finite")
    gap = r.copy()
    gap[400:460] = np.nan  # 3 ms: 3 % of the samples, but 1.2 ball passes long
    write("long_gap", t, gap, "longer than")
    op = r.copy()
    op[::20] = np.inf
    write("open_circuit", t, op, "open circuit")
    write("low_rate", t[::8], r[::8], "below the")
    p = tmp / "no_column.csv"
    df.rename(columns={"resistance_ohm": "R"}).to_csv(p, index=False)
    cases["no_column"] = (p, "no column 'resistance_ohm'")
    p = tmp / "trace.xlsx"
    p.write_text("x")
    cases["unknown_format"] = (p, "unknown format")
    cases["missing_file"] = (tmp / "nothing.csv", "no such file")
    # unreadable inputs: empty, one sample, text in a number column, truncated Parquet, a directory
    write("empty", t[:0], r[:0], "0 samples")
    write("one_sample", t[:1], r[:1], "1 samples")
    text = pd.DataFrame({"time_s": t, "resistance_ohm": r.astype(object)})
    text.loc[700, "resistance_ohm"] = "abc"
    p = tmp / "text.csv"
    text.to_csv(p, index=False)
    cases["text_in_column"] = (p, "resistance_ohm")
    p = tmp / "truncated.parquet"
    df.to_parquet(p)
    p.write_bytes(p.read_bytes()[:200])
    cases["truncated_parquet"] = (p, "cannot be read as parquet")
    p = tmp / "folder.csv"
    p.mkdir()
    cases["directory"] = (p, "trace")
    p = tmp / "stamped.parquet"  # timestamps where the resistance is asked
    pd.DataFrame(
        {"time_s": t, "resistance_ohm": pd.Timestamp(0) + pd.to_timedelta(t, "s")}
    ).to_parquet(p)
    cases["timestamps_for_resistance"] = (p, "column 'resistance_ohm' holds timestamps")
    p = tmp / "latin.csv"  # a byte that is not UTF-8 in the resistance column
    p.write_bytes(b"time_s,resistance_ohm\n0,0.0025\n5e-5,0.0025\xe4\n")
    cases["latin1_in_column"] = (p, "column 'resistance_ohm' holds text at row 1")
    p = tmp / "simulated"  # a simulation's clean signals (their phase column tells them)
    assert _run(["simulate", "--fidelity", "quasistatic", "--quiet", "--out", str(p)]) == 0
    cases["clean_simulation"] = (
        p / "signals.parquet",
        "a simulation's signals carry no meter's noise, which every training trace has",
    )
    # the same with a meter's noise, and none of the ripple: refused, no word of noise
    noisy = pd.read_parquet(p / "signals.parquet")
    noisy["resistance_ohm"] = noisy["resistance_ohm"].mean() * (
        1 + 0.03 * np.random.default_rng(2).standard_normal(len(noisy))
    )
    noisy.to_parquet(tmp / "noisy_simulation.parquet")
    cases["noisy_simulation"] = (tmp / "noisy_simulation.parquet", "no ball-pass ripple found")
    return cases


@pytest.mark.parametrize(
    "case",
    [
        "too_short",
        "non_monotone",
        "mostly_nan",
        "long_gap",
        "open_circuit",
        "low_rate",
        "no_column",
        "unknown_format",
        "missing_file",
        "empty",
        "one_sample",
        "text_in_column",
        "truncated_parquet",
        "directory",
        "timestamps_for_resistance",
        "latin1_in_column",
        "clean_simulation",
        "noisy_simulation",
    ],
)
def test_estimate_refuses(small_model, tmp_path, capsys, case):
    path, expected = _bad_traces(tmp_path)[case]
    out = tmp_path / "never.json"
    code = _run(
        ["estimate", str(path), "--omega", "500", "--model", str(small_model), "--out", str(out)]
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("signatelec: error: "), err
    assert expected in err[0]
    assert ("meter's noise" in err[0]) is (case == "clean_simulation")
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["--omega", "0"], "must be > 0"),
        (["--omega", "nan"], "finite"),
        (["--omega", "500", "--out", "x.txt"], "must end in .json or .parquet"),
    ],
)
def test_estimate_bad_options(small_model, capsys, args, expected):
    code = _run(["estimate", str(EXAMPLE), "--model", str(small_model), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and expected in err[0]


@pytest.mark.slow
def test_train_and_estimate(tmp_path, capsys):
    """`signatelec train` on a feature table, and on a directory of measured traces."""
    table = pd.read_parquet(DEFAULT_TABLE)
    small = table[table["run_id"].isin(np.unique(table["run_id"])[::6])]
    src = tmp_path / "features.parquet"
    small.to_parquet(src)
    model = tmp_path / "m.model"
    assert _run(["train", str(src), "--out", str(model)]) == 0
    assert "trained on" in capsys.readouterr().out
    assert _run(["estimate", str(EXAMPLE), "--omega", "500", "--model", str(model)]) == 0
    # a file of measured traces, one per row, the layout `signatelec generate` writes
    df = _example()
    rows = []
    for i in range(12):
        rows.append(
            {
                "trace_id": i,
                "sample_rate_hz": 20000.0,
                "omega_rad_s": 500.0,
                "radial_load_n": 7000.0 * (1 + 0.05 * i),
                "epsilon": 0.45,
                "clearance_m": 8e-6,
                "regime": "clearance" if i % 2 else "zero",
                "resistance_ohm": df["resistance_ohm"].to_numpy() * (1 - 0.05 * i),
            }
        )
    traces = tmp_path / "traces.parquet"
    pd.DataFrame(rows).to_parquet(traces)
    assert _run(["train", str(traces), "--out", str(tmp_path / "t.model"), "--quiet"]) == 0
    assert _run(["train", str(tmp_path / "nothing"), "--out", str(tmp_path / "x.model")]) == 2
    assert "no such file" in capsys.readouterr().err


def test_default_model_built_once(builds, tmp_path, capsys):
    """Without --model: built on first use, with one line saying so, then read from the cache.
    The build stands in for the recipe: the trace-sanity and fuzz fixtures ask for the default
    model itself, which a test run with an empty cache (CI's) trains on the shipped tables."""
    assert _run(["estimate", str(EXAMPLE), "--omega", "500"]) == 0
    first = capsys.readouterr()
    assert "building the default model" in first.err
    assert list((tmp_path / "cache" / "models").glob("*.model")) == [
        persistence.default_model_path()
    ]
    assert _run(["estimate", str(EXAMPLE), "--omega", "500"]) == 0
    second = capsys.readouterr()
    assert "building" not in second.err
    assert second.out == first.out and builds == [1]
    shutil.rmtree(tmp_path / "cache")
