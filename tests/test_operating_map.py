"""The operating map: its grid (ISO 5753-1 clearances, geometric speeds) and the quick map."""

from __future__ import annotations

import warnings
from dataclasses import astuple
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from signatelec.cli import cli
from signatelec.config.catalogue import CATALOGUE, catalogue_bearing
from signatelec.config.scene import Scene
from signatelec.engines.simulate import simulate
from signatelec.physics.electrical import CurrentDensityWarning
from signatelec.studies.operating_map import (
    CAGES,
    ENERGY_RTOL,
    LOAD_FRACTIONS,
    LOAD_RTOL,
    QUICK_CELLS,
    RESISTANCE_RTOL,
    SETTLE_S,
    Cell,
    cell_scene,
    cells,
    limiting_speed_rad_s,
    minimum_load_fraction,
    normal_clearance_m,
    run_cell,
    run_map,
    speeds_rad_s,
)


def test_normal_clearance_is_the_middle_of_iso_5753_group_n():
    # ISO 5753-1:2009 table 1, group N: bore 10-18 mm 3-18 um, 24-30 mm 5-20 um, 30-40 mm 6-20 um
    assert normal_clearance_m("6203") == pytest.approx(10.5e-6)
    assert normal_clearance_m("6205") == pytest.approx(12.5e-6)
    assert normal_clearance_m("6208") == pytest.approx(13e-6)
    assert normal_clearance_m("seed") == normal_clearance_m("6208")  # the seed's bearing


def test_the_grid_spans_each_bearings_rated_speeds():
    # SKF: limiting speed of the 6205, 18 000 rpm
    assert limiting_speed_rad_s("6205") == pytest.approx(18000 * np.pi / 30)
    w = speeds_rad_s("6205")
    assert w[0] == 10.0 and w[-1] == pytest.approx(18000 * np.pi / 30) and len(w) >= 5
    np.testing.assert_allclose(w[1:] / w[:-1], w[1] / w[0], rtol=1e-12)  # geometric
    grid = cells()
    # at each speed: the minimum load, then 0.05, 0.2 and 0.5 C_r
    assert len(grid) == len(CATALOGUE) * len(w) * (1 + len(LOAD_FRACTIONS)) * 3 * len(CAGES)
    assert CAGES == ("balls", "rigid")
    assert LOAD_FRACTIONS == (0.05, 0.2, 0.5)
    lightest = {(c.designation, c.omega_rad_s): c.load_fraction for c in grid[::12]}
    for (designation, omega), fraction in lightest.items():
        assert fraction == minimum_load_fraction(designation, omega)
        assert 0.0 < fraction < LOAD_FRACTIONS[0]
    # ISO VG 68 at 40 C: nu = 68 mm^2/s; 6208 (d_m = 60 mm, C_r = 32.5 kN) at 10 rad/s
    # (95.5 r/min): 0.025 (68 x 95.49 / 1000)^(2/3) 0.6^2 kN = 31.3 N
    assert minimum_load_fraction("6208", 10.0) * 32.5e3 == pytest.approx(31.33, rel=1e-3)
    assert {c.load_fraction for c in cells(zero_load=True)} == {0.0}


def test_quick_map_runs_and_writes_its_outputs(tmp_path):
    out = tmp_path / "map"
    res = CliRunner().invoke(cli, ["study", "operating-map", "--quick", "--out", str(out)])
    assert res.exit_code == 0, res.output
    table = pd.read_parquet(out / "operating_map.parquet")
    # three cells for each cage model: the seed's cage balls and the rigid cage
    assert len(table) == 6 and set(table.cage) == {"balls", "rigid"}
    assert (out / "operating_map.png").stat().st_size > 0
    assert "# Operating map" in (out / "operating_map.md").read_text()
    assert (table.status != "diverged").all()
    # the energy balance closes (work in = dissipated + elastic + kinetic)
    assert (table.energy_error < 0.01).all()
    # every cell on the quasi-static tier: resistance within 1 %, largest ball load within 2 %
    assert (table.status == "ok").all(), table[["designation", "cage", "status"]]
    assert (table.resistance_error.abs() <= RESISTANCE_RTOL).all()
    assert (table.load_error.abs() <= LOAD_RTOL).all()
    bad = CliRunner().invoke(cli, ["study", "operating-map", "--cage", "x", "--out", str(out)])
    assert bad.exit_code == 2 and "--cage 'x': must be one of" in bad.output


@pytest.mark.parametrize(
    "cell",
    [
        Cell("6203", float(speeds_rad_s("6203")[2]), 0.2, "zero"),
        Cell("6205", float(speeds_rad_s("6205")[3]), 0.5, "normal"),
        Cell("6308", float(speeds_rad_s("6308")[-1]), 0.2, "zero"),
    ],
    ids=lambda c: f"{c.designation}-{c.omega_rad_s:.0f}rad_s-{c.load_fraction}Cr-{c.clearance}",
)
def test_loaded_catalogue_bearings_agree_with_the_quasistatic_tier(cell):
    # Under a radial load the steady DEM over 3 ball passes must match the quasi-static
    # equilibrium of evenly spaced balls (Hertz, seed eq. 8; clearance, seed eq. 14): mean
    # resistance within 1 %, mean largest ball load within 2 %. With the cage balls filling
    # 99.5 % of the gap, as the seed's do, it holds at light and heavy load, zero and normal
    # clearance, up to the limiting speed; with 10 % pocket play these cells were 1.1-6.8 % off.
    row = run_cell(cell)
    assert row["status"] == "ok", row
    assert abs(row["resistance_error"]) <= RESISTANCE_RTOL
    assert abs(row["load_error"]) <= LOAD_RTOL
    assert row["energy_error"] < 0.01


@pytest.mark.slow
def test_zero_load_with_the_cage_balls_agrees_with_the_quasistatic_tier():
    # F_r = 0: the ring's weight (0.69 N) and the balls' (9 x 0.083 N) are the whole load. Two
    # things must hold for the DEM to settle on the tier's state: the automatic spin-up lets the
    # ring's weight bring the balls to rolling (0.4 s here; after the seed's 5 ms the ball set
    # slides, and this cell was -11 % on resistance, +3.2 % on ball load), and the tier carries
    # the push of the cage-ball chain that holds the tangential part of the balls' weights
    # (0.08 N on the bottom ball; without it the steady DEM is 8 % below the tier at 10 rad/s).
    row = run_cell(Cell("6208", float(speeds_rad_s("6208")[1]), 0.0, "zero"))
    assert row["status"] == "ok", row
    assert abs(row["resistance_error"]) <= RESISTANCE_RTOL
    assert abs(row["load_error"]) <= LOAD_RTOL
    assert row["energy_error"] < 0.01


SHIPPED_MAP = Path(__file__).resolve().parents[1] / "docs/operating_map/operating_map.parquet"


def test_the_shipped_map_covers_every_cell_of_both_cage_models():
    table = pd.read_parquet(SHIPPED_MAP)
    assert len(table) == len(cells()) and set(table.cage) == {"balls", "rigid"}
    # the cells of today's grid (the minimum load of each speed included), not an older one
    columns = ["designation", "omega_rad_s", "load_fraction", "clearance", "cage"]
    shipped = set(table[columns].itertuples(index=False, name=None))
    assert shipped == {astuple(c) for c in cells()}


def test_every_cell_of_the_shipped_map_is_ok():
    """The acceptance of the operating map: every cell of docs/operating_map (every catalogue
    bearing, both cage models, 5 speeds up to the limiting speed, the minimum load to 0.5 C_r,
    preload, zero and normal clearance) completes with defaults, closes its energy balance and
    agrees with the quasi-static tier (resistance 1 %, largest ball load 2 %). A cell that is
    off, diverged or not run fails this test; it is not excused."""
    table = pd.read_parquet(SHIPPED_MAP)
    bad = table[table.status != "ok"]
    listing = bad.groupby(["cage", "load_fraction", "status"]).size().to_string()
    assert bad.empty, f"{len(bad)} of {len(table)} cells not ok:\n{listing}"


def test_cache_key_survives_a_section_added_with_defaults(monkeypatch):
    # A cell's cached result stays valid when the scene grows a section or field at its default
    # value (the physics of the cell is unchanged); any value the cell runs with changes the key.
    from signatelec.config.scene import Scene
    from signatelec.studies import operating_map

    cell = Cell("6205", 100.0, 0.2, "normal", "rigid")
    key = cell.key()
    to_dict = Scene.to_dict
    monkeypatch.setattr(Scene, "to_dict", lambda self: to_dict(self) | {"new": {"x_m": 1.0}})
    assert cell.key() == key
    monkeypatch.setattr(Scene, "to_dict", to_dict)
    cell_scene = operating_map.cell_scene
    monkeypatch.setattr(
        operating_map,
        "cell_scene",
        lambda c, p=3: cell_scene(c, p).with_overrides(temperature_c=60.0),
    )
    assert cell.key() != key


@pytest.mark.parametrize("cage", CAGES)
def test_below_the_minimum_load_the_ball_set_skids_and_at_it_rolls(cage):
    # Coulomb friction at the ball/raceway contacts (seed section 2.1) is what drives the ball
    # set. At F_r = 0 only the ring's weight (0.69 N for the 6208) presses the balls on the
    # inner race: the inner contacts slide (|f_i| = mu Q_i at every loaded one), the ball set
    # orbits far below its rolling speed and speeds up as the traction acts (measured: 3.2 rad/s
    # 25 ms after the seed's 5 ms spin-up against the rolling 138.6 rad/s; rolling after 2.1 s).
    # At the bearing's minimum load (SKF, 152 N at 351.6 rad/s) the ball set rolls: its cage
    # speed is within 1 % of the rolling kinematics (Harris 2001, eq. of the cage speed).
    b = catalogue_bearing("6208")
    omega = float(speeds_rad_s("6208")[3])  # 351.6 rad/s
    rolling = b.cage_speed_rad_s(omega)
    zero = Scene(bearing=b).with_overrides(
        omega_rad_s=omega,
        radial_load_n=0.0,
        clearance_m=0.0,
        spin_up_time_s=5e-3,
        duration_s=0.03,
        energy=True,
        cage=cage,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CurrentDensityWarning)  # tiny contacts: physics
        skid = simulate(zero)
    sig = skid.signals
    assert np.isfinite(sig.drop(columns="phase").to_numpy(dtype=float)).all()
    end = sig.iloc[-1]
    energy_error = abs(end.work_in_j - end.dissipated_j - end.elastic_j - end.kinetic_j)
    assert energy_error <= ENERGY_RTOL * end.work_in_j
    late = sig[sig.time_s > 0.01]
    assert (late.cage_speed_rad_s < 0.1 * rolling).all()
    speed = late.cage_speed_rad_s.to_numpy()
    assert speed[-1] > 1.5 * speed[0] > 0.0  # the traction accelerates it
    balls = skid.balls[skid.balls.time_s > 0.01]
    loaded = balls[balls.inner_force_n > 1e-3]
    sliding = loaded.inner_tangential_n.abs() / (b.friction_coefficient * loaded.inner_force_n)
    np.testing.assert_allclose(sliding, 1.0, rtol=1e-9)

    cell = Cell("6208", omega, minimum_load_fraction("6208", omega), "zero", cage)
    scene = cell_scene(cell)
    scene = scene.with_overrides(duration_s=scene.setup_time_s + SETTLE_S + 0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CurrentDensityWarning)
        roll = simulate(scene).steady(settle_s=SETTLE_S)
    assert roll.cage_speed_rad_s.mean() == pytest.approx(rolling, rel=0.01)


def test_a_cell_whose_tier_fails_is_recorded_not_raised(monkeypatch, tmp_path):
    # The map must finish and list a cell whose quasi-static equilibrium is not reached (status
    # and message), not stop at it.
    from signatelec.engines import simulate as engine

    real = engine.simulate

    def failing(scene, **kw):
        if scene.numerics.fidelity == "quasistatic":
            raise RuntimeError("ring equilibrium not reached at 1 of 1 instants")
        return real(scene, **kw)

    monkeypatch.setattr(engine, "simulate", failing)
    table = run_map([QUICK_CELLS[1]], tmp_path, ball_passes=2)
    assert table.status.tolist() == ["tier failed"]
    assert "ring equilibrium not reached" in table.message.iloc[0]
