"""Worker processes that end with the job that started them.

``signatelec generate`` runs its traces in local worker processes forked from a forkserver. They
must not outlive the job: a job killed with SIGKILL would otherwise leave them simulating and
writing for minutes. Three guards, from the strongest:

- Linux's ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the kernel kills the forkserver when the job
  dies, and each worker when the forkserver dies (set in each, then the parent is checked once
  more, since it may have died before the call);
- a watchdog thread in each worker polls the job's pid and its own parent pid (the portable
  fallback, and the guard where the death signal was not delivered) and exits at once;
- Ctrl-C (SIGINT to the whole process group) is for the job alone: it is blocked while the
  forkserver starts (the signal mask is inherited through fork and exec, so the forkserver and
  its workers never see it) and ignored by each worker; the job then stops its workers itself.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator

from signatelec.io import pid_alive

#: Environment variable naming the job's pid to the forkserver it starts.
JOB_PID_VARIABLE = "SIGNATELEC_JOB_PID"
#: Seconds between two checks of the watchdog.
WATCH_INTERVAL_S = 0.25
_PR_SET_PDEATHSIG = 1


def die_with_parent(expected_parent: int | None = None) -> bool:
    """Ask the kernel to kill this process when its parent dies (Linux); exit at once when the
    parent is already gone (``expected_parent``: its pid). Returns whether the kernel agreed."""
    armed = False
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            armed = libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    if expected_parent is not None and os.getppid() != expected_parent:
        os._exit(1)  # the parent died before the death signal was armed
    return armed


def watch_job(job_pid: int, interval_s: float = WATCH_INTERVAL_S) -> threading.Thread:
    """A daemon thread that ends this process when the job ``job_pid`` or this process's parent
    is gone."""
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(interval_s)
            if os.getppid() != parent or not pid_alive(job_pid):
                os._exit(1)

    thread = threading.Thread(target=watch, name="signatelec-watchdog", daemon=True)
    thread.start()
    return thread


def init_worker(job_pid: int) -> None:
    """First thing in a local worker: ignore Ctrl-C, die with the parent, watch the job."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent()
    watch_job(job_pid)


def init_forkserver() -> None:
    """In the forkserver (its preload): die with the job that started it, and keep quiet the
    workers it forks that fail to start because the job is stopping (nothing in any other
    process: the job names itself in the environment before it starts the forkserver)."""
    job = os.environ.get(JOB_PID_VARIABLE, "")
    if not job.isdigit() or int(job) == os.getpid():
        return
    die_with_parent(int(job))
    server, report = os.getpid(), sys.excepthook

    def excepthook(*exc_info) -> None:
        # a worker that failed before its initializer ran: report it only while the job and
        # this forkserver live (a stopping job kills the forkserver first, see stop_pool)
        if os.getppid() == server and pid_alive(int(job)):
            report(*exc_info)

    sys.excepthook = excepthook


@contextlib.contextmanager
def interrupts_blocked() -> Iterator[None]:
    """Block SIGINT in this thread for the block: processes started meanwhile inherit the mask.
    A Ctrl-C that arrives meanwhile is delivered when the block ends."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not (
        threading.main_thread()
    ):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _stop_forkserver(pool) -> None:
    """Kill the forkserver of ``pool``'s workers (the next pool starts a new one): a worker it
    is forking then dies with it, without a word."""
    context = getattr(pool, "_mp_context", None)
    if context is None or context.get_start_method() != "forkserver":
        return
    from multiprocessing import forkserver

    pid = getattr(getattr(forkserver, "_forkserver", None), "_forkserver_pid", None)
    if pid:
        with contextlib.suppress(OSError, AttributeError):
            os.kill(pid, signal.SIGKILL)
            # wait until it has ended, without reaping it: multiprocessing reaps it and starts
            # a new one when a pool next needs it
            os.waitid(os.P_PID, pid, os.WEXITED | os.WNOWAIT)


def stop_pool(pool) -> None:
    """End a ``ProcessPoolExecutor``'s workers now (SIGKILL), dropping the queued tasks: a stop
    (Ctrl-C, an error) must not wait for the traces in flight."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    _stop_forkserver(pool)
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError):
            process.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        with contextlib.suppress(OSError, ValueError, AttributeError, AssertionError):
            process.join(5.0)
    # join returns at once for a forkserver child once the forkserver is gone, before the kill
    # has landed: wait until each worker is really gone, so that the sweep of the temporaries
    # that follows sees their writers dead
    deadline = time.monotonic() + 5.0
    for process in processes:
        pid = getattr(process, "pid", None)
        while pid and pid_alive(pid) and time.monotonic() < deadline:
            time.sleep(0.01)
