"""Running a spec's traces: local worker processes or a Dask cluster, resumable.

``signatelec generate SPEC.toml --out DIR`` (or :func:`generate`) expands the spec's design into
traces (:mod:`signatelec.data.design`), runs each (:mod:`signatelec.data.runner`) and writes one
part file per trace (:mod:`signatelec.data.store`), skipping the traces already written. The
kernels are compiled in the calling process before any worker starts; local workers are forked
from a forkserver whose imports overlap that compilation; a bounded number of traces is in
flight per worker, so a million-trace spec is not queued at once. Local workers end with the
job (:mod:`signatelec.data.lifeline`): a job that stops, is interrupted or killed takes them
with it, and what they were writing is left as temporaries the next run removes.
"""

from __future__ import annotations

import itertools
import math
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from signatelec.data import lifeline
from signatelec.data.design import TraceTask, design_traces
from signatelec.data.runner import (
    STATUS_OK,
    batched,
    check_budget,
    labels,
    run_trace,
    run_traces,
    warm_up,
)
from signatelec.data.spec import Spec, TraceContext
from signatelec.data.store import (
    MANIFEST_FILE,
    DatasetDirError,
    done_trace_ids,
    locked,
    part_metadata,
    prepare_output,
    remove_stale_temporaries,
    verified_parts,
    write_manifest,
    write_part,
)
from signatelec.io import stop_now

_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

#: State of a local worker process, set by its initializer.
_WORKER: dict[str, Any] = {}
#: Traces in flight per worker (bounded, so a million-trace spec is not queued at once).
IN_FLIGHT_PER_WORKER = 4


def _worker_init(ctx: TraceContext, out: str, metadata: dict, job_pid: int) -> None:
    """Each local worker, before its first trace: bind its life to the job's, then load the
    kernels the parent compiled."""
    lifeline.init_worker(job_pid)
    _WORKER.update(ctx=ctx, out=Path(out), metadata=metadata)
    warm_up(ctx)


def _run_and_write(tasks: list[TraceTask]) -> list[dict]:
    """In a local worker: run the traces (together when the spec is batched), write their part
    files, return their labels only."""
    out = []
    for rec in _run(_WORKER["ctx"], tasks):
        write_part(_WORKER["out"], rec, _WORKER["metadata"])
        out.append(labels(rec))
    return out


def _run(ctx: TraceContext, tasks: list[TraceTask]) -> list[dict]:
    """The records of ``tasks``: through the ensemble kernel when the spec's traces run there
    (runner.batched), even a lone one (so a trace's values do not depend on the batch it fell
    in: a resumed or redistributed job gives the same dataset), else one by one."""
    if batched(ctx):
        return run_traces(ctx, tasks)
    return [run_trace(ctx, task) for task in tasks]


def _batches(ctx: TraceContext, tasks: list[TraceTask]) -> list[list[TraceTask]]:
    """The traces in groups of the ensemble kernel's lane width (one each when not batched)."""
    from signatelec.engines.dem.batch import LANES

    size = LANES if batched(ctx) else 1
    return [tasks[i : i + size] for i in range(0, len(tasks), size)]


def _process_context():
    """The start method of the local workers: a forkserver (started here, at once, so that its
    imports overlap the parent's kernel compilation) or, where there is none, spawn."""
    import multiprocessing
    import multiprocessing.forkserver
    import multiprocessing.resource_tracker

    for name in _THREAD_VARIABLES:  # one thread per worker: the workers are the parallelism
        os.environ.setdefault(name, "1")
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    mp = multiprocessing.get_context("forkserver")
    mp.set_forkserver_preload(["signatelec.data._forkserver_preload"])
    os.environ[lifeline.JOB_PID_VARIABLE] = str(os.getpid())
    # the resource tracker first: starting it unblocks SIGINT (multiprocessing.resource_tracker)
    multiprocessing.resource_tracker.ensure_running()
    with lifeline.interrupts_blocked():  # the forkserver and its workers never see Ctrl-C
        multiprocessing.forkserver.ensure_running()
    return mp


def _local_results(
    ctx: TraceContext, tasks: list[TraceTask], workers: int, out: Path, metadata: dict, mp=None
) -> Iterator[dict]:
    """Labels of each finished trace, whose part file is written (by the worker)."""
    if workers == 0:
        for batch in _batches(ctx, tasks):
            for rec in _run(ctx, batch):
                write_part(out, rec, metadata)
                yield rec
        return
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=mp or _process_context(),
        initializer=_worker_init,
        initargs=(ctx, str(out), metadata, os.getpid()),
    )
    batches = _batches(ctx, tasks)
    queue = iter(batches)
    in_flight = IN_FLIGHT_PER_WORKER * workers if len(batches) == len(tasks) else 2 * workers
    pending: set = set()
    with pool:
        try:
            while True:
                while len(pending) < in_flight:
                    batch = next(queue, None)
                    if batch is None:
                        break
                    pending.add(pool.submit(_run_and_write, batch))
                if not pending:
                    break
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in finished:
                    yield from fut.result()
        except BaseException:  # an error, Ctrl-C, or the caller stopped: the workers end now
            lifeline.stop_pool(pool)
            raise


def _dask_results(
    ctx: TraceContext, tasks: list[TraceTask], client, out: Path, metadata: dict
) -> Iterator[dict]:
    """Labels of each finished trace; the cluster's workers return the records and this
    process writes the part files (the workers need not see ``out``)."""
    from distributed import as_completed

    client.run(warm_up, ctx)  # each worker loads (or compiles) the kernels once
    shared = client.scatter(ctx, broadcast=True)
    limit = IN_FLIGHT_PER_WORKER * max(sum(client.nthreads().values()), 1)
    queue = iter(_batches(ctx, tasks))
    running = as_completed()
    for batch in itertools.islice(queue, limit):
        running.add(client.submit(_run, shared, batch, pure=False))
    try:
        for fut in running:
            recs = fut.result()
            fut.release()
            batch = next(queue, None)
            if batch is not None:
                running.add(client.submit(_run, shared, batch, pure=False))
            for rec in recs:
                write_part(out, rec, metadata)
                yield rec
    finally:
        running.clear()


@dataclass
class Summary:
    out: str
    n_traces: int
    already_done: int
    generated: int
    failed_now: int
    failed_total: int
    wall_s: float
    warm_up_s: float
    cores: int
    cpu_s: float
    scheduler: str | None = None

    @property
    def traces_per_core_s(self) -> float:
        return self.generated / (self.wall_s * self.cores) if self.wall_s > 0 else math.nan

    def describe(self) -> str:
        where = f"Dask cluster {self.scheduler}" if self.scheduler else "local processes"
        lines = [
            f"traces: {self.n_traces} in the spec, {self.already_done} already present, "
            f"{self.generated} generated now",
            f"failures: {self.failed_now} now, {self.failed_total} in the dataset "
            "(status = 'failed', see the error column)",
            f"wall time: {self.wall_s:.2f} s on {self.cores} core(s) ({where}); kernels ready in "
            f"{self.warm_up_s:.2f} s; simulation CPU {self.cpu_s:.2f} s",
            f"throughput: {self.traces_per_core_s:.3f} traces per core-second "
            f"({60 * self.traces_per_core_s:.2f} per core-minute)",
            f"wrote {self.out} (regime=*/trace-*.parquet, {MANIFEST_FILE})",
        ]
        return "\n".join(lines)


def generate(
    spec: Spec,
    out: str | Path,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = False,
    on_trace: Callable[[dict], None] | None = None,
    log: Callable[[str], None] | None = None,
) -> Summary:
    """Generate the spec's traces into ``out``, skipping those already there.

    ``workers``: local worker processes (default: all cores; 0 runs in this process);
    ``scheduler``: the address of a Dask scheduler to run on instead. Kernels are compiled in
    this process before the workers start; ``on_trace`` is called with the labels of each trace
    written, ``log`` with a line for each part file found unreadable and moved aside. Returns a
    :class:`Summary`. Before anything is written, a trace that would exceed the run limits
    (:func:`signatelec.data.runner.check_budget`) raises
    :class:`~signatelec.data.spec.SpecError`.
    """
    t_start = time.perf_counter()
    if scheduler is None:
        workers = default_workers() if workers is None else workers
        check_budget(spec, concurrent=max(workers, 1))
    else:  # the cluster's workers have their own memory
        check_budget(spec, concurrent=None)
    client = None
    if scheduler:  # before anything is written: a cluster that cannot be reached is an input
        from distributed import Client

        try:
            client = Client(scheduler, timeout="20s")
        except OSError as exc:
            raise DatasetDirError(f"--scheduler {scheduler!r}: cannot connect ({exc})") from None
    try:
        out = prepare_output(spec, out)
        with locked(out):
            try:
                summary = _generate_into(
                    spec, out, workers, client, progress, on_trace, log, t_start
                )
            finally:  # what stopped workers were writing (their pids are gone now)
                remove_stale_temporaries(out)
    finally:
        if client is not None:
            client.close()
    summary.scheduler = scheduler
    return summary


def default_workers() -> int:
    """Local workers when none are asked for: one per core this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _generate_into(spec, out, workers, client, progress, on_trace, log, t_start) -> Summary:
    ctx = spec.context
    metadata = part_metadata(spec)
    remove_stale_temporaries(out)
    done = verified_parts(out, done_trace_ids(out), log)
    local = client is None
    # the forkserver's imports overlap the design and the parent's kernel compilation
    mp = _process_context() if local and workers and len(done) < spec.n_traces else None
    tasks = [t for t in design_traces(spec) if t.trace_id not in done]
    if local:
        workers = min(workers, len(tasks)) if workers else 0
    warm_s = warm_up(ctx, imports=local and not workers) if tasks else 0.0  # compile first
    stop_now()  # a Ctrl-C that an import's callback swallowed during the start-up stops here
    if local:
        cores = max(workers, 1)
        results = _local_results(ctx, tasks, workers, out, metadata, mp)
    else:
        cores = sum(client.nthreads().values())
        results = _dask_results(ctx, tasks, client, out, metadata)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=spec.n_traces, initial=len(done), unit="trace", desc="generate")
    generated = failed = 0
    cpu = 0.0
    try:
        for rec in results:  # each one's part file is written
            stop_now()
            generated += 1
            failed += rec["status"] != STATUS_OK
            cpu += rec["cpu_s"]
            if on_trace is not None:
                on_trace(labels(rec))
            if bar is not None:
                bar.update(1)
                if failed:
                    bar.set_postfix(failed=failed)
    finally:
        if bar is not None:
            bar.close()
    manifest = write_manifest(spec, out)
    wall = time.perf_counter() - t_start
    return Summary(
        out=str(out),
        n_traces=spec.n_traces,
        already_done=len(done),
        generated=generated,
        failed_now=failed,
        failed_total=len(manifest["failed"]),
        wall_s=wall,
        warm_up_s=warm_s,
        cores=cores,
        cpu_s=cpu,
    )


def kept(out: str | Path, spec: Spec) -> str:
    """What a stopped job leaves in ``out``: the traces written, and how to go on."""
    if not Path(out).is_dir():
        return "nothing written"
    try:
        done = len(done_trace_ids(out))
    except OSError:
        done = 0
    return (
        f"{done} of {spec.n_traces} traces are written and kept: rerun the same command to resume"
    )


def stop_reason(exc: Exception) -> tuple[bool, str]:
    """Whether a rerun can finish a job stopped by ``exc`` (the disk, the file system, a worker
    process, the cluster; not a bug), and the reason in a few words."""
    from concurrent.futures import BrokenExecutor

    if isinstance(exc, OSError):
        return True, exc.strerror or str(exc) or type(exc).__name__
    if isinstance(exc, BrokenExecutor):
        return True, "a worker process died"
    if type(exc).__name__ in ("KilledWorker", "CancelledError", "CommClosedError"):
        return True, f"the cluster failed: {type(exc).__name__}: {exc}"
    return False, f"unexpected {type(exc).__name__}: {exc}"
