"""Benchmark of ``signatelec generate``: traces per core-minute and the 1 -> 2 worker speed-up.

    python pipelines/dataset_bench.py [--out docs/dataset_bench] [--paper-traces 96]
                                      [--fast-traces 480] [--repeat 1] [--priority -10]

Two cases, each a Latin hypercube over F_r = 0.1-0.4 C_r and clearance -10 to +20 um at
500 rad/s, with the seed's set-up (7 ms) and a 50 ms recorded window (plus the measurement
model's 2 x 2 ms filter guards), 10 kHz output with noise, drift, offset and quantisation:

- ``paper``: the paper's settings (DEM, velocity Verlet, dt = 1e-7 s, every seed effect);
- ``fast``: the ``fast`` fidelity preset (cage balls 80x heavier, symplectic Euler, dt at 0.95
  of the stability limit).

Each case runs with 1 and then 2 local worker processes, every run in a fresh Python process
(as the CLI would: its own forkserver, imports and kernel load from the warm on-disk cache;
compilation is not measured), into an empty directory. Reported per run: wall time from the
call of :func:`signatelec.data.generate` to its return (start-up included), the steady
throughput between the first and the last trace written (start-up excluded), the CPU time of
the run's process tree, and what the rest of the machine did meanwhile (busy CPU from
/proc/stat minus our tree's, and the load average), since other jobs on the same 2 cores make
the speed-up look worse than it is (``--priority`` lifts each run's session above them).

Writes ``dataset_bench.json`` and ``dataset_bench.md`` (a table) into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

SPEC = """
[dataset]
name = "bench-{case}"
seed = 12345
fidelity = "{fidelity}"
duration_s = 0.05
settle_s = 0.0

[[design]]
kind = "latin_hypercube"
n_traces = {n}
factors.radial_load_fraction = {{min = 0.1, max = 0.4}}
factors.clearance_m = {{min = -10e-6, max = 20e-6}}
factors.omega_rad_s = {{value = 500.0}}

[measurement]
sample_rate_hz = 10000.0
noise_fraction = [0.001, 0.01]
drift_fraction = [0.0, 0.002]
offset_ohm = [-2e-4, 2e-4]
quantisation_ohm = 1e-7
"""

CASES = {"paper": "dem", "fast": "fast"}


def _busy_cpu_s() -> float:
    """Busy CPU time of the whole machine since boot, s (/proc/stat: all but idle, iowait)."""
    with open("/proc/stat") as fh:
        fields = [int(x) for x in fh.readline().split()[1:]]
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)
    return (sum(fields[:8]) - idle) / os.sysconf("SC_CLK_TCK")


def run_one(case: str, workers: int, n: int, out: str) -> dict:
    """In a child process: generate the case and report its timings (JSON on stdout)."""
    import tomllib

    from signatelec.data import generate, spec_from_dict

    spec = spec_from_dict(
        tomllib.loads(SPEC.format(case=case, fidelity=CASES[case], n=n)), f"<bench {case}>"
    )
    stamps: list[float] = []
    start = time.time()
    t0 = time.perf_counter()
    summary = generate(spec, out, workers=workers, on_trace=lambda r: stamps.append(time.time()))
    wall = time.perf_counter() - t0
    try:  # reap the forkserver, so the workers' CPU time is counted in this process's children
        import multiprocessing.forkserver as fs

        fs._forkserver._stop()
    except Exception:  # noqa: BLE001
        pass
    steady = (len(stamps) - 1) / (stamps[-1] - stamps[0]) if len(stamps) > 1 else float("nan")
    return {
        "wall_s": wall,
        "warm_up_s": summary.warm_up_s,
        "trace_cpu_s": summary.cpu_s,
        "failed": summary.failed_now,
        "steady_traces_per_s": steady,
        "first_trace_after_s": stamps[0] - start if stamps else None,
    }


def measure(case: str, workers: int, n: int, priority: int = 0) -> dict:
    """One run in a fresh process (and session); ``priority``: the autogroup nice value of that
    session (Linux schedules sessions against each other first, so a plain nice does not lift
    a run above other sessions' work; negative values need CAP_SYS_NICE)."""
    with tempfile.TemporaryDirectory(prefix="signatelec-bench-") as tmp:
        busy0, load0 = _busy_cpu_s(), os.getloadavg()
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.Popen(
            [sys.executable, __file__, "--one", case, str(workers), str(n), f"{tmp}/ds"],
            stdout=subprocess.PIPE,
            text=True,
            start_new_session=True,
        )
        if priority:
            Path(f"/proc/{proc.pid}/autogroup").write_text(str(priority))
        stdout, _ = proc.communicate()
        if proc.returncode:
            raise RuntimeError(f"benchmark run {case}/{workers} failed ({proc.returncode})")
        ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        busy1, load1 = _busy_cpu_s(), os.getloadavg()
    row = json.loads(stdout.strip().splitlines()[-1])
    ours = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    wall = row["wall_s"]
    row.update(
        case=case,
        fidelity=CASES[case],
        workers=workers,
        traces=n,
        our_cpu_s=ours,
        machine_busy_cpu_s=busy1 - busy0,
        others_cpu_s=max(0.0, (busy1 - busy0) - ours),
        loadavg_before=load0[0],
        loadavg_after=load1[0],
        traces_per_core_minute=60.0 * n / (wall * workers),
        steady_traces_per_core_minute=60.0 * row["steady_traces_per_s"] / workers,
        cpu_s_per_trace=row["trace_cpu_s"] / n,
    )
    return row


def format_table(report: dict) -> str:
    lines = [
        f"signatelec {report['version']}, {report['machine']['cpus']} CPUs, run priority "
        f"(autogroup nice) {report['priority']}; 'others' CPU' is what the rest of the machine "
        "used during the run.",
        "",
        "| case | workers | traces | wall s | traces/core-min | steady traces/core-min | "
        "CPU s/trace | others' CPU s (of 2 x wall) | load avg |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in report["runs"]:
        lines.append(
            f"| {r['case']} ({r['fidelity']}) | {r['workers']} | {r['traces']} | "
            f"{r['wall_s']:.1f} | {r['traces_per_core_minute']:.1f} | "
            f"{r['steady_traces_per_core_minute']:.1f} | {r['cpu_s_per_trace']:.3f} | "
            f"{r['others_cpu_s']:.1f} (of {2 * r['wall_s']:.1f}) | "
            f"{r['loadavg_before']:.2f} -> {r['loadavg_after']:.2f} |"
        )
    lines += [
        "",
        "| case | speed-up 1 -> 2 workers (wall) | speed-up (steady) |",
        "| --- | --- | --- |",
    ]
    for case, s in report["speedup"].items():
        lines.append(f"| {case} | {s['wall']:.2f}x | {s['steady']:.2f}x |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/dataset_bench")
    parser.add_argument("--paper-traces", type=int, default=96)
    parser.add_argument("--fast-traces", type=int, default=480)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument(
        "--priority",
        type=int,
        default=0,
        help="autogroup nice of each run's session (e.g. -10 on a machine others share)",
    )
    parser.add_argument("--one", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        case, workers, n, out = args.one
        print(json.dumps(run_one(case, int(workers), int(n), out)))
        return

    import tomllib

    from signatelec import __version__
    from signatelec.data import spec_from_dict, warm_up

    for case, fidelity in CASES.items():  # compile the kernels now: not part of any run
        spec = spec_from_dict(tomllib.loads(SPEC.format(case=case, fidelity=fidelity, n=1)))
        warm_up(spec.context)
    counts = {"paper": args.paper_traces, "fast": args.fast_traces}
    runs = []
    for _ in range(args.repeat):
        for case in CASES:
            for workers in (1, 2):
                row = measure(case, workers, counts[case], args.priority)
                print(
                    f"{case:5s} {workers} worker(s): {row['wall_s']:.1f} s, "
                    f"{row['traces_per_core_minute']:.1f} traces/core-min, others' CPU "
                    f"{row['others_cpu_s']:.1f} s, load {row['loadavg_before']:.2f}",
                    flush=True,
                )
                runs.append(row)
    speedup = {}
    for case in CASES:
        one = [r for r in runs if r["case"] == case and r["workers"] == 1]
        two = [r for r in runs if r["case"] == case and r["workers"] == 2]
        speedup[case] = {
            "wall": min(r["wall_s"] for r in one) / min(r["wall_s"] for r in two),
            "steady": max(r["steady_traces_per_s"] for r in two)
            / max(r["steady_traces_per_s"] for r in one),
        }
    report = {
        "version": __version__,
        "priority": args.priority,
        "machine": {
            "cpus": os.cpu_count(),
            "affinity": len(os.sched_getaffinity(0)),
            "platform": platform.platform(),
            "python": platform.python_version(),
        },
        "spec": textwrap.dedent(SPEC).strip(),
        "runs": runs,
        "speedup": speedup,
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    table = format_table(report)
    for name, text in (
        ("dataset_bench.json", json.dumps(report, indent=2)),
        ("dataset_bench.md", table + "\n"),
    ):
        tmp = out / f".{name}.tmp"
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, out / name)
    print(table)
    print(f"wrote {out}/dataset_bench.json, {out}/dataset_bench.md")


if __name__ == "__main__":
    main()
