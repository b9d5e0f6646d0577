"""Fuzzing the input contract of the command line (hypothesis).

For any scene file, dataset spec or trace, ``signatelec simulate | generate | estimate`` either

- exits 0 with complete outputs (the output directory holds exactly the command's files, its
  parent nothing else new), or
- exits 2 with exactly one line ``signatelec: ...`` on stderr, no traceback, and nothing written
  (no output directory, no temporary file beside it),

never anything else, never a hang (each case runs under a timer).

The inputs are structured (the sections and keys of the scene dataclasses and of the spec
tables, plus unknown ones, with values of every type: huge, tiny, negative, NaN and infinite
numbers, 400-digit integers, strings, booleans, arrays, nested tables) and raw (arbitrary bytes
and text). Accepted inputs are kept cheap: scenes run at ``--fidelity quasistatic`` with
durations a little past the set-up, specs with one or two short quasi-static traces; a DEM or
preset scene is run only when the command refuses it (its validation alone is fuzzed). An
accepted input whose run would still be long (many recorded instants) is validated, not run.

Cases run in this process through :func:`signatelec.cli.main` (fast); a few run as a subprocess
to catch what only a process shows (output of imports, warnings at exit). The examples are
derandomised, so CI runs the same cases every time; ``SIGNATELEC_FUZZ_EXAMPLES=2000`` runs that
many random ones per target for a local search.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import signal
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st

from tests.cli_run import cli, run_main
from tests.fuzz_inputs import (
    HUGE,
    fidelities,
    omegas,
    out_suffixes,
    raw_text,
    scene_tables,
    specs,
    toml_text,
    trace_tables,
    write_input,
    write_trace,
)

pytestmark = pytest.mark.slow

#: Examples per target; CI's counts keep the whole file to about two minutes on 2 cores.
LOCAL = int(os.environ.get("SIGNATELEC_FUZZ_EXAMPLES", "0"))
#: A case that takes longer than this has hung (the slowest accepted case takes ~1 s).
CASE_TIMEOUT_S = 60
#: Accepted inputs whose run records more ball-instants than this are validated, not run.
MAX_BALL_INSTANTS = 13 * 20_000


def fuzz_settings(examples: int):
    return settings(
        max_examples=LOCAL or examples,
        # CI replays the same cases; a local search draws new ones each run
        derandomize=not LOCAL,
        database=None,
        # a shared CI machine makes times noisy: the per-case timer catches hangs instead
        deadline=None,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.data_too_large,
            HealthCheck.filter_too_much,
            # capsys is read out before and after each case (run_in_process)
            HealthCheck.function_scoped_fixture,
        ],
    )


# --- running a case ---------------------------------------------------------------------------


class Hung(BaseException):
    """Raised by the timer; a BaseException so that no handler of the command swallows it."""


@contextlib.contextmanager
def timer(seconds: int):
    def ring(signum, frame):
        raise Hung(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, ring)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def run_in_process(capsys, argv: list[str]) -> tuple[int, str, str]:
    capsys.readouterr()
    with timer(CASE_TIMEOUT_S):
        code = run_main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def reason(err: str) -> str:
    """What a refusal names, for the statistics: its key, or its first words."""
    text = err.split("': ", 1)[-1]
    key = re.match(r"([^ ]+) = ", text)
    return key[1].split("[")[0] if key else " ".join(text.split()[:3])


def assert_contract(
    code: int, err: str, workdir: Path, before: set[str], out: Path, argv, complete
) -> None:
    """Exit 0 with ``complete(out)`` true and only ``out`` new in ``workdir``, or exit 2 with one
    line on stderr and ``workdir`` as it was."""
    after = set(os.listdir(workdir))
    context = f"argv={argv}\nexit={code}\nstderr={err}"
    event(f"exit {code}" + (f": {reason(err)}" if code == 2 else ""))
    assert "Traceback" not in err, context
    if code == 2:
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("signatelec: error: "), context
        assert after == before, (context, after - before)
        return
    assert code == 0, context
    assert after - before <= {out.name} and before <= after, (context, after ^ before)
    assert complete(out), context


# --- simulate ---------------------------------------------------------------------------------


def simulate_complete(out: Path) -> bool:
    import pyarrow.parquet as pq

    names_ = set(os.listdir(out))
    if names_ != {".signatelec.json", "balls.parquet", "signals.parquet"}:
        return False
    return pq.read_table(out / "signals.parquet").num_rows > 0


def scene_cost(path: Path, fidelity: str) -> int | None:
    """Ball-instants the command would record, or None when it refuses the scene."""
    from signatelec.cli import InputError, load_scene
    from signatelec.config.scene import SceneError
    from signatelec.engines.budget import check_run
    from signatelec.engines.fidelity import apply_fidelity

    try:
        scene = apply_fidelity(load_scene(str(path)), fidelity)
        return check_run(scene).n_instants * scene.bearing.n_balls
    except (InputError, SceneError):
        return None


def check_scene(capsys, text: str | bytes, fidelity: str) -> None:
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        workdir = Path(tmp)
        path = write_input(workdir / "scene.toml", text)
        cost = scene_cost(path, fidelity)
        if cost is not None and (fidelity != "quasistatic" or cost > MAX_BALL_INSTANTS):
            event(f"accepted at {fidelity}, validated only")
            return
        out = workdir / "out"
        argv = ["simulate", "--scene", str(path), "--out", str(out), "--quiet"]
        argv += ["--fidelity", fidelity]
        before = set(os.listdir(workdir))
        code, _, err = run_in_process(capsys, argv)
        assert_contract(code, err, workdir, before, out, argv, simulate_complete)


@fuzz_settings(400)
# a defect the fuzz found: a key holding a line break (str.splitlines breaks at \x1e) printed raw
@example(scene={"bearing": {"\x1e": []}}, fidelity="quasistatic")
@given(scene=scene_tables(), fidelity=fidelities)
def test_scene_files(capsys, scene, fidelity):
    check_scene(capsys, toml_text(scene), fidelity)


@fuzz_settings(100)
@given(text=raw_text)
def test_scene_garbage(capsys, text):
    check_scene(capsys, text, "quasistatic")


# --- generate ---------------------------------------------------------------------------------


def dataset_complete(out: Path) -> bool:
    names_ = set(os.listdir(out))
    if not {".signatelec.json", "_spec.json", "_manifest.json"} <= names_:
        return False
    manifest = json.loads((out / "_manifest.json").read_text())
    return manifest["complete"] and not manifest["missing"]


def spec_cost(path: Path) -> float | None:
    """Samples the spec's traces would simulate (inf off the quasi-static tier), None when it is
    refused."""
    from signatelec.data import SpecError, load_spec

    try:
        spec = load_spec(path)
    except SpecError:
        return None
    if spec.fidelity != "quasistatic":
        return math.inf
    m = spec.measurement
    per_trace = (spec.duration_s + spec.settle_s) * m.sample_rate_hz * m.oversample
    return spec.n_traces * per_trace * spec.scene.bearing.n_balls


def check_spec(capsys, text: str | bytes) -> None:
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        workdir = Path(tmp)
        path = write_input(workdir / "spec.toml", text)
        cost = spec_cost(path)
        if cost is not None and cost > MAX_BALL_INSTANTS:
            event("accepted, validated only")
            return
        out = workdir / "out"
        argv = ["generate", str(path), "--out", str(out), "--workers", "0", "--quiet"]
        before = set(os.listdir(workdir))
        code, _, err = run_in_process(capsys, argv)
        assert_contract(code, err, workdir, before, out, argv, dataset_complete)


@fuzz_settings(400)
@example(spec={"design": [{"kind": "grid", "\r": 0.0}]})  # a key holding a line break
@given(spec=specs())
def test_dataset_specs(capsys, spec):
    check_spec(capsys, toml_text(spec))


@fuzz_settings(100)
@given(text=raw_text)
def test_dataset_spec_garbage(capsys, text):
    check_spec(capsys, text)


# --- estimate ---------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def default_model():
    """The default model, built once before the cases (its first build takes seconds)."""
    from signatelec.estimation.persistence import default_model as build

    build()


def check_trace(capsys, write, suffix: str, omega: str, out_suffix: str | None) -> None:
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        workdir = Path(tmp)
        path = workdir / f"trace{suffix}"
        write(path)
        argv = ["estimate", str(path), "--omega", omega, "--quiet"]
        out = workdir / f"estimate{out_suffix or '.json'}"
        if out_suffix is not None:
            argv += ["--out", str(out)]
        before = set(os.listdir(workdir))
        code, _, err = run_in_process(capsys, argv)

        def complete(out: Path) -> bool:
            return out_suffix is None or (out.is_file() and out.stat().st_size > 0)

        assert_contract(code, err, workdir, before, out, argv, complete)


@fuzz_settings(400)
# defects the fuzz found: a 400-digit integer cell (OverflowError in pandas.to_numeric), one
# sample of 1e77 ohm (the features' powers of R overflow), a level of 1e-103 ohm (they underflow)
@example(
    table={"time_s": list(np.arange(400) / 20e3), "resistance_ohm": [1.5e-103] * 400},
    suffix=".csv",
    omega="500",
    out_suffix=None,
)
@example(
    table={"time_s": list(np.arange(400) / 20e3), "resistance_ohm": [1e77] + [1.5e-3] * 399},
    suffix=".csv",
    omega="500",
    out_suffix=None,
)
@example(
    table={"time_s": [HUGE], "resistance_ohm": [1.5e-3]},
    suffix=".csv",
    omega="500",
    out_suffix=None,
)
@given(
    table=trace_tables(),
    suffix=st.sampled_from([".csv", ".parquet", ".tsv", ".txt"]),
    omega=omegas,
    out_suffix=out_suffixes,
)
def test_traces(capsys, default_model, table, suffix, omega, out_suffix):
    check_trace(capsys, lambda p: write_trace(p, table), suffix, omega, out_suffix)


@fuzz_settings(100)
# defects the fuzz found: a file the CSV sniffer finds no delimiter in (csv.Error), a column
# name holding a character str.splitlines breaks at
@example(data=b"", suffix=".csv", out_suffix=None)
@example(data="0\x1e", suffix=".csv", out_suffix=None)
@given(
    data=raw_text,
    suffix=st.sampled_from([".csv", ".parquet", ".txt", ".dat", ""]),
    out_suffix=out_suffixes,
)
def test_trace_garbage(capsys, default_model, data, suffix, out_suffix):
    check_trace(capsys, lambda path: write_input(path, data), suffix, "500", out_suffix)


def monitor_complete(out: Path) -> bool:
    import json

    names_ = set(os.listdir(out))
    if names_ != {".signatelec.json", "windows.parquet", "summary.json", "monitor.png"}:
        return False
    summary = json.loads((out / "summary.json").read_text())
    return summary["trace"]["windows"] > 0


@fuzz_settings(100)
@given(
    table=trace_tables(),
    suffix=st.sampled_from([".csv", ".parquet", ".txt"]),
    omega=omegas,
    window=st.sampled_from(["0.2", "0.05", "0.01", "1e-9", "nan", "-1"]),
)
def test_monitor_traces(capsys, default_model, table, suffix, omega, window):
    """``signatelec monitor`` keeps the same contract on the traces ``estimate`` is fuzzed with."""
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        workdir = Path(tmp)
        path = workdir / f"trace{suffix}"
        write_trace(path, table)
        out = workdir / "monitor"
        argv = ["monitor", str(path), "--omega", omega, "--window", window, "--out", str(out)]
        argv.append("--quiet")
        before = set(os.listdir(workdir))
        code, _, err = run_in_process(capsys, argv)
        assert_contract(code, err, workdir, before, out, argv, monitor_complete)


# --- the same contract seen from a process ----------------------------------------------------


@fuzz_settings(6)
@given(scene=scene_tables(), spec=specs(), table=trace_tables())
def test_as_a_process(scene, spec, table):
    """A scene, a spec and a trace per example through ``python -c main()``: one line or a
    complete output, whatever imports or the interpreter's exit print."""
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        workdir = Path(tmp)
        write_input(workdir / "scene.toml", toml_text(scene))
        write_input(workdir / "spec.toml", toml_text(spec))
        write_trace(workdir / "trace.csv", table)
        cases = [
            (
                ["simulate", "--scene", "scene.toml", "--fidelity", "quasistatic"],
                scene_cost(workdir / "scene.toml", "quasistatic"),
                simulate_complete,
            ),
            (
                ["generate", "spec.toml", "--workers", "0"],
                spec_cost(workdir / "spec.toml"),
                dataset_complete,
            ),
        ]
        for args, cost, complete in cases:
            if cost is not None and cost > MAX_BALL_INSTANTS:
                continue
            out = workdir / f"out-{args[0]}"
            before = set(os.listdir(workdir))
            argv = [*args, "--out", out.name, "--quiet"]
            proc = cli(*argv, cwd=workdir, timeout=CASE_TIMEOUT_S)
            assert_contract(proc.returncode, proc.stderr, workdir, before, out, argv, complete)
        before = set(os.listdir(workdir))
        argv = ["estimate", "trace.csv", "--omega", "500", "--quiet"]
        proc = cli(*argv, cwd=workdir, timeout=CASE_TIMEOUT_S)
        assert_contract(proc.returncode, proc.stderr, workdir, before, workdir, argv, bool)
