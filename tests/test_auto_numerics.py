"""Scenes that choose their numerics: any catalogue bearing at any rated speed runs by default.

The seed's scene keeps the paper's numerics (section 4: dt = 1e-7 s, a 5 ms spin-up, 30 ms);
other scenes get a time step within their stability limit and a spin-up gentle enough for their
speed, cage and clearance, and the runs complete and settle on the quasi-static tier's state.
"""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner

from signatelec.cli import cli
from signatelec.config.catalogue import (
    CATALOGUE,
    catalogue_bearing,
    designation_of,
    limiting_speed_rad_s,
)
from signatelec.config.scene import AUTO, Scene, SceneError
from signatelec.engines.fidelity import apply_fidelity
from signatelec.engines.results import DivergenceError, record_rate_hz
from signatelec.engines.simulate import simulate
from signatelec.measurement.band import MIN_BALL_PASSES
from signatelec.measurement.traces import TraceError, prepare_trace
from signatelec.physics.contact import hertz_overlap
from signatelec.physics.electrical import DENSITY_LIMIT_A_M2
from signatelec.physics.laws import chain_force_n, scene_law
from signatelec.physics.stability import (
    CHAIN_OVERLAP_FRACTION,
    DT_ACCURACY_S,
    DT_MARGIN,
    SPIN_UP_MIN_S,
    TRACTION_SHARE,
    chain_contact,
    record_grid_dt_s,
    stability_limit,
    traction_spin_up_time_s,
)


def test_the_seed_scene_keeps_the_papers_numerics():
    scene = Scene()
    assert scene.numerics.dt_s == 1e-7  # seed section 4
    assert scene.procedure.spin_up_time_s == 5e-3
    assert scene.numerics.duration_s == pytest.approx(0.03, abs=1e-15)
    assert set(scene.auto) == {"numerics.dt_s", "procedure.spin_up_time_s", "numerics.duration_s"}
    assert Scene.from_dict({"numerics": {"dt_s": AUTO}}) == scene


@pytest.mark.parametrize("designation", list(CATALOGUE))
def test_chosen_dt_is_within_the_stability_limit_at_every_rated_speed(designation):
    bearing = catalogue_bearing(designation)
    for omega in np.geomspace(10.0, limiting_speed_rad_s(designation), 5):
        for clearance in (-5e-6, 0.0, 20e-6):
            scene = Scene(bearing=bearing).with_overrides(
                omega_rad_s=float(omega), clearance_m=clearance
            )
            limit = stability_limit(scene).dt_limit_s
            assert scene.numerics.dt_s <= DT_MARGIN * limit * (1 + 1e-12)
            assert scene.numerics.dt_s <= DT_ACCURACY_S
            rate = scene.numerics.sample_rate_hz
            assert scene.numerics.dt_s == record_grid_dt_s(
                min(DT_ACCURACY_S, DT_MARGIN * limit), rate
            )
            assert scene.record_every * scene.numerics.dt_s * rate == pytest.approx(1, rel=1e-12)
            assert scene.numerics.duration_s > scene.setup_time_s


@pytest.mark.parametrize("designation", list(CATALOGUE))
def test_spin_up_keeps_the_chain_force_below_its_overlap(designation):
    """The chain force of the chosen spin-up (engines' eq. of the sinusoid) presses the chain's
    contact (Hertz, seed eq. 6) by at most CHAIN_OVERLAP_FRACTION of its radius."""
    bearing = catalogue_bearing(designation)
    for omega in np.geomspace(10.0, limiting_speed_rad_s(designation), 5):
        scene = Scene(bearing=bearing).with_overrides(omega_rad_s=float(omega))
        kind, radius = chain_contact(scene)
        coef, _ = scene_law(scene)
        overlap = hertz_overlap(chain_force_n(scene), coef[kind])
        assert overlap <= CHAIN_OVERLAP_FRACTION * radius
        assert scene.procedure.spin_up_time_s >= SPIN_UP_MIN_S


def test_the_spin_up_grows_with_speed_and_clearance():
    base = Scene()
    times = [base.with_overrides(omega_rad_s=w).procedure.spin_up_time_s for w in (500, 1000, 3000)]
    assert times[0] == 5e-3
    # measured on the seed's scene: 1000 rad/s fails with 5 ms and passes with 10 ms, 3000 rad/s
    # fails with 40 ms and passes with 80 ms; the rule keeps about a factor of 2 above those
    assert 10e-3 <= times[1] <= 40e-3
    assert 80e-3 <= times[2] <= 320e-3
    # a 247 um clearance (0.1 C_r) at 500 rad/s fails with 5 ms and passes with 10 ms
    assert 10e-3 <= base.with_overrides(clearance_m=247e-6).procedure.spin_up_time_s <= 40e-3


def test_a_value_given_is_kept_and_the_others_chosen_again():
    scene = Scene().with_overrides(dt_s=5e-8)
    faster = scene.with_overrides(omega_rad_s=1000.0)
    assert faster.numerics.dt_s == 5e-8
    assert faster.procedure.spin_up_time_s > 5e-3
    assert faster.numerics.duration_s > faster.setup_time_s
    assert "numerics.dt_s" not in faster.auto
    with pytest.raises(SceneError, match=r'numerics\.dt_s = .fast.: must be a number or "auto"'):
        Scene.from_dict({"numerics": {"dt_s": "fast"}})


def test_explicit_dt_above_the_limit_is_refused_with_the_limit():
    scene = Scene(bearing=catalogue_bearing("6205")).with_overrides(dt_s=2e-6)
    with pytest.raises(SceneError, match=r"numerics\.dt_s = 2e-06: above the stability limit"):
        simulate(scene)


def _steady_close_to_tier(result) -> None:
    """The DEM's steady state against the quasi-static tier on the same instants."""
    tier = simulate(
        result.scene.with_overrides(
            fidelity="quasistatic",
            spin_up_time_s=result.scene.procedure.spin_up_time_s,
            dt_s=result.scene.numerics.dt_s,
            duration_s=result.scene.numerics.duration_s,
        )
    )
    # whole ball passes only: the largest ball load ripples at the ball-pass frequency, and the
    # DEM's cage phase lags the tier's kinematic one after the spin-up
    d, q = result.steady(settle_s=2e-3), tier.steady(settle_s=2e-3)
    period = 1.0 / result.scene.bearing.ball_pass_frequency_hz(result.scene.operating.omega_rad_s)
    end = d.time_s.iloc[-1]
    start = end - period * math.floor((end - d.time_s.iloc[0]) / period)
    d, q = d[d.time_s > start + 1e-12], q[q.time_s > start + 1e-12]
    assert d.resistance_ohm.mean() == pytest.approx(q.resistance_ohm.mean(), rel=0.01)
    assert d.max_ball_load_n.mean() == pytest.approx(q.max_ball_load_n.mean(), rel=0.02)


@pytest.mark.parametrize(
    "designation, omega, load_n, clearance_m",
    [
        ("seed", 1000.0, 5820.0, 0.0),  # 9550 rpm: refused, then diverged, at the old defaults
        ("6208", 500.0, 5820.0, 0.0),  # diverged in the spin-up at the old defaults
        ("6205", 1800.0, 5820.0, 0.0),
        ("6308", 500.0, 20000.0, 20e-6),
    ],
)
def test_defaults_run_any_bearing_without_warning(designation, omega, load_n, clearance_m):
    scene = Scene(bearing=catalogue_bearing(designation)).with_overrides(
        omega_rad_s=omega, radial_load_n=load_n, clearance_m=clearance_m
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = simulate(scene)
    t = result.timings
    assert (
        t["dt_s"] == scene.numerics.dt_s and t["spin_up_time_s"] == scene.procedure.spin_up_time_s
    )
    assert "procedure.spin_up_time_s" in t["chosen"]
    # the set-up's first contacts carry the whole current on a tiny area; the running bearing
    # does not (seed section 3: 0.1 A/mm^2)
    assert t["steady_peak_current_density_a_m2"] < DENSITY_LIMIT_A_M2
    _steady_close_to_tier(result)


def test_the_set_up_peak_density_is_reported_not_warned():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = simulate(Scene())
    assert result.timings["setup_peak_current_density_a_m2"] > DENSITY_LIMIT_A_M2
    assert result.timings["steady_peak_current_density_a_m2"] < DENSITY_LIMIT_A_M2


def test_divergence_names_phase_body_and_the_measured_cure():
    """The seed at 1000 rad/s with the seed's 5 ms spin-up diverges in the spin-up (cage ball on
    its boundary); a doubled spin-up is measured to cure it."""
    scene = Scene().with_overrides(omega_rad_s=1000.0, spin_up_time_s=5e-3, duration_s=0.03)
    with pytest.raises(DivergenceError) as info:
        simulate(scene)
    message = str(info.value)
    assert "in the spin_up phase" in message and "cage ball" in message
    assert "cure measured: a longer spin-up, procedure.spin_up_time_s = 0.01" in message


def test_scene_designation_and_cli(tmp_path):
    scene = Scene.from_dict({"bearing": {"designation": "6205", "n_balls": 8}})
    assert scene.bearing == catalogue_bearing("6205", n_balls=8)
    assert Scene.from_dict(scene.to_dict()) == scene  # written out field by field
    with pytest.raises(SceneError, match=r"bearing.designation = '6209': unknown bearing"):
        Scene.from_dict({"bearing": {"designation": "6209"}})
    listing = CliRunner().invoke(cli, ["bearings"])
    assert listing.exit_code == 0 and all(d in listing.output for d in CATALOGUE)
    csv = CliRunner().invoke(cli, ["bearings", "--csv"])
    assert csv.exit_code == 0 and csv.output.count("\n") == len(CATALOGUE) + 1
    bad = CliRunner().invoke(cli, ["simulate", "--bearing", "6209", "--out", str(tmp_path)])
    assert bad.exit_code == 2 and "--bearing '6209': bearing.designation" in bad.output


@pytest.mark.parametrize("fidelity", ["fast", "balanced"])
@pytest.mark.parametrize("rate_hz", [20000.0, 12345.0])
def test_a_presets_step_records_at_the_rate_asked(fidelity, rate_hz):
    """The kernel records every round(1 / (rate dt)) steps: the preset's 0.9 x stability limit
    (1.37e-6 s on a 6208 at 5000 N) recorded every 37 steps, at 19782 Hz for 20 kHz asked. Its
    step is the largest below that fraction with a whole number k of steps per recorded
    instant (k - 1 < period / preset step <= k), so it shrinks by less than one part in k."""
    base = Scene(bearing=catalogue_bearing("6208")).with_overrides(sample_rate_hz=rate_hz)
    for load_n in (2000.0, 5000.0, 8000.0, 12000.0):
        scene = apply_fidelity(base.with_overrides(radial_load_n=load_n), fidelity)
        dt, k = scene.numerics.dt_s, scene.record_every
        assert k * dt == pytest.approx(1.0 / rate_hz, rel=1e-12)
        assert record_rate_hz(scene) == pytest.approx(rate_hz, rel=1e-12)
        preset_dt = 0.9 * stability_limit(scene).dt_limit_s
        assert preset_dt * (k - 1) / k < dt <= preset_dt * (1 + 1e-12)


def test_simulate_records_at_the_rate_asked_or_says_at_which(tmp_path):
    """--fidelity balanced writes its instants 1/20000 s apart, as the metadata says; a --dt
    off the record grid (3e-7 s: every 167 steps, 1 / (167 x 3e-7 s) = 19960.1 Hz) is warned
    with the rate it records at, which the metadata holds."""
    for name, args, rate_hz in (
        ("preset", ["--fidelity", "balanced"], 20000.0),
        ("dt", ["--dt", "3e-7"], 1.0 / (167 * 3e-7)),
    ):
        out = tmp_path / name
        res = CliRunner().invoke(
            cli,
            ["simulate", "--bearing", "6208", "--duration", "0.01", *args, "--out", str(out)],
        )
        assert res.exit_code == 0, res.output
        time_s = pd.read_parquet(out / "signals.parquet", columns=["time_s"])["time_s"]
        assert 1.0 / np.diff(time_s).mean() == pytest.approx(rate_hz, rel=1e-9)
        meta = json.loads(pq.read_schema(out / "signals.parquet").metadata[b"signatelec"])
        assert meta["timings"]["record_rate_hz"] == pytest.approx(rate_hz, rel=1e-12)
        warned = (
            "sample rate 20000 Hz asked, but dt = 3e-07 s records every 167 steps, at 19960.1 Hz"
        )
        assert (warned in res.output) == (name == "dt"), res.output


def test_simulate_prints_what_it_chose(tmp_path):
    out = tmp_path / "run"
    res = CliRunner().invoke(cli, ["simulate", "--bearing", "6208", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "dt = 1e-07 s (auto), spin-up = 5 ms (auto), 0.03 s (auto)" in res.output
    assert "warning" not in res.output
    assert math.isfinite(float(res.output.split("resistance: mean ")[1].split()[0]))


@pytest.mark.parametrize(
    "designation, omega",
    [("seed", 1000.0), ("seed", 3000.0), ("6208", 1152.0), ("6203", 2513.0)],
)
def test_the_chosen_spin_up_keeps_every_overlap_well_below_the_abort(
    designation, omega, monkeypatch
):
    """With the abort threshold lowered from 10 % to 6 % of the body radius, the run still
    completes: no contact, cage balls included, overlaps more than 6 % (the seed's own scene at
    500 rad/s peaks at 7.7 %; measured under the rule: 3.6-5.0 %)."""
    import signatelec.engines.dem.run as dem_run

    original = dem_run.kernel_parameters

    def stricter(scene):
        p = original(scene)
        p["max_overlap_fraction"] = 0.06
        return p

    monkeypatch.setattr(dem_run, "kernel_parameters", stricter)
    scene = Scene(bearing=catalogue_bearing(designation)).with_overrides(omega_rad_s=omega)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dem_run.simulate_dem(scene, cure=False)


def test_at_zero_load_the_rings_weight_alone_drives_the_balls_at_the_traction_rate():
    """F_r = 0: only the ring's weight presses the inner contacts, and Coulomb friction (seed
    eq. 4, mu = 0.15) there is all that drives the ball set. After the seed's 5 ms spin-up the
    balls slide and their orbit accelerates at the balance of the traction rule,
    alpha_c = 2 mu sum Q_i / (Z r_p (m_b + I_b/R_b^2) + J_cage / r_p). The rule takes
    sum Q_i = m_ring g, the least the inner contacts carry (its rate, recovered from its time as
    pi omega_c / (2 share T), is a lower bound: 64 rad/s^2); at a slow orbit the balls' weights
    press on the inner race too, so the rate may reach (m_ring + Z m_b) g / (m_ring g) times it.
    Measured: 111 rad/s^2 over the first 50 ms, falling to 68 as the centrifugal force lifts the
    upper balls off the inner race (the ball set reaches rolling after 2.1 s)."""
    bearing = catalogue_bearing("6208")
    scene = Scene(bearing=bearing).with_overrides(
        radial_load_n=0.0, omega_rad_s=351.6, spin_up_time_s=5e-3, duration_s=0.05
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sig = simulate(scene).signals
    late = sig[sig.time_s > 0.015]
    measured = np.polyfit(late.time_s, late.cage_speed_rad_s, 1)[0]
    omega_c = bearing.cage_speed_rad_s(351.6)
    expected = math.pi * omega_c / (2 * TRACTION_SHARE * traction_spin_up_time_s(scene))
    assert late.cage_speed_rad_s.max() < 0.1 * omega_c  # sliding, far from rolling
    ratio = 1.0 + bearing.n_balls * bearing.ball_mass_kg / bearing.inner_ring_mass_kg
    assert expected <= measured <= ratio * expected


def test_the_automatic_spin_up_leaves_a_zero_load_ball_set_rolling():
    """With the traction rule the ball set follows the ring: the steady cage speed is the
    rolling one (R_inn / (R_inn + R_out) omega) within 1 %, where the seed's 5 ms leaves it at
    under a tenth of it (previous test)."""
    bearing = catalogue_bearing("6208")
    scene = Scene(bearing=bearing).with_overrides(radial_load_n=0.0, omega_rad_s=32.76)
    assert scene.procedure.spin_up_time_s > 0.1  # the traction rule, not the chain's 5 ms
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sig = simulate(scene.with_overrides(duration_s=scene.setup_time_s + 0.02)).signals
    steady = sig[sig.phase == "steady"]
    kinematic = bearing.cage_speed_rad_s(32.76)
    assert steady.cage_speed_rad_s.mean() == pytest.approx(kinematic, rel=0.01)


@pytest.mark.parametrize("designation", ["6208", "seed", "6308"])
@pytest.mark.parametrize("omega", [20.0, 50.0, 120.0])
def test_the_automatic_duration_is_long_enough_to_estimate(designation, omega):
    """At low speed the automatic duration is set by ball passes, not by the seed's 23 ms: its
    steady phase, as recorded (N instants 1/rate apart, N / rate of trace), must hold the ball
    passes ``signatelec estimate`` needs (measurement.band.MIN_BALL_PASSES) with a whole pass to
    spare, since the recorded grid falls a fraction of an instant short of the phase. The
    quasi-static tier records the DEM's steady instants (engines/quasistatic/tier.py)."""
    scene = Scene(bearing=catalogue_bearing(designation)).with_overrides(
        omega_rad_s=omega, fidelity="quasistatic"
    )
    signals = simulate(scene).signals
    rate_hz = scene.numerics.sample_rate_hz
    passes_hz = scene.bearing.ball_pass_frequency_hz(omega)
    passes = len(signals) / rate_hz * passes_hz
    # the phase's ends fall between recorded instants: up to two of them fewer
    assert passes >= MIN_BALL_PASSES + 1.0 - 2.0 * passes_hz / rate_hz
    trace = prepare_trace(
        signals["time_s"], signals["resistance_ohm"], omega, bearing=scene.bearing
    )
    assert trace.resistance_ohm.size == len(signals)


def test_a_trace_just_short_of_the_passes_needed_is_not_told_it_has_them():
    """A trace one sample short of MIN_BALL_PASSES (4.9996 passes of a 6208 at 50 rad/s, 20 kHz)
    is refused, and the refusal writes its length below the length needed, in passes and in ms
    (it had read '177 ms is 5 ball passes ... at least 5 (177 ms) are needed')."""
    bearing, omega, rate_hz = catalogue_bearing("6208"), 50.0, 20000.0
    passes_hz = bearing.ball_pass_frequency_hz(omega)
    n = math.ceil(MIN_BALL_PASSES / passes_hz * rate_hz) - 1
    t = np.arange(n) / rate_hz
    r = 3e-3 * (1.0 + 0.01 * np.sin(2.0 * math.pi * passes_hz * t))
    with pytest.raises(TraceError) as info:
        prepare_trace(t, r, omega, bearing=bearing)
    found = re.search(
        r"too short: ([\d.]+) ms is ([\d.]+) ball passes .*at least ([\d.]+) \(([\d.]+) ms\)",
        str(info.value),
    )
    assert found, str(info.value)
    have_ms, have, need, need_ms = map(float, found.groups())
    assert have < need == MIN_BALL_PASSES and have_ms < need_ms
    assert have == pytest.approx(n / rate_hz * passes_hz, rel=1e-3)


def test_a_speed_above_the_catalogues_limiting_speed_is_warned_with_its_likely_unit(tmp_path):
    """The 6208's limiting speed is 11 000 rpm = 1151.9 rad/s [SKF]. 4775 typed for its rpm
    (4775 rpm = 500.0 rad/s) runs at 4.15 x that as rad/s: one warning line, before the run,
    naming the value, the limit and the unit that would bring it within. At 1100 rad/s, within
    the limit, nothing is said, nor at 1152 rad/s, the limit as written rounded. (The
    quasi-static tier keeps the runs cheap.)"""
    limit = 11000.0 * 2.0 * math.pi / 60.0
    assert limiting_speed_rad_s(designation_of(catalogue_bearing("6208"))) == pytest.approx(limit)
    assert limiting_speed_rad_s(designation_of(Scene().bearing)) == pytest.approx(limit)  # seed's
    for omega, warned in (("4775", True), ("1100", False), ("1152", False)):
        res = CliRunner().invoke(
            cli,
            ["simulate", "--bearing", "6208", "--omega", omega, "--fidelity", "quasistatic"]
            + ["--quiet", "--out", str(tmp_path / omega)],
        )
        assert res.exit_code == 0, res.output
        lines = [line for line in res.output.splitlines() if "warning" in line]
        if not warned:
            assert not lines, res.output
            continue
        assert len(lines) == 1, res.output
        said = "--omega = 4775 rad/s is 4.15 x the SKF 6208's limiting speed, 1152 rad/s"
        assert said in lines[0]
        assert "rpm (4775 rpm = 500 rad/s)" in lines[0] and "Hz" not in lines[0]


@pytest.mark.parametrize(
    ("load_n", "clearance_m", "warned"), [(1000.0, 0.0, True), (5820.0, 0.0, False)]
)
def test_a_steady_phase_that_still_settles_is_warned(tmp_path, load_n, clearance_m, warned):
    """The automatic duration's steady phase starts when the spin-up ends. At 1000 N the ring
    and cage settle into it for ~10 ms, its level 3.4 % low at first: one warning line naming
    the part `estimate` would cut and how far off the steady mean resistance is, measured
    against the level a run 0.25 s long settles to (0.1-0.25 s after the set-up); at the
    seed's 5820 N nothing is said, and the steady mean lies within 0.1 % of that level (the
    fast preset)."""
    out = tmp_path / "run"
    args = ["simulate", "--fidelity", "fast", "--radial-load", str(load_n)]
    args += ["--clearance", str(clearance_m), "--quiet", "--out", str(out)]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    lines = [line for line in res.output.splitlines() if "warning" in line]
    signals = pd.read_parquet(out / "signals.parquet")
    short = signals.loc[signals["phase"] == "steady", "resistance_ohm"].mean()
    scene = apply_fidelity(
        Scene().with_overrides(radial_load_n=load_n, clearance_m=clearance_m), "fast"
    )
    scene = scene.with_overrides(duration_s=scene.setup_time_s + 0.25)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        long = simulate(scene).signals
    settled = long.loc[long["time_s"] > scene.setup_time_s + 0.1, "resistance_ohm"].mean()
    if not warned:
        assert not lines, res.output
        assert short / settled - 1 == pytest.approx(0.0, abs=1e-3)
        return
    assert len(lines) == 1 and "before the ring and cage have settled" in lines[0], res.output
    said = float(re.search(r"mean resistance ([-+\d.]+)% off", lines[0]).group(1))
    assert short / settled - 1 < -5e-3  # the case: the mean half a percent low or more
    assert said / 100 == pytest.approx(short / settled - 1, abs=3e-3)
