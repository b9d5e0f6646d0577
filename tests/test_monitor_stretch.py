"""The stretch model: its training rows (a stretch's mean features), and how a stretch's
estimate takes its answer (value, interval, regime) or falls back to the windows'."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from signatelec.estimation.evidence import BIAS_RATIO, Z90, combine_stretch
from signatelec.physics.kinematics import expected_ball_pass_hz
from signatelec.studies.load_state import (
    OFFSET_OHM,
    STRETCH_LENGTHS_S,
    STRETCH_WINDOWS,
    stretch_table,
)

FS, OMEGA = 20000.0, 500.0
H1, H2 = 0.004, 0.001


def _ripple_runs(n_runs: int) -> pd.DataFrame:
    """Runs whose clean trace is a ball-pass ripple of known relative harmonics H1, H2."""
    t = np.arange(int(0.2 * FS)) / FS
    f = expected_ball_pass_hz(OMEGA)
    clean = 5e-3 * (1 + H1 * np.cos(2 * np.pi * f * t) + H2 * np.cos(4 * np.pi * f * t + 0.3))
    row = {
        "sample_rate_hz": FS,
        "omega_rad_s": OMEGA,
        "resistance_clean_ohm": clean,
        "radial_load_n": 5000.0,
        "epsilon": 0.4,
        "clearance_m": 1e-5,
        "regime": "clearance",
    }
    return pd.DataFrame([{**row, "trace_id": i} for i in range(n_runs)])


def test_stretch_rows_keep_the_ripple_and_average_the_noise():
    """A stretch row is the mean of n noisy windows' features: its harmonics are the clean
    trace's to within the least-squares amplitude error averaged over the windows,
    sd = sigma (2 / N / n)^(1/2) (N samples a window, sigma the noise relative to the level;
    measured |z| up to 4.7, sd 1.6: the ball-pass frequency is fitted too), and its noise
    estimate is the meter's noise (measured within 3.4 % above 0.1 % noise; drift adds)."""
    rows = stretch_table(_ripple_runs(8), 0)
    assert len(rows) == 8 * 12
    assert set(rows["n_windows"]) <= set(STRETCH_WINDOWS)
    assert set(rows["length_s"].astype(float).round(3)) <= set(STRETCH_LENGTHS_S)
    sd = rows["noise_fraction"] * np.sqrt(2.0 / (rows["length_s"] * FS) / rows["n_windows"])
    assert np.abs((rows["h1_rel"] - H1) / sd).max() < 7.0
    assert np.abs((rows["h2_rel"] - H2) / sd).max() < 7.0
    clear = rows["noise_fraction"] >= 1e-3
    ratio = rows.loc[clear, "noise_rms_rel"] / rows.loc[clear, "noise_fraction"]
    assert np.abs(ratio - 1.0).max() < 0.08
    # the level: the clean trace's, moved by the meter's offset (+-20 uOhm) and drift
    assert rows["level_mean_ohm"].to_numpy() == pytest.approx(5e-3, abs=OFFSET_OHM * 1.25)


class _Fixed:
    """A stretch model that answers one state and records the mean features it was asked."""

    features = ["h1_rel", "h2_rel"]

    def __init__(self):
        self.asked = None

    def predict_one(self, features: dict) -> dict:
        self.asked = features
        return {
            "radial_load_n": 5000.0,
            "radial_load_n_low": 4950.0,
            "radial_load_n_high": 5050.0,
            "epsilon": 0.40,
            "epsilon_low": 0.39,
            "epsilon_high": 0.41,
            "clearance_m": 1.0e-5,
            "clearance_m_low": 0.9e-5,
            "clearance_m_high": 1.1e-5,
            "regime": "clearance",
            "regime_probability_clearance": 0.7,
            "regime_probability_preload": 0.1,
            "regime_probability_zero": 0.2,
        }


def _windows(n: int, seed: int = 0, condition: str | None = None) -> pd.DataFrame:
    """n windows of one state whose estimates all agree (no scatter): zero regime, 5200 N."""
    rng = np.random.default_rng(seed)
    w = pd.DataFrame(
        {
            "radial_load_n": 5200.0,
            "radial_load_n_low": 5100.0,
            "radial_load_n_high": 5300.0,
            "epsilon": 0.5,
            "epsilon_low": 0.49,
            "epsilon_high": 0.51,
            "clearance_m": 0.0,
            "clearance_m_low": -1e-6,
            "clearance_m_high": 1e-6,
            "regime_probability_clearance": 0.05,
            "regime_probability_preload": 0.05,
            "regime_probability_zero": 0.9,
            "h1_rel": rng.normal(H1, 1e-4, n),
            "h2_rel": rng.normal(H2, 1e-4, n),
        },
        index=range(n),
    )
    if condition is not None:
        w["condition"] = condition
        w["condition_probability_healthy"] = 0.9 if condition == "healthy" else 0.1
        w["condition_probability_outer"] = 0.1 if condition == "healthy" else 0.9
    return w


@pytest.mark.parametrize("n", [12, 1])
def test_stretch_takes_the_stretch_models_answer(n):
    """Value and regime are the stretch model's, asked about the windows' mean features (also
    for a stretch of one window, which leaving out the windows that straddle a change can make:
    the two stretches of a change are read by one model); with no scatter between the windows
    the interval is the model's own, on the combining scale, times the calibrated ratio of the
    regime it is estimated in (b z90 sd_model)."""
    model, windows = _Fixed(), _windows(n, condition="healthy")
    s = combine_stretch(windows, stretch_model=model)
    assert model.asked == pytest.approx(windows[list(model.features)].mean().to_dict())
    assert s["estimated_from"] == "mean features"
    assert s["regime"] == "clearance" and s["regime_probability"] == pytest.approx(0.7)
    assert s["condition"] == "healthy"
    b = BIAS_RATIO["radial_load_n"]["clearance"]
    half = b * math.log(5050.0 / 4950.0) / 2.0  # z90 sd, sd = log(high / low) / (2 z90)
    assert s["radial_load_n"] == pytest.approx(5000.0)
    assert s["radial_load_n_low"] == pytest.approx(5000.0 * math.exp(-half))
    assert s["radial_load_n_high"] == pytest.approx(5000.0 * math.exp(half))
    b = BIAS_RATIO["epsilon"]["clearance"]
    assert s["epsilon_high"] - s["epsilon"] == pytest.approx(b * 0.01)
    assert s["epsilon_se_noise"] == 0.0
    assert s["epsilon_window_sd"] == pytest.approx(0.01 / Z90)


class _Foreign:
    """A domain in which every stretch lies far out."""

    def score(self, features: dict) -> float:
        return 1e-9


@pytest.mark.parametrize("case", ["no model", "feature missing", "not finite", "unlike training"])
def test_stretch_falls_back_to_the_windows(case):
    """The windows' combination answers when there is no stretch model, a feature the windows
    did not keep or that is not finite, or mean features unlike every training stretch."""
    model = None if case == "no model" else _Fixed()
    if case == "unlike training":
        model.domain = _Foreign()
    windows = _windows(12, condition="healthy")
    if case == "not finite":
        windows.loc[3, "h1_rel"] = np.nan
    if case == "feature missing":
        windows = windows.drop(columns="h2_rel")
    s = combine_stretch(windows, stretch_model=model)
    assert s["estimated_from"] == "windows"
    assert s["radial_load_n"] == pytest.approx(5200.0)
    assert s["regime"] == "zero"
    assert model is None or model.asked is None


class _Scored:
    """A domain that scores every stretch alike."""

    def __init__(self, score: float):
        self.value = score

    def score(self, features: dict) -> float:
        return self.value


@pytest.mark.parametrize("score", [1e-4, 0.5])
def test_a_stretch_reports_how_like_its_training_stretches_it_is(score):
    """A stretch the stretch model answers carries its mean features' in-domain score among the
    training stretches (the windows' own median stays ``in_domain_score``); one answered, yet
    as atypical as the 1 % most atypical training stretches (below the warning score, above the
    refusal), is warned of as an extrapolation and no regime call on it is confident."""
    from signatelec.estimation.domain import REFUSE_SCORE, WARN_SCORE
    from signatelec.estimation.monitor_report import qualify

    assert REFUSE_SCORE < 1e-4 < WARN_SCORE < 0.5
    model = _Fixed()
    model.domain = _Scored(score)
    windows = _windows(12, condition="healthy").assign(in_domain_score=0.8)
    s = combine_stretch(windows, stretch_model=model)
    assert s["estimated_from"] == "mean features"
    assert s["stretch_in_domain_score"] == score and s["in_domain_score"] == 0.8
    s.update(start_s=0.0, end_s=2.4, regime_probability=0.99)  # a sure regime call
    notes = qualify([s])
    warned = score < WARN_SCORE
    assert len(notes) == warned and s["regime_confident"] is not warned
    if warned:
        assert "stretch's mean features" in notes[0] and "extrapolation" in notes[0]


def test_a_faulty_stretch_is_answered_and_warned_of():
    """Both the stretch model and the window model learnt healthy bearings: a stretch whose
    condition is confidently a spall keeps the stretch model's answer, and the summary warns
    that its load state is an extrapolation (no regime call on it is confident)."""
    from signatelec.estimation.monitor_report import qualify

    model = _Fixed()
    s = combine_stretch(_windows(12, condition="outer"), stretch_model=model)
    assert s["estimated_from"] == "mean features" and s["condition"] == "outer"
    s.update(start_s=0.0, end_s=2.4)
    notes = qualify([s])
    assert len(notes) == 1 and "condition outer" in notes[0] and "extrapolation" in notes[0]
    assert s["regime_confident"] is False
