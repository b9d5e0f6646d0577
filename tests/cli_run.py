"""Running the command line as a user does, for the tests of outputs, limits and processes."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from signatelec import io
from signatelec.cli import main

QUICK = ("simulate", "--fidelity", "quasistatic", "--quiet")


def cli(*args: str, cwd: Path | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", "from signatelec.cli import main; main()", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
    )


def _as_from_a_terminal() -> None:
    """Ctrl-C reaches the command as it does from a terminal, even when the test runner was
    started with SIGINT ignored (nohup, a background job of a non-interactive shell)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args: str) -> subprocess.Popen:
    """The command in a session of its own (its workers and forkserver join that session)."""
    return subprocess.Popen(
        [sys.executable, "-c", "from signatelec.cli import main; main()", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_as_from_a_terminal,
    )


def assert_one_line(proc, code: int, *fragments: str) -> str:
    """Exit ``code``, one line on stderr holding ``fragments``, no traceback; the line."""
    err = proc.stderr.splitlines()
    assert proc.returncode == code, proc.stderr
    assert len(err) == 1, proc.stderr
    assert err[0].startswith("signatelec: ") and "Traceback" not in proc.stderr
    for fragment in fragments:
        assert fragment in err[0], (fragment, err[0])
    return err[0]


def snapshot(directory: Path) -> dict[str, str]:
    """Every entry below ``directory``: a file's content hash, or "dir"."""
    entries = {}
    for p in sorted(directory.rglob("*")):
        rel = str(p.relative_to(directory))
        entries[rel] = "dir" if p.is_dir() else hashlib.sha1(p.read_bytes()).hexdigest()
    return entries


def run_main(argv: list[str]) -> int:
    """``signatelec.cli.main`` in this process (where a failure is injected): the exit code."""
    try:
        main(argv)
    except SystemExit as exc:
        return exc.code
    return 0


def dead_pid() -> int:
    """The pid of a process that has ended (and been reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def stale_name(pid: int) -> str:
    """A temporary name as a process ``pid`` of this host would have made it."""
    return io.temporary_name().replace(f"-{os.getpid()}-", f"-{pid}-")


def write_spec(directory: Path, text: str, name: str = "spec.toml") -> Path:
    path = directory / name
    path.write_text(textwrap.dedent(text))
    return path


def session_processes(session: int) -> list[int]:
    """Live (not zombie) processes of a session."""
    pids = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        state, _, _, sid = stat.rsplit(")", 1)[1].split()[:4]
        if int(sid) == session and state not in ("Z", "X"):
            pids.append(int(entry))
    return pids


def wait_for(condition, timeout_s: float, proc=None) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert proc is None or proc.poll() is None, proc.stderr.read()
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="Linux /proc")
