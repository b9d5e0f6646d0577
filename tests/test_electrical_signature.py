"""Electrical signature of the bearing: the seed's section 4 against physics.

- The DEM's steady resistance equals the resistance of the quasi-static Hertz ball loads
  (Harris 2001, ch. 7, evaluated at the DEM's own ball angles) fed to the seed's electrical model
  (eqs 16-18): the electrical chain adds nothing of its own once the forces agree.
- As in the seed's figures 8 and 11, the resistance falls when F_r rises and when epsilon rises
  (clearance -> preload); the F_r dependence follows Hertz: each ball conducts as
  S_i S_o ~ Q^(2/3) Q^(2/3), so at fixed epsilon R ~ F_r^(-4/3).
- The electrical model is an effect: off, it is neither computed nor written.
- An instant at which no ball joins the rings has R = +inf, written as such, never NaN.
- ``signatelec figures`` writes the three PNGs of the seed's figures 6-11.
"""

from __future__ import annotations

import math

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import CR_N, make_scene

from signatelec.physics.electrical import bearing_electrics
from signatelec.physics.quasistatic import solve_equilibrium_over_time

#: Steady window: from this long after the set-up. With a clearance the DEM's resistance stays
#: ~1 % below its final value until ~10 ms after the spin-up (a slow transient of the loosely
#: held ring); 10 ms is past it for every case here, and runs of 0.03 s keep 13 ms of signal.
SETTLE_S = 10e-3
DURATION_S = 0.03  # the seed's scene
# The first recorded instants load the balls with grams, so 0.1 A crosses tiny contacts above
# the seed's 0.1 A/mm^2: expected there, and not what these tests are about.
pytestmark = pytest.mark.filterwarnings(
    "ignore::signatelec.physics.electrical.CurrentDensityWarning"
)
ELECTRICAL_COLUMNS = {
    "balls": ("current_a", "potential_v", "inner_area_m2", "outer_area_m2"),
    "signals": ("resistance_ohm", "max_current_density_a_m2"),
}


def steady(result, settle_s: float = SETTLE_S):
    """Steady signals and the (instants, balls) arrays of angle and ball positions."""
    z = result.scene.bearing.n_balls
    sig = result.steady(settle_s=settle_s)
    balls = result.steady("balls", settle_s=settle_s)
    angle = balls.angle_rad.to_numpy().reshape(-1, z)
    assert len(sig) == angle.shape[0] > 100
    return sig, angle


def quasistatic_resistance_ohm(scene, ball_angle_rad):
    """R of the quasi-static Hertz loads at the given ball angles (centrifugal and gravity on),
    theta = pi for every ball (seed section 3)."""
    qs = solve_equilibrium_over_time(
        ball_angle_rad,
        scene.bearing,
        scene.operating.radial_load_n,
        scene.operating.clearance_m,
        scene.operating.omega_rad_s,
        centrifugal=True,
        gravity=True,
    )
    el = bearing_electrics(
        qs.inner_force_n,
        qs.outer_force_n,
        scene.bearing,
        scene.operating.injected_current_a,
        density_limit_a_m2=math.inf,
    )
    return el.resistance_ohm, qs


def mean_resistance_ohm(result) -> float:
    sig, _ = steady(result)
    resistance = sig.resistance_ohm.to_numpy()
    assert np.all(np.isfinite(resistance))
    return float(resistance.mean())


# --- DEM against quasi-static theory ----------------------------------------------------------


@pytest.mark.validation
def test_seed_steady_resistance_matches_quasistatic_hertz_loads(run_scene):
    """Seed scene (F_r = 5820 N, no clearance, 500 rad/s): the DEM's resistance is required
    within 2 % of the theory's on the time average.

    Measured: DEM 3.1492 mOhm against 3.1503 mOhm (-0.035 %); every instant within 0.1 %; 0.035
    loaded balls apart on average.
    """
    scene = make_scene(duration_s=DURATION_S)
    result = run_scene(scene)
    sig, angle = steady(result)
    theory_ohm, qs = quasistatic_resistance_ohm(scene, angle)
    dem_ohm = sig.resistance_ohm.to_numpy()
    assert dem_ohm.mean() == pytest.approx(theory_ohm.mean(), rel=1.5e-3)
    # not only on average: instant by instant, as the ball set turns
    np.testing.assert_allclose(dem_ohm, theory_ohm, rtol=4e-3)
    # the two start from the same mechanical state (epsilon = 0.5 exactly at zero clearance,
    # seed eq. 15; half the balls loaded)
    assert sig.epsilon.mean() == pytest.approx(0.5, abs=1e-15)
    assert sig.loaded_balls.mean() == pytest.approx(qs.loaded_count.mean(), abs=0.15)


# --- figures 8 and 11: trends -----------------------------------------------------------------

LOAD_FRACTIONS = (0.1, 0.2, 0.4)
CLEARANCES_M = (20e-6, 0.0, -10e-6)  # clearance, none, preload: epsilon rises


@pytest.fixture(scope="module")
def load_set(run_scene):
    return [
        run_scene(make_scene(radial_load_n=f * CR_N, duration_s=DURATION_S)) for f in LOAD_FRACTIONS
    ]


@pytest.fixture(scope="module")
def epsilon_set(run_scene):
    return [run_scene(make_scene(clearance_m=c, duration_s=DURATION_S)) for c in CLEARANCES_M]


@pytest.mark.validation
def test_resistance_falls_as_radial_load_rises_as_hertz_says(load_set):
    """Seed fig. 8: R falls with F_r, non-linearly. At epsilon = 0.5 the ball loads scale with
    F_r, each ball's conductance (eq. 16) with S_i S_o ~ Q^(4/3), so R ~ F_r^(-4/3); the
    centrifugal force (~10 N per ball) is what keeps it from exact.

    Measured: 7.896, 3.149, 1.252 mOhm at 0.1, 0.2, 0.4 C_r; exponent -1.328 (0.38 % from -4/3).
    """
    mean_ohm = np.array([mean_resistance_ohm(r) for r in load_set])
    assert np.all(np.diff(mean_ohm) < 0.0)
    loads = np.array(LOAD_FRACTIONS) * CR_N
    exponent = np.polyfit(np.log(loads), np.log(mean_ohm), 1)[0]
    assert exponent == pytest.approx(-4.0 / 3.0, rel=0.015)


@pytest.mark.validation
def test_resistance_falls_as_epsilon_rises(epsilon_set):
    """Seed fig. 11: at F_r = 5820 N, clearance -> none -> preload raises epsilon (eq. 15) and
    lowers R (a preload squeezes more balls). Each mean also matches the quasi-static theory.

    Measured: epsilon 0.384, 0.500, 0.600 give 3.206, 3.149, 3.060 mOhm (theory within 0.047 %;
    required: 2 %).
    """
    eps = np.array([steady(r)[0].epsilon.mean() for r in epsilon_set])
    assert np.all(np.diff(eps) > 0.0)
    mean_ohm = np.array([mean_resistance_ohm(r) for r in epsilon_set])
    assert np.all(np.diff(mean_ohm) < 0.0)
    for result, dem_ohm in zip(epsilon_set, mean_ohm, strict=True):
        theory_ohm, _ = quasistatic_resistance_ohm(result.scene, steady(result)[1])
        assert dem_ohm == pytest.approx(theory_ohm.mean(), rel=2e-3)


# --- electrical is an effect ------------------------------------------------------------------


def _short_scene(**kwargs):
    return make_scene(duration_s=0.008, **kwargs)  # the set-up (7 ms) and 1 ms of running


def test_electrical_off_is_neither_computed_nor_written(monkeypatch, tmp_path):
    import signatelec.physics.electrical
    from signatelec.engines.simulate import simulate

    def refuse(*args, **kwargs):
        raise AssertionError("bearing_electrics called with the electrical effect off")

    monkeypatch.setattr(signatelec.physics.electrical, "bearing_electrics", refuse)
    result = simulate(_short_scene(outputs={"electrical": False}))  # not cached: the patch acts
    result.write(tmp_path / "run")
    for table, columns in ELECTRICAL_COLUMNS.items():
        in_memory = set(getattr(result, table).columns)
        on_disk = set(pq.read_schema(tmp_path / "run" / f"{table}.parquet").names)
        assert in_memory == on_disk
        assert not in_memory & set(columns)
    assert "electrical_s" not in result.timings
    # the patch is where simulate looks: with the effect on, it is called
    with pytest.raises(AssertionError, match="bearing_electrics called"):
        simulate(_short_scene())


def test_electrical_on_writes_every_column(run_scene):
    result = run_scene(_short_scene())
    for table, columns in ELECTRICAL_COLUMNS.items():
        assert set(columns) <= set(getattr(result, table).columns)


# --- unloaded instants ------------------------------------------------------------------------


def test_unloaded_instants_have_infinite_resistance_written_explicitly(run_scene, tmp_path):
    """F_r = 0 with 20 um of clearance: while the outer race opens and the inner ring falls under
    its weight, no ball touches both rings at some instants; R is then +inf (no path), never NaN,
    no current flows, and Parquet keeps the inf."""
    from signatelec.cli import main

    scene = _short_scene(radial_load_n=0.0, clearance_m=20e-6, procedure={"spin_up_time_s": 5e-3})
    result = run_scene(scene)
    resistance = result.signals.resistance_ohm.to_numpy()
    assert not np.isnan(resistance).any()
    unloaded = np.isinf(resistance)
    assert unloaded.any()
    assert np.all(resistance[unloaded] > 0.0)
    assert (result.signals.phase[unloaded] == "clearance").any()  # the very first instants
    z = scene.bearing.n_balls
    current = result.balls.current_a.to_numpy().reshape(-1, z)
    assert np.all(current[unloaded] == 0.0)
    inner = result.balls.inner_area_m2.to_numpy().reshape(-1, z)
    outer = result.balls.outer_area_m2.to_numpy().reshape(-1, z)
    assert not np.any((inner[unloaded] > 0.0) & (outer[unloaded] > 0.0))  # no bridging ball

    out = tmp_path / "unloaded"
    spin_up = tmp_path / "spin_up.toml"
    spin_up.write_text("[procedure]\nspin_up_time_s = 5e-3\n")
    main(["simulate", "--scene", str(spin_up), "--radial-load", "0", "--clearance", "20e-6",
          "--duration", "0.008", "--quiet", "--out", str(out)])  # fmt: skip
    written = pq.read_table(out / "signals.parquet").column("resistance_ohm").to_numpy()
    assert not np.isnan(written).any()
    np.testing.assert_array_equal(np.isposinf(written), unloaded)
    np.testing.assert_array_equal(written, resistance)


# --- figures 7 and 10: the followed ball -------------------------------------------------------


def test_followed_ball_round_is_symmetric_and_keeps_outer_contact(run_scene):
    """Seed fig. 7: over a rolling round the followed ball's outer force is symmetric about the
    load axis, peaks at psi = 0, and never drops to zero: outside the load zone the centrifugal
    force m_b omega_c^2 r_p (plus the radial part of the weight) keeps it on the outer race."""
    from signatelec.studies.paper_figures import paper_cases, rolling_round

    scene = paper_cases().figure_6  # the seed's scene, run for one whole round
    result = run_scene(scene)
    rr = rolling_round(result)
    assert rr.complete
    b = scene.bearing
    omega_c = result.steady().cage_speed_rad_s.mean()
    psi = rr.angle_rad
    # a whole round, to the angle a ball turns between two records (measured 0.009 rad short)
    assert psi.max() - psi.min() == pytest.approx(2.0 * math.pi, abs=0.04)

    # The peak at psi = 0 within the angle the ball turns between two records (measured 0.03
    # deg off; a record is 0.57 deg); mirror symmetry to 0.19 % of the peak (measured).
    peak = rr.outer_force_n.max()
    record_step_rad = omega_c / scene.numerics.sample_rate_hz
    assert abs(psi[np.argmax(rr.outer_force_n)]) < record_step_rad
    mirrored = np.interp(-psi, psi, rr.outer_force_n)
    assert np.max(np.abs(mirrored - rr.outer_force_n)) < 8e-3 * peak

    idle = np.abs(psi) > math.radians(110.0)  # beyond the load zone (psi_l = 90 deg)
    expected = b.ball_mass_kg * (omega_c**2 * b.pitch_radius_m + 9.80665 * np.cos(psi[idle]))
    assert np.all(rr.outer_force_n > 0.0)
    # on average over the idle arc; instant by instant the DEM ball rattles about it (measured:
    # the mean 5.4 % above, no instant below 0.997 of it)
    assert rr.outer_force_n[idle].mean() == pytest.approx(expected.mean(), rel=0.1)
    assert np.all(rr.outer_force_n[idle] > 0.99 * expected)
    assert np.all(rr.inner_force_n[idle] == 0.0)


@pytest.mark.validation
def test_figure_9_clearance_gives_epsilon_0_3_in_the_dem(run_scene):
    """The clearance of figure 9 comes from the quasi-static theory; the DEM confirms it."""
    from signatelec.physics.quasistatic import clearance_for_epsilon
    from signatelec.studies.paper_figures import EPSILON_SET_LOAD_N

    scene = make_scene(duration_s=0.02)
    clearance = clearance_for_epsilon(
        scene.bearing, EPSILON_SET_LOAD_N, scene.operating.omega_rad_s, 0.3
    )
    assert 30e-6 < clearance < 60e-6
    result = run_scene(make_scene(clearance_m=clearance, duration_s=0.02))
    # measured 1.9e-4 from 0.3
    assert steady(result, 5e-3)[0].epsilon.mean() == pytest.approx(0.3, abs=8e-4)


# --- the command --------------------------------------------------------------------------------


@pytest.mark.slow  # seven short DEM runs and three figures: 2-9 s
def test_figures_command_writes_the_three_pngs(tmp_path):
    from signatelec.cli import main
    from signatelec.io import MARKER_FILE
    from signatelec.studies.paper_figures import FIGURE_FILES

    out = tmp_path / "docs" / "figures"
    main(["figures", "--quick", "--quiet", "--out", str(out)])
    # the figures and the output marker, no temporary left
    assert sorted(p.name for p in out.iterdir()) == sorted([*FIGURE_FILES, MARKER_FILE])
    assert sorted(p.name for p in out.parent.iterdir()) == ["figures"]
    for name in FIGURE_FILES:
        data = (out / name).read_bytes()
        assert data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 10_000


def test_figures_command_refuses_an_output_that_is_a_file(tmp_path, capsys):
    from signatelec.cli import EXIT_INPUT, main

    target = tmp_path / "a_file"
    target.write_text("keep me")
    with pytest.raises(SystemExit) as exc:
        main(["figures", "--quick", "--out", str(target)])
    assert exc.value.code == EXIT_INPUT
    err = capsys.readouterr().err
    assert err.startswith("signatelec: error: --out") and str(target) in err  # one line, names it
    assert target.read_text() == "keep me"
