"""Runs streamed to Parquet block by block, and the quasi-static tier mapped onto one period.

A streamed run must give the tables of the in-memory run, value for value, with the schema and
metadata :func:`signatelec.io.write_result` writes; a run stopped midway must leave nothing that
reads as complete. The quasi-static tier's period map must give the per-instant solution to
1e-6 of each column's largest value (measured: 6e-8 on the seed's scene, the horizontal ring shift
being the worst column, against a scatter of 4e-8 of the per-instant solution itself).
"""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_run import run_main

from signatelec import io
from signatelec.config.scene import Scene
from signatelec.engines import stream as stream_module
from signatelec.engines.budget import run_budget
from signatelec.engines.dem import run as dem_run
from signatelec.engines.quasistatic import buffers, period, tier
from signatelec.engines.simulate import simulate
from signatelec.physics.electrical import CurrentDensityWarning

#: Blocks of a prime number of instants: the last block is a partial one.
BLOCK = 37


def short(scene: Scene, steady_s: float = 0.004) -> Scene:
    return scene.with_overrides(duration_s=scene.setup_time_s + steady_s)


def read(out, name: str) -> pd.DataFrame:
    return pd.read_parquet(out / f"{name}.parquet")


@pytest.mark.parametrize("changes", [{}, {"electrical": False}], ids=["seed", "no-electrical"])
def test_a_streamed_dem_run_equals_the_in_memory_one(tmp_path, monkeypatch, changes):
    monkeypatch.setattr(dem_run, "STREAM_BLOCK_INSTANTS", BLOCK)
    scene = short(Scene().with_overrides(**changes))
    memory = simulate(scene)
    streamed = simulate(scene, out_dir=tmp_path / "run")
    assert streamed.balls is None and streamed.signals is None
    n = len(memory.signals)
    assert n > 5 * BLOCK and n % BLOCK
    written = tmp_path / "written"
    memory.write(written)  # the in-memory path's files
    for name in ("balls", "signals"):
        pd.testing.assert_frame_equal(read(tmp_path / "run", name), getattr(memory, name))
        assert pq.ParquetFile(tmp_path / "run" / f"{name}.parquet").num_row_groups == -(-n // BLOCK)
        a = pq.read_schema(tmp_path / "run" / f"{name}.parquet")
        b = pq.read_schema(written / f"{name}.parquet")
        assert a.remove_metadata() == b.remove_metadata()
        assert a.metadata[b"pandas"] == b.metadata[b"pandas"]
    meta = io.read_metadata(tmp_path / "run" / "signals.parquet")
    assert meta["scene"] == scene.to_dict() and meta["version"] == io.__version__
    assert set(meta["timings"]) == set(memory.timings)
    assert io.read_marker(tmp_path / "run")["command"] == "simulate"
    # the summary's steady means, gathered block by block
    means = memory.steady_means()
    for column, value in streamed.steady_means().items():
        assert value == pytest.approx(means[column], rel=1e-12, nan_ok=True), column


def test_the_command_line_streams_at_the_sample_rate_asked(tmp_path):
    out = tmp_path / "run"
    duration = Scene().setup_time_s + 0.002
    args = ["simulate", "--duration", str(duration), "--sample-rate", "10000", "--quiet"]
    assert run_main([*args, "--out", str(out)]) == 0
    time_s = read(out, "signals").time_s.to_numpy()
    # one instant every 1e-4 s (every 1000 steps of 1e-7 s), the last at the duration
    np.testing.assert_allclose(np.diff(time_s), 1e-4, rtol=1e-9)
    assert time_s[-1] == pytest.approx(duration, abs=1e-12)


def test_a_run_stopped_midway_leaves_no_output_and_no_temporary(tmp_path, monkeypatch):
    monkeypatch.setattr(dem_run, "STREAM_BLOCK_INSTANTS", BLOCK)
    write = stream_module.TableStream.write
    calls = []

    def interrupted(self, balls, signals):
        calls.append(len(signals))
        if len(calls) == 3:
            raise KeyboardInterrupt
        write(self, balls, signals)

    monkeypatch.setattr(stream_module.TableStream, "write", interrupted)
    with pytest.raises(KeyboardInterrupt):
        simulate(short(Scene()), out_dir=tmp_path / "run")
    assert calls == [BLOCK] * 3
    assert list(tmp_path.iterdir()) == []


def test_an_unfinished_table_does_not_read_as_complete(tmp_path):
    scene = short(Scene().with_overrides(fidelity="quasistatic"), steady_s=0.001)
    result = simulate(scene)
    stream = stream_module.TableStream(tmp_path, scene)
    stream.write(result.balls, result.signals)
    for name in ("balls", "signals"):  # a killed run: no footer
        with pytest.raises(pa.ArrowInvalid, match="footer"):
            pq.read_table(tmp_path / f"{name}.parquet")
    stream.finish(result.timings)
    pd.testing.assert_frame_equal(read(tmp_path, "signals"), result.signals)


def test_a_streamed_run_holds_one_block_whatever_its_duration():
    seed = Scene().with_overrides(sample_rate_hz=100_000.0)
    held = [run_budget(seed.with_overrides(duration_s=d), streamed=True) for d in (1.0, 100.0)]
    assert held[0].memory_bytes == held[1].memory_bytes
    assert held[1].n_instants == pytest.approx(100 * held[0].n_instants, rel=1e-3)
    assert (
        run_budget(seed.with_overrides(duration_s=100.0)).memory_bytes > 1e3 * held[1].memory_bytes
    )


# --- the quasi-static tier over one ball-pass period ---------------------------------------------

#: Each column's largest error relative to its largest magnitude (requirement: 1e-6; measured
#: over these scenes: 4e-8 to 2.4e-7).
MAP_RTOL = 1e-6


@pytest.mark.parametrize(
    "changes",
    [
        {},
        {"clearance_m": 40e-6, "contact_law": "linear"},
        {"clearance_m": -10e-6, "gravity": "none", "energy": True},
        {"radial_load_n": 100.0, "clearance_m": 40e-6, "omega_rad_s": 2000.0},
    ],
    ids=["seed", "clearance-linear", "preload-energy", "light-fast"],
)
def test_the_period_map_gives_the_per_instant_solution(changes):
    scene = Scene().with_overrides(fidelity="quasistatic", **changes)
    rate = scene.numerics.sample_rate_hz
    scene = scene.with_overrides(duration_s=scene.setup_time_s + 1.2 * period.MIN_INSTANTS / rate)
    t = tier.steady_record_times_s(scene)
    assert period.use_period_map(scene, t.size)
    with warnings.catch_warnings():  # the light, fast scene's densities are above the seed's
        warnings.simplefilter("ignore", CurrentDensityWarning)
        mapped = tier.simulate_quasistatic(scene)
    assert mapped.timings["period_map"]["nodes"] == period.PERIOD_NODES
    balls, signals, _ = tier.instant_columns(scene, t, tier.kinematic_ball_angles_rad(scene, t))
    for got, want in ((mapped.balls, balls), (mapped.signals, signals)):
        assert list(got.columns) == list(want)
        for name, values in want.items():
            if name == "phase":
                assert (got[name] == values).all()
                continue
            g, w = got[name].to_numpy(float), np.asarray(values, float)
            np.testing.assert_array_equal(np.isfinite(g), np.isfinite(w), err_msg=name)
            finite = np.isfinite(w)
            np.testing.assert_array_equal(g[~finite], w[~finite], err_msg=name)
            scale = np.abs(w[finite]).max(initial=0.0)
            assert np.abs(g[finite] - w[finite]).max(initial=0.0) <= MAP_RTOL * scale, name


def test_a_short_or_streamed_tier_run(tmp_path, monkeypatch):
    """Below MIN_INSTANTS the tier solves instant by instant; streamed, its blocks are the
    in-memory tables'."""
    scene = short(Scene().with_overrides(fidelity="quasistatic"), steady_s=0.01)
    assert not period.use_period_map(scene, tier.steady_record_times_s(scene).size)
    monkeypatch.setattr(stream_module, "STREAM_BLOCK_INSTANTS", BLOCK)
    memory = simulate(scene)
    assert "period_map" not in memory.timings
    simulate(scene, out_dir=tmp_path / "run")
    for name in ("balls", "signals"):
        got, want = read(tmp_path / "run", name), getattr(memory, name)
        # instant by instant: each block restarts the solver (residual 1e-10 of the load)
        pd.testing.assert_frame_equal(got, want, check_exact=False, rtol=1e-8, atol=1e-14)


def test_a_mapped_table_reuses_only_the_memory_of_tables_that_are_gone(monkeypatch):
    """The ball table's memory comes back for the next table of its size once every array on it
    is freed, never while one lives; a table written over reused memory is the fresh one."""
    monkeypatch.setattr(buffers, "REUSE_BYTES", buffers.REUSE_BYTES)
    scene = Scene().with_overrides(fidelity="quasistatic")
    rate = scene.numerics.sample_rate_hz
    scene = scene.with_overrides(duration_s=scene.setup_time_s + 1.05 * period.MIN_INSTANTS / rate)
    # the first map of a process compiles its kernel on a table of one instant, which goes
    # back to the pool: compiled before the pool is emptied
    simulate(scene)
    buffers.release()
    first = simulate(scene)
    fresh = first.balls.copy(deep=True)
    assert buffers.kept_bytes() == 0
    column = first.balls["current_a"].to_numpy()  # outlives its table
    del first
    assert buffers.kept_bytes() == 0
    second = simulate(scene)
    assert not np.shares_memory(column, second.balls["x_m"].to_numpy())
    del column
    size = buffers.kept_bytes()
    # per ball row: time, angle and the 8 interpolated columns in double, the ball in int32 (the
    # constant columns, speeds and tangential forces, are one value each); per instant: the
    # ring's shift (x, y, |s|), the resistance, the largest load and density, the grid node in
    # 8 bytes, the loaded balls in 4, the phase in 1
    n_instants = len(fresh) // scene.bearing.n_balls
    least = len(fresh) * (10 * 8 + 4) + n_instants * (7 * 8 + 4 + 1)
    assert least <= size < least + 10 * 64
    third = simulate(scene)  # over the first table's memory
    assert buffers.kept_bytes() == 0
    pd.testing.assert_frame_equal(third.balls, fresh, check_exact=True)
    pd.testing.assert_frame_equal(second.balls, fresh, check_exact=True)
    del second, third
    assert buffers.kept_bytes() == 2 * size
    monkeypatch.setattr(buffers, "REUSE_BYTES", size)  # the oldest beyond the bound is freed
    buffers._give_back(np.empty(size, np.uint8))
    assert buffers.kept_bytes() == size
    assert buffers.release() == size and buffers.kept_bytes() == 0


# --- start-up -------------------------------------------------------------------------------------

#: Libraries the seed's ``simulate`` does not use: imported, they cost the start-up ~0.3 s of CPU
#: (scipy's integrate, optimize, special and sparse, most of it) on a run of ~0.15 s.
UNUSED_BY_SIMULATE = (
    "sklearn",
    "matplotlib",
    "scipy.integrate",
    "scipy.optimize",
    "scipy.special",
    "scipy.sparse",
)


def test_simulate_imports_only_what_it_needs(tmp_path):
    out = tmp_path / "run"
    code = f"""
import sys
from signatelec.cli import main
main(["simulate", "--duration", "{Scene().setup_time_s + 0.001}", "--quiet", "--out", r"{out}"])
print(",".join(m for m in {UNUSED_BY_SIMULATE!r} if m in sys.modules))
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == ""
    meta = io.read_metadata(out / "signals.parquet")
    assert meta["timings"]["process_to_first_step_s"] > 0.0
