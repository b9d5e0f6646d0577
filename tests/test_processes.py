"""Processes that end together: a killed, interrupted or terminated job takes its workers and
forkserver with it at once, says so in one line and leaves what a rerun resumes from."""

from __future__ import annotations

import os
import signal
import time
import weakref

import pytest
from cli_run import cli, needs_proc, session_processes, start, wait_for, write_spec

from signatelec.cli import _raise_interrupted
from signatelec.data import generate, load_spec, read_dataset
from signatelec.io import clear_stops

#: 40 DEM traces of 4 ms: long enough to be stopped part-way.
PROCESS_SPEC = """
[dataset]
seed = 11
fidelity = "dem"
duration_s = 0.004
settle_s = 0.0
[[design]]
kind = "random"
n_traces = 40
factors.radial_load_fraction = {min = 0.1, max = 0.3}
factors.clearance_m = {min = -5e-6, max = 5e-6}
"""


@pytest.mark.slow
@needs_proc
def test_workers_end_with_a_killed_job_and_the_rerun_completes(tmp_path):
    spec = write_spec(tmp_path, PROCESS_SPEC)
    ds = tmp_path / "ds"
    proc = start("generate", str(spec), "--out", str(ds), "--workers", "2", "--quiet")
    try:
        wait_for(lambda: len(list(ds.glob("regime=*/trace-*.parquet"))) >= 2, 300, proc)
        assert len(session_processes(proc.pid)) >= 4  # job, forkserver, two workers
        proc.kill()
        proc.wait()
        wait_for(lambda: not session_processes(proc.pid), 5.0)  # not the minute of work left
    finally:
        for pid in session_processes(proc.pid):
            os.kill(pid, signal.SIGKILL)
        proc.stderr.close()
    rerun = cli("generate", str(spec), "--out", str(ds), "--workers", "2", timeout=600)
    assert rerun.returncode == 0, rerun.stderr
    assert sorted(read_dataset(ds).trace_id) == list(range(40))
    assert not [p for p in ds.rglob("*") if p.name.endswith(".tmp")]


@needs_proc
@pytest.mark.parametrize(
    ("when", "sig", "code"),
    [
        ("warm-up", signal.SIGINT, 130),
        ("traces", signal.SIGINT, 130),
        ("traces", signal.SIGTERM, 143),
    ],
)
def test_an_interrupt_stops_every_process_with_one_line(tmp_path, when, sig, code):
    spec = write_spec(tmp_path, PROCESS_SPEC)
    ds = tmp_path / "ds"
    proc = start("generate", str(spec), "--out", str(ds), "--workers", "2", "--quiet")
    try:
        if when == "warm-up":  # the spec is written just before the kernels are warmed up
            wait_for(lambda: (ds / "_spec.json").exists(), 300, proc)
        else:
            wait_for(lambda: len(list(ds.glob("regime=*/trace-*.parquet"))) >= 2, 300, proc)
        # Ctrl-C reaches the whole process group; SIGTERM is sent to the job alone
        (os.killpg if sig == signal.SIGINT else os.kill)(proc.pid, sig)
        _, err = proc.communicate(timeout=30)
        wait_for(lambda: not session_processes(proc.pid), 5.0)
    finally:
        for pid in session_processes(proc.pid):
            os.kill(pid, signal.SIGKILL)
    assert proc.returncode == code, err
    lines = err.splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "rerun the same command to resume" in lines[0]
    written = len(list(ds.glob("regime=*/trace-*.parquet")))
    assert f"{written} of 40 traces are written and kept" in lines[0]
    assert not [p for p in ds.rglob("*") if p.name.endswith(".tmp")]


@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
def test_a_ctrl_c_that_a_callback_swallowed_still_stops_the_job(tmp_path):
    """Python only prints an exception raised in a weakref or import-lock callback and goes on:
    a Ctrl-C that lands there must still stop the job at its next point, before any trace."""

    class Held:
        pass

    held = Held()
    ref = weakref.ref(held, lambda _: _raise_interrupted(signal.SIGINT, None))
    try:
        del held  # the callback raises; Python reports it as ignored
        assert ref() is None
        with pytest.raises(KeyboardInterrupt):
            generate(load_spec(write_spec(tmp_path, PROCESS_SPEC)), tmp_path / "ds", workers=0)
    finally:
        clear_stops()
    assert not list((tmp_path / "ds").glob("regime=*/trace-*.parquet"))


@needs_proc
def test_ctrl_c_during_simulate_writes_nothing(tmp_path):
    out = tmp_path / "run"
    proc = start("simulate", "--duration", "2", "--quiet", "--out", str(out))
    time.sleep(4.0)  # imports, kernel load, then the time loop (2e7 steps: ~10 s)
    assert proc.poll() is None
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    lines = err.splitlines()  # during the run, or during the imports on a slow machine
    assert lines in (
        ["signatelec: error: interrupted; nothing written"],
        ["signatelec: interrupted"],
    )
    assert list(tmp_path.iterdir()) == []
