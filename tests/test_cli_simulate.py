"""`signatelec simulate` and `signatelec bench` from the command line."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from signatelec.cli import main
from signatelec.config.scene import Scene
from signatelec.io import read_metadata
from signatelec.physics.stability import stability_limit


def run_cli(argv):
    with pytest.raises(SystemExit) as exc:
        main(argv)
        raise SystemExit(0)
    return exc.value.code


def test_simulate_writes_documented_parquet(tmp_path):
    out = tmp_path / "run"
    code = run_cli(
        ["simulate", "--duration", "0.01", "--radial-load", "2910", "--quiet", "--out", str(out)]
    )
    assert code == 0
    balls = pd.read_parquet(out / "balls.parquet")
    signals = pd.read_parquet(out / "signals.parquet")
    for col in (
        "time_s",
        "ball",
        "angle_rad",
        "inner_force_n",
        "outer_force_n",
        "current_a",
        "potential_v",
        "inner_area_m2",
        "outer_area_m2",
    ):
        assert col in balls
    for col in ("time_s", "inner_x_m", "inner_y_m", "resistance_ohm"):
        assert col in signals
    meta = read_metadata(out / "signals.parquet")
    assert meta["scene"]["operating"]["radial_load_n"] == 2910.0
    assert Scene.from_dict(meta["scene"]).operating.radial_load_n == 2910.0
    # sampled at the scene's rate: 20 kHz over 0.01 s
    assert len(signals) == 200
    assert balls.ball.nunique() == 13
    # the load direction is -y: at steady state the most loaded ball sits near angle 0
    steady = balls[balls.time_s > 0.008]
    top = steady.loc[steady.groupby("time_s").inner_force_n.idxmax()]
    assert top.angle_rad.abs().max() < 0.25


def test_dt_above_stability_limit_is_refused_with_the_limit(tmp_path, capsys):
    limit = stability_limit(Scene()).dt_limit_s
    out = tmp_path / "run"
    code = run_cli(["simulate", "--dt", str(2 * limit), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1
    assert "numerics.dt_s" in err[0] and f"{limit:.3g}" in err[0]
    assert not out.exists()


@pytest.mark.slow
def test_bench_writes_json_with_compile_apart(tmp_path):
    # the seed's kernel serves both cases: one compile (or a load from the warm cache)
    out = tmp_path / "bench.json"
    out.write_text("{}")  # an earlier report is replaced
    argv = ["bench", "--duration", "0.0075", "--warm-cache", "--out", str(out)]
    code = run_cli([*argv, "--case", "seed", "--case", "electrical=false", "--batch-sizes", "4"])
    assert code == 0
    report = json.loads(out.read_text())
    # the ensemble kernel's cost per scene-step, against the single-scene kernel's
    (batch,) = report["batch"]
    assert batch["batch_size"] == batch["lanes"] == 4
    assert batch["cpu_us_per_scene_step"] > 0 and batch["single_cpu_us_per_step"] > 0
    rows = {r["case"]: r for r in report["rows"]}
    assert set(rows) == {"seed", "electrical=false"}
    seed = rows["seed"]
    assert seed["us_per_step"] > 0 and seed["compile_s"] >= 0
    assert seed["electrical_us_per_instant"] > 0
    assert rows["electrical=false"]["electrical_us_per_instant"] is None
    assert rows["electrical=false"]["kernel"] == seed["kernel"]


def test_bench_cases_cover_every_kernel_option():
    """Each value of an option the kernel is compiled per has a case of its own."""
    from signatelec.config.options import OPTIONS
    from signatelec.studies.bench import CASES

    for option in OPTIONS:
        if option.kernel:
            for value in option.values:
                assert value == option.default or {option.name: value} in CASES.values()
    assert CASES["seed"] == {}


def test_bench_refuses_an_unknown_case(tmp_path, capsys):
    code = run_cli(["bench", "--case", "warp", "--out", str(tmp_path / "b.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--case 'warp'" in err[0] and "seed" in err[0]
    assert not (tmp_path / "b.json").exists()


def test_bench_refuses_bad_batch_sizes(tmp_path, capsys):
    code = run_cli(["bench", "--batch-sizes", "8,zero", "--out", str(tmp_path / "b.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--batch-sizes '8,zero'" in err[0]
    assert not (tmp_path / "b.json").exists()


def test_bench_refuses_a_directory_before_running(tmp_path, capsys):
    code = run_cli(["bench", "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--out" in err[0]


@pytest.mark.slow
def test_bench_start_up_and_tiers(tmp_path, monkeypatch):
    """The start-up and tier rows of the bench: whole-process figures of a warm `simulate`, and
    the tier's marginal cost far below the DEM's (medians measured 1250-1411x on a shared
    2-core host; 100x is the floor the tier had to clear before it mapped instants onto one
    period)."""
    from signatelec.studies import bench

    startup = bench.startup_cost(repeat=1, out_dir=str(tmp_path))
    assert startup["repeat"] == 1
    assert 0.0 < startup["median_first_step_s"] < startup["median_wall_s"]
    assert startup["median_cpu_s"] > 0.0
    tiers = bench.tier_marginal_cost(repeat=3)  # the best of 3 pairs: a loaded host spikes
    assert tiers["dem_cpu_s_per_simulated_s"] > 0.0
    assert tiers["ratio"] > 100.0
