"""Outputs as a contract and limits before work (processes: tests/test_processes.py).

Every command runs as a user runs it (a subprocess; in-process only where a failure is injected)
and must end with the documented exit code (0 complete, 2 refused and nothing written, 3
diverged, 75 incomplete: rerun to resume, 130 Ctrl-C, 143 SIGTERM), at most one line on stderr
and never a traceback, and leave either the new output, the old one untouched, or nothing.
Scenes are tiny (the quasi-static tier where the DEM is not the point).
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest
from cli_run import (
    QUICK,
    assert_one_line,
    cli,
    dead_pid,
    run_main,
    snapshot,
    stale_name,
    write_spec,
)

from signatelec import io
from signatelec.cli import EXIT_CODES
from signatelec.config.scene import Scene, SceneError
from signatelec.data import read_dataset
from signatelec.engines.budget import (
    MAX_STEPS,
    available_memory_bytes,
    check_run,
    instant_bytes,
)

REPO = Path(__file__).resolve().parents[1]


#: Four quasi-static traces: milliseconds each.
SMALL_SPEC = """
[dataset]
seed = 7
fidelity = "quasistatic"
duration_s = 0.01
[[design]]
kind = "grid"
factors.radial_load_fraction = {values = [0.1, 0.2]}
factors.clearance_m = {values = [-5e-6, 10e-6]}
"""


# --- outputs as a contract ------------------------------------------------------------------


def test_simulate_refuses_a_dataset_directory_and_leaves_it_as_it_was(tmp_path):
    spec = write_spec(tmp_path, SMALL_SPEC)
    ds = tmp_path / "ds"
    assert cli("generate", str(spec), "--out", str(ds), "--workers", "0", "--quiet").returncode == 0
    before = snapshot(ds)
    proc = cli(*QUICK, "--out", str(ds))
    assert_one_line(proc, 2, f"--out {str(ds)!r}", "holds the output of signatelec generate")
    assert snapshot(ds) == before
    assert len(read_dataset(ds)) == 4  # four traces, not ball rows


@pytest.mark.parametrize("command", ["simulate", "generate", "figures", "study"])
def test_a_foreign_non_empty_directory_is_refused_untouched(tmp_path, command):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("my notes")
    (out / "signals.parquet").mkdir()  # a name a command writes, here the user's directory
    before = snapshot(out)
    args = {
        "simulate": QUICK,
        "generate": ("generate", str(write_spec(tmp_path, SMALL_SPEC)), "--workers", "0"),
        "figures": ("figures", "--quick", "--quiet"),
        "study": ("study", "accuracy-cost", "--quick", "--quiet"),
    }[command]
    proc = cli(*args, "--out", str(out))
    assert_one_line(proc, 2, f"--out {str(out)!r}", "is not empty", "notes.txt")
    assert snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name != "spec.toml") == ["mine"]


def test_simulate_replaces_its_previous_output_as_a_whole(tmp_path):
    out = tmp_path / "run"
    assert cli(*QUICK, "--radial-load", "2910", "--out", str(out)).returncode == 0
    first = snapshot(out)
    assert json.loads((out / io.MARKER_FILE).read_text())["command"] == "simulate"
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o777 & ~umask  # a directory as any other, not 0700
    (out / "signals.parquet").unlink()
    (out / "signals.parquet").mkdir()  # damage inside a previous output: replaced with it
    assert cli(*QUICK, "--radial-load", "5820", "--out", str(out)).returncode == 0
    second = snapshot(out)
    assert set(second) == set(first) == {io.MARKER_FILE, *io.SIMULATE_FILES}
    assert second["balls.parquet"] != first["balls.parquet"]
    meta = io.read_metadata(out / "signals.parquet")
    assert meta["scene"]["operating"]["radial_load_n"] == 5820.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no temporary, no old copy
    # an output of a version before the marker (the two tables only) is recognised too
    (out / io.MARKER_FILE).unlink()
    assert cli(*QUICK, "--out", str(out)).returncode == 0


def test_figures_replace_figures_of_an_older_version(tmp_path):
    out = tmp_path / "figures"
    shutil.copytree(REPO / "docs" / "figures", out)  # the PNGs only, no marker
    proc = cli("figures", "--quick", "--quiet", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == [
        io.MARKER_FILE,
        "figure_6_9.png",
        "figure_7_10.png",
        "figure_8_11.png",
    ]
    assert io.read_marker(out)["command"] == "figures"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figures"]


def test_a_failed_write_keeps_the_previous_output(tmp_path, monkeypatch, capsys):
    import pyarrow.parquet as pq

    out = tmp_path / "run"
    assert run_main([*QUICK, "--out", str(out)]) == 0
    before = snapshot(out)

    class DiskFullAtSignals(pq.ParquetWriter):
        """The tables are written as the run goes: the disk fills at the first signals block."""

        def write_table(self, table, *args, **kwargs):
            if str(self.where).endswith("signals.parquet"):
                Path(self.where).write_bytes(b"PAR1 half")
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.where))
            return super().write_table(table, *args, **kwargs)

    monkeypatch.setattr(pq, "ParquetWriter", DiskFullAtSignals)
    capsys.readouterr()
    code = run_main([*QUICK, "--radial-load", "2910", "--out", str(out)])
    err = capsys.readouterr().err.splitlines()
    assert code == 75 and len(err) == 1, err
    assert "No space left on device" in err[0] and "nothing was written" in err[0]
    assert snapshot(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    # a new output under new directories: those are removed with the temporary
    code = run_main([*QUICK, "--out", str(tmp_path / "new" / "deeper" / "run")])
    assert code == 75 and sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_the_current_directory_is_not_replaced(tmp_path):
    (tmp_path / "inside").mkdir()
    for out in (".", str(tmp_path), ".."):
        proc = cli(*QUICK, "--out", out, cwd=tmp_path / "inside")
        assert_one_line(proc, 2, f"--out {out!r}", "is the current directory or holds it")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["inside"]


def test_the_exchange_without_renameat2_gives_the_same_result(tmp_path, monkeypatch):
    out = tmp_path / "out"
    out.mkdir()
    (out / io.MARKER_FILE).write_text('{"command": "test"}')
    (out / "old.txt").write_text("old")
    monkeypatch.setattr(io, "_exchange", lambda a, b: False)
    with io.replace_directory(out, "test") as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [io.MARKER_FILE, "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize("atomic", [True, False])
def test_ctrl_c_during_the_exchange_completes_it(tmp_path, monkeypatch, atomic):
    """A Ctrl-C that lands while the new output takes the old one's place (with or without an
    atomic exchange) neither leaves both halves nor reports "nothing written" for an output
    that is in place: the exchange and the old output's removal finish, no interrupt."""
    import signal

    out = tmp_path / "out"
    out.mkdir()
    (out / io.MARKER_FILE).write_text('{"command": "test"}')
    (out / "old.txt").write_text("old")
    exchange = io._exchange

    def interrupted(a, b):
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.01)  # the signal is delivered before the exchange goes on
        return exchange(a, b) if atomic else False

    monkeypatch.setattr(io, "_exchange", interrupted)
    with io.replace_directory(out, "test") as tmp:
        (tmp / "new.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [io.MARKER_FILE, "new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_a_killed_runs_temporaries_are_removed_and_no_other_file(tmp_path):
    stale = tmp_path / stale_name(dead_pid())
    stale.mkdir()
    (stale / "balls.parquet").write_bytes(b"half")
    live = tmp_path / stale_name(os.getppid())  # a live process's (this test's parent)
    live.mkdir()
    other_host = tmp_path / ".signatelec-00000000-1-0123abcd.tmp"
    other_host.mkdir()
    mine = [tmp_path / ".draft.tmp", tmp_path / ".x.1234.tmp", tmp_path / "notes.tmp"]
    for p in mine:
        p.write_text("the user's")
    assert cli(*QUICK, "--out", str(tmp_path / "run")).returncode == 0
    assert not stale.exists()
    assert live.exists() and other_host.exists() and all(p.exists() for p in mine)


def test_an_over_long_name_is_refused_before_the_run(tmp_path):
    name = "a" * 300
    t0 = time.monotonic()
    # 1e8 DEM steps if it ran: the refusal must come first
    proc = cli("simulate", "--duration", "10", "--quiet", "--out", str(tmp_path / name))
    assert time.monotonic() - t0 < 60
    assert_one_line(proc, 2, "is 300 bytes", "at most 255 bytes per name")
    assert list(tmp_path.iterdir()) == []
    deep = tmp_path.joinpath(*["d" * 200] * 21)
    proc = cli(*QUICK, "--out", str(deep))
    assert_one_line(proc, 2, "longer than the 4096 bytes")
    assert list(tmp_path.iterdir()) == []


def test_a_name_of_250_characters_is_written(tmp_path):
    out = tmp_path / ("b" * 250)
    proc = cli(*QUICK, "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == [io.MARKER_FILE, *io.SIMULATE_FILES]


@pytest.fixture
def small_tmpfs(tmp_path):
    """A 4 MiB tmpfs (root only; skipped where it cannot be mounted)."""
    mount = tmp_path / "tmpfs"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=4m", "tmpfs", str(mount)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs: {done.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def test_a_full_disk_during_simulate_leaves_the_previous_output(small_tmpfs):
    (small_tmpfs / "filler").write_bytes(b"\0" * 3_200_000)  # leaves ~0.9 MB
    out = small_tmpfs / "run"
    assert cli(*QUICK, "--duration", "0.015", "--out", str(out)).returncode == 0
    before = snapshot(out)
    proc = cli(*QUICK, "--duration", "0.06", "--out", str(out))  # ~0.9 MB: does not fit
    assert_one_line(proc, 75, "No space left on device", "nothing was written")
    assert snapshot(out) == before
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["filler", "run"]


@pytest.mark.slow
def test_a_full_disk_during_generate_exits_75_and_the_rerun_completes(small_tmpfs, tmp_path):
    spec = write_spec(
        tmp_path,
        SMALL_SPEC.replace("values = [0.1, 0.2]}", "min = 0.1, max = 0.3, levels = 40}"),
    )
    ds = small_tmpfs / "ds"
    full = small_tmpfs / "full"
    fd = os.open(full, os.O_WRONLY | os.O_CREAT)
    try:
        with pytest.raises(OSError, match="No space left"):
            for _ in range(5000):
                os.write(fd, b"\0" * 1024)
    finally:
        os.close(fd)
    proc = cli("generate", str(spec), "--out", str(ds), "--workers", "0", "--quiet")
    assert_one_line(proc, 75, "No space left on device", "nothing written")
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["full"]
    full.unlink()
    filler = small_tmpfs / "filler"
    filler.write_bytes(b"\0" * 3_900_000)  # leaves room for the spec and a few traces
    proc = cli("generate", str(spec), "--out", str(ds), "--workers", "0", "--quiet")
    line = assert_one_line(proc, 75, "No space left on device", "rerun the same command")
    written = len(list(ds.glob("regime=*/trace-*.parquet")))
    assert 0 < written < 80 and f"{written} of 80 traces are written and kept" in line
    assert not [p for p in ds.rglob("*") if p.name.endswith(".tmp")]
    assert len(read_dataset(ds)) == written  # every part kept is whole
    filler.unlink()
    proc = cli("generate", str(spec), "--out", str(ds), "--workers", "0")
    assert proc.returncode == 0, proc.stderr
    assert f"{written} already present, {80 - written} generated now" in proc.stdout
    assert sorted(read_dataset(ds).trace_id) == list(range(80))


def test_a_full_disk_in_a_worker_is_incomplete_not_refused(tmp_path, monkeypatch, capsys):
    spec = write_spec(tmp_path, SMALL_SPEC)
    ds = tmp_path / "ds"
    write = io.write_bytes_atomic
    parts = []

    def full_after_two_parts(path, data):
        if Path(path).name.startswith("trace-"):
            if len(parts) == 2:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
            parts.append(path)
        write(path, data)

    monkeypatch.setattr(io, "write_bytes_atomic", full_after_two_parts)
    code = run_main(["generate", str(spec), "--out", str(ds), "--workers", "0", "--quiet"])
    err = capsys.readouterr().err.splitlines()
    assert code == 75 and len(err) == 1, err
    assert "No space left on device" in err[0] and "2 of 4 traces are written and kept" in err[0]


def test_a_rerun_quarantines_a_truncated_part_and_regenerates_it(tmp_path):
    spec = write_spec(tmp_path, SMALL_SPEC)
    ds = tmp_path / "ds"
    argv = ("generate", str(spec), "--out", str(ds), "--workers", "0", "--quiet")
    assert cli(*argv).returncode == 0
    clean = read_dataset(ds).drop(columns=["cpu_s"])
    part = sorted(ds.glob("regime=*/trace-000002.parquet"))[0]
    part.write_bytes(part.read_bytes()[: part.stat().st_size // 2])
    user_file = ds / ".my-notes.tmp"
    user_file.write_text("mine")
    proc = cli(*argv)
    assert proc.returncode == 0, proc.stderr
    line = assert_one_line(proc, 0, "warning:", str(part.relative_to(ds)), "cannot be read")
    quarantined = part.with_name("_trace-000002.parquet.corrupt")
    assert f"moved to {quarantined.relative_to(ds)}" in line and quarantined.exists()
    again = read_dataset(ds).drop(columns=["cpu_s"])  # readers skip the quarantined file
    assert again.equals(clean)
    assert user_file.read_text() == "mine"


def test_a_dataset_rerun_touches_only_what_it_made(tmp_path):
    spec = write_spec(tmp_path, SMALL_SPEC)
    ds = tmp_path / "ds"
    argv = ("generate", str(spec), "--out", str(ds), "--workers", "0", "--quiet")
    assert cli(*argv).returncode == 0
    regime = next(ds.glob("regime=*"))
    stale = [regime / stale_name(dead_pid()), regime / f".trace-000099.parquet.{dead_pid()}.tmp"]
    users = [ds / ".draft.tmp", regime / ".trace-000001.parquet.mine.tmp", ds / "README.txt"]
    for p in stale + users:
        p.write_bytes(b"x")
    before = {p: p.stat().st_mtime_ns for p in ds.glob("regime=*/trace-*.parquet")}
    assert cli(*argv).returncode == 0
    assert not any(p.exists() for p in stale)
    assert all(p.read_bytes() == b"x" for p in users)
    assert {p: p.stat().st_mtime_ns for p in ds.glob("regime=*/trace-*.parquet")} == before


# --- limits before work ---------------------------------------------------------------------


def test_time_steps_beyond_the_limit_are_refused_with_a_step_that_helps(tmp_path):
    proc = cli("simulate", "--dt", "1e-12", "--out", str(tmp_path / "run"))
    line = assert_one_line(proc, 2, "numerics.dt_s = 1e-12", "3e+10 steps", "raise numerics.dt_s")
    assert f"{MAX_STEPS:.0e}" in line
    # above the stability limit and too long at any stable step: shorten the run, by how much
    stiff = "[effects]\ncontact_law = 'linear'\n[numerics]\nduration_s = 100.0\n"
    stiff += "linear_stiffness_n_m = 1e10\n"
    for extra, said in (("dt_s = 1e-7\n", "above the stability limit"), ("", "at any stable")):
        scene = write_spec(tmp_path, stiff + extra, "stiff.toml")
        proc = cli("simulate", "--scene", str(scene), "--out", str(tmp_path / "run"))
        line = assert_one_line(proc, 2, said, "shorten numerics.duration_s")
        limit_s = float(line.split("stability limit ")[1].split(" s")[0])
        at_most = float(line.split("to at most ")[1].split(" s")[0])
        assert at_most / limit_s == pytest.approx(MAX_STEPS, rel=1e-2)
        assert list(tmp_path.glob("run*")) == []


def test_no_allowed_step_gives_no_advice_to_use_one(tmp_path):
    scene = write_spec(
        tmp_path,
        "[effects]\ncontact_law = 'linear'\n[numerics]\nlinear_stiffness_n_m = 1e300\n",
    )
    proc = cli("simulate", "--scene", str(scene), "--out", str(tmp_path / "run"))
    line = assert_one_line(proc, 2, "no allowed time step runs this scene", "below the smallest")
    assert "use dt_s" not in line and "<= 0 s" not in line


def test_recorded_instants_and_memory_are_checked_before_the_run(tmp_path):
    scene = write_spec(tmp_path, "[numerics]\nsample_rate_hz = 1e7\nduration_s = 100.0\n")
    out = tmp_path / "run"
    proc = cli("simulate", "--scene", str(scene), "--fidelity", "quasistatic", "--out", str(out))
    assert_one_line(proc, 2, "1e+09 instants", "lower numerics.sample_rate_hz")
    need = 5e7 * instant_bytes(13)  # 10 s at 5 MHz
    available = available_memory_bytes()
    if available is None or available > need:
        pytest.skip("this machine has the memory for 5e7 recorded instants")
    scene.write_text("[numerics]\nsample_rate_hz = 5e6\nduration_s = 10.0\n")
    # held in memory (signatelec.simulate without out_dir): the whole run's tables; the command
    # line streams them to its output, one block in memory (tests/test_streaming.py)
    with pytest.raises(SceneError, match=r"5e\+07 recorded instants need .* available") as info:
        check_run(Scene.from_toml(scene))
    assert "numerics.duration_s" in str(info.value)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("fidelity", ["dem", "quasistatic"])
def test_a_sample_rate_with_no_instant_after_the_set_up_is_refused(tmp_path, fidelity):
    # one instant every 6.76 ms: at 6.76 ms, inside the 7 ms set-up, then none before 7.5 ms
    scene = write_spec(tmp_path, "[numerics]\nsample_rate_hz = 148.0\nduration_s = 0.0075\n")
    out = tmp_path / "run"
    proc = cli("simulate", "--scene", str(scene), "--fidelity", fidelity, "--out", str(out))
    line = assert_one_line(proc, 2, "records no instant after the set-up", "above")
    floor_hz = float(line.split("above ")[1].split(" Hz")[0])
    assert floor_hz == pytest.approx(1.0 / (0.0075 - 0.007), rel=1e-3)
    assert not out.exists()


def test_a_spec_whose_window_holds_no_sample_is_refused(tmp_path):
    spec = write_spec(tmp_path, SMALL_SPEC + "[measurement]\nsample_rate_hz = 10.0\n")
    proc = cli("generate", str(spec), "--out", str(tmp_path / "ds"))
    assert_one_line(proc, 2, "measurement.sample_rate_hz = 10.0", ">= 1/duration_s = 100 Hz")
    assert not (tmp_path / "ds").exists()


def test_a_spec_beyond_memory_is_refused_before_anything_is_written(tmp_path):
    text = SMALL_SPEC.replace("duration_s = 0.01", "duration_s = 10.0")
    spec = write_spec(tmp_path, text + "[measurement]\nsample_rate_hz = 1e6\noversample = 64\n")
    proc = cli("generate", str(spec), "--out", str(tmp_path / "ds"), "--workers", "2")
    assert_one_line(proc, 2, "dataset.duration_s = 10.0", "instants", "oversample")
    assert not (tmp_path / "ds").exists()


@pytest.mark.parametrize(
    ("path", "expected"),
    [
        ("", "must name a file"),
        ("/dev/zero", "is larger than 10 MiB"),
        ("big.toml", "is larger than 10 MiB"),
        ("a_directory", "cannot be read"),
    ],
)
def test_scene_files_are_read_with_a_limit(tmp_path, path, expected):
    with open(tmp_path / "big.toml", "wb") as fh:
        fh.truncate(11 * 1024**2)  # sparse: 11 MiB of nothing
    (tmp_path / "a_directory").mkdir()
    t0 = time.monotonic()
    proc = cli(*QUICK, "--scene", path, "--out", str(tmp_path / "run"), cwd=tmp_path)
    assert time.monotonic() - t0 < 60
    assert_one_line(proc, 2, f"scene file {path!r}", expected)
    assert not (tmp_path / "run").exists()
    spec = path if path else ""
    proc = cli("generate", spec, "--out", str(tmp_path / "ds"), cwd=tmp_path)
    assert_one_line(proc, 2, f"spec {spec!r}", expected)


@pytest.mark.parametrize(
    ("name", "expected"), [("/dev/zero", "is not a regular file"), ("huge.csv", "larger than")]
)
def test_trace_files_are_read_with_a_limit(tmp_path, name, expected):
    with open(tmp_path / "huge.csv", "wb") as fh:
        fh.truncate(2 * 1024**3)  # sparse
    proc = cli("estimate", name, "--omega", "500", cwd=tmp_path)
    assert_one_line(proc, 2, f"trace {name!r}", expected)


def test_the_divergence_advice_is_one_that_helps(tmp_path):
    """A large clearance at 1000 rad/s after a brisk 5 ms spin-up throws a cage ball out. A
    quarter of the time step diverges at the same instant, so a smaller dt is not the cure; the
    message names the cure it measured, and the scene with that cure runs."""
    brisk = "[procedure]\nspin_up_time_s = 0.005\n"
    args = ("--radial-load", "873", "--clearance", "6e-5", "--omega", "1000", "--quiet")
    out = tmp_path / "run"
    scene = write_spec(tmp_path, brisk, "brisk.toml")
    proc = cli("simulate", "--scene", str(scene), *args, "--duration", "0.012", "--out", str(out))
    line = assert_one_line(proc, 3, "diverged at step", "cure measured: ")
    assert "cure measured: a smaller time step" not in line
    at_s = float(line.split("(t = ")[1].split(" s)")[0])
    quarter = ("--duration", "0.012", "--dt", "2.5e-8", "--out", str(out))
    proc = cli("simulate", "--scene", str(scene), *args, *quarter)
    line_quarter = assert_one_line(proc, 3, "diverged at step")
    assert float(line_quarter.split("(t = ")[1].split(" s)")[0]) == pytest.approx(at_s, rel=1e-3)
    assert not out.exists()
    cure = line.split("cure measured: ")[1]
    if "spin_up_time_s = " in cure:
        spin_up = float(cure.split("spin_up_time_s = ")[1].split(",")[0])
        cured = f"[procedure]\nspin_up_time_s = {spin_up!r}\n"
    else:
        cage = cure.split('effects.cage = "')[1].split('"')[0]
        cured = brisk + f"[effects]\ncage = {cage!r}\n"
    scene = write_spec(tmp_path, cured, "cured.toml")
    proc = cli("simulate", "--scene", str(scene), *args, "--duration", "0.05", "--out", str(out))
    assert proc.returncode == 0, proc.stderr


# --- the exit codes are documented ---------------------------------------------------------


def test_exit_codes_are_in_the_help_and_the_readme():
    proc = cli("--help")
    text = " ".join(proc.stdout.split())
    readme = (REPO / "README.md").read_text()
    table = readme.split("## Exit codes", 1)[1].split("\n## ", 1)[0]
    for code, _ in EXIT_CODES:
        assert f"{code} " in text
        assert f"| {code} |" in table


def test_the_stale_check_knows_a_live_process_from_a_dead_one():
    assert io.pid_alive(os.getpid()) and not io.pid_alive(dead_pid())
    assert io.stale_owner(stale_name(dead_pid())) is not None
    assert io.stale_owner(io.temporary_name()) is None  # this process's own
    assert io.stale_owner(".draft.tmp") is None
    assert len(io.temporary_name()) <= io.TEMPORARY_NAME_MAX
