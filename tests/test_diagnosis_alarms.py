"""The diagnosis study's statistics and the condition's characteristic line.

The false-alarm bound is checked against its definition and closed form (Clopper and Pearson,
Biometrika 26 (1934) 404-413), the counting against its unit (runs, not windows); the line that
names a defect against the textbook kinematics of a rolling bearing (Harris and Kotzalas,
"Rolling Bearing Analysis", 5th ed. 2006, ch. 7; Randall and Antoni, MSSP 25 (2011) 485-520,
eqs 1-2). The figures on held-out DEM runs are measured by ``signatelec study diagnosis``
(docs/diagnosis), not here.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binom

from signatelec.config.scene import Scene
from signatelec.estimation.diagnose import matched_line
from signatelec.estimation.envelope import analyse_envelope
from signatelec.studies.diagnosis_alarms import (
    alarm_figures,
    clopper_pearson_upper,
    load_error_figures,
)


@pytest.mark.parametrize("n", [10, 50, 299, 350])
def test_upper_bound_without_alarms_is_closed_form(n):
    """With none of n flagged the exact one-sided 95 % bound is 1 - 0.05^(1/n)."""
    assert clopper_pearson_upper(0, n) == pytest.approx(1.0 - 0.05 ** (1.0 / n), rel=1e-9)


def test_one_percent_needs_299_runs():
    """0 of 299 bounds the rate below 1 %, 0 of 298 does not (the study's run count)."""
    assert clopper_pearson_upper(0, 299) < 0.01 < clopper_pearson_upper(0, 298)


@pytest.mark.parametrize(("flagged", "n"), [(1, 10), (2, 300), (5, 40)])
def test_upper_bound_meets_its_definition(flagged, n):
    """P(X <= flagged | n, p_U) = 5 % at the bound (binomial tail, Clopper-Pearson 1934);
    1 of 10: (1 - p)^10 + 10 p (1 - p)^9 = 0.05 at p = 0.394."""
    p = clopper_pearson_upper(flagged, n)
    assert binom.cdf(flagged, n, p) == pytest.approx(0.05, abs=1e-9)
    if (flagged, n) == (1, 10):
        assert p == pytest.approx(0.394, abs=5e-4)


def test_alarms_counted_by_run():
    """Three windows of one run flagged count as one flagged run among the runs."""
    calls = ["healthy"] * 9 + ["outer", "outer", "healthy"]
    pred = pd.DataFrame(
        {
            "run_id": np.repeat([f"seed-{i}" for i in range(4)], 3),
            "bearing": "seed",
            "pred_condition": calls,
        }
    )
    row = alarm_figures(pred).set_index("group").loc["all"]
    assert (row["runs"], row["flagged"], row["rate"]) == (4, 1, 0.25)
    assert row["called"] == "outer 1"


def test_load_error_rule():
    """A spall's MAPE holds when its interval overlaps the healthy one (or lies below it) and
    its point value is within the healthy half-width; twice the healthy error does not, half of
    it does."""
    rng = np.random.default_rng(0)
    rows = []
    for condition, scale in (("healthy", 1.0), ("outer", 1.0), ("inner", 2.0), ("ball", 0.5)):
        for run in range(60):
            ape = 0.005 * scale * rng.uniform(0.5, 1.5)
            for _ in range(3):
                rows.append(
                    {
                        "run_id": f"{condition}-{run}",
                        "condition": condition,
                        "acceptance": True,
                        "radial_load_n": 5000.0,
                        "pred_load_radial_load_n": 5000.0 * (1.0 + ape),
                    }
                )
    table = load_error_figures(pd.DataFrame(rows)).set_index("condition")
    assert table.loc["healthy", "low"] < 0.005 < table.loc["healthy", "high"]
    assert table.loc["outer", "holds"] == 1.0
    assert table.loc["inner", "holds"] == 0.0
    assert table.loc["ball", "high"] < table.loc["healthy", "low"]
    assert table.loc["ball", "holds"] == 1.0


def _pulses(f_hz: float, fs: float = 20000.0, duration_s: float = 0.2) -> np.ndarray:
    """A resistance of 3 mOhm with a 5 % pulse of 0.2 ms at each passage, 0.2 % noise."""
    t = np.arange(int(duration_s * fs)) / fs
    phase = (t * f_hz) % 1.0
    r = 3e-3 * (1.0 + 0.05 * (phase < 0.2e-3 * f_hz))
    return r * (1.0 + 0.002 * np.random.default_rng(1).standard_normal(t.size))


@pytest.mark.parametrize(("condition", "sign"), [("outer", -1.0), ("inner", 1.0)])
def test_defect_line_found_at_the_kinematic_frequency(condition, sign):
    """Pulses at BPFO (BPFI) = Z/2 f_s (1 -+ d/D) of the seed's bearing (Harris and Kotzalas
    2006, eqs 7.21-7.22 at contact angle 0) are named and found within one bin 1/T of it."""
    b = Scene().bearing
    omega = 500.0
    f_s = omega / (2.0 * math.pi)
    pitch_d = b.outer_race_radius_m + b.inner_race_radius_m
    f_kin = 0.5 * b.n_balls * f_s * (1.0 + sign * 2.0 * b.ball_radius_m / pitch_d)
    fs = 20000.0
    line = matched_line(condition, analyse_envelope(_pulses(f_kin, fs), fs, omega))
    assert line["condition_line"] == {"outer": "bpfo", "inner": "bpfi"}[condition]
    assert line["condition_line_hz"] == pytest.approx(f_kin, rel=1e-9)
    assert abs(line["condition_line_found_hz"] - f_kin) <= 1.0 / 0.2
    assert line["condition_line_snr"] > 5.0
