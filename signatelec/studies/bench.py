"""``signatelec bench``: what each option costs, in microseconds per time step.

The cases derive from the scene options (:data:`signatelec.config.options.OPTIONS`): the seed
scene, then each option that changes the kernel or the outputs set to each of its other values
(``cage=none``, ``contact_law=linear``, ``energy=true``, ``integrator=euler``, ...), then
``minimal``: every physics option at its null model, no electrical output. Every kernel is
compiled apart, its compile time reported apart from the run time. Run with a fresh kernel cache
(the default) so the compile time is a real compile, not a cache load.
"""

from __future__ import annotations

import os
import platform
import tempfile

from signatelec._version import __version__
from signatelec.config.options import OPTIONS
from signatelec.config.scene import Scene, SceneError


def machine() -> dict:
    """The host the figures were measured on: its processor (the model name Linux reports,
    else the platform's), whether it has AVX-512 (None where unknown), its CPUs and Python:
    the same code's figures per core differ by up to 2x between hosts (docs/bench)."""
    name, avx512 = platform.processor() or platform.machine(), None
    try:
        with open("/proc/cpuinfo") as f:
            info = f.read()
    except OSError:
        info = ""
    for line in info.splitlines():
        key, _, value = line.partition(":")
        if key.strip() == "model name" and value.strip():
            name = value.strip()
        elif key.strip() == "flags":
            avx512 = "avx512f" in value.split()
    return {
        "processor": name,
        "avx512": avx512,
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
    }


def host_in_words() -> str:
    """The host of :func:`machine` in words: processor, AVX-512, CPUs."""
    m = machine()
    avx = {True: "with AVX-512", False: "without AVX-512", None: "AVX-512 unknown"}[m["avx512"]]
    return f"{m['processor']}, {avx}, {m['cpus']} CPUs"


def _cases() -> dict[str, dict]:
    """The seed scene; every option that changes the kernel or the outputs (config.options.OPTIONS)
    at each of its other values, one at a time; then every physics option at its null model."""
    cases: dict[str, dict] = {"seed": {}}
    for option in OPTIONS:
        if option.kernel or option.section == "outputs":
            for value in option.values:
                if value != option.default:
                    name = f"{option.name}={str(value).lower()}"
                    cases[name] = {option.name: value}
    cases["minimal"] = {o.name: o.off for o in OPTIONS if o.off == "none"}
    cases["minimal"]["electrical"] = False
    return cases


#: name -> what changes from the seed scene (flat Scene.with_overrides keys)
CASES: dict[str, dict] = _cases()


def bench_scene(changes: dict, duration_s: float) -> Scene:
    return Scene().with_overrides(duration_s=duration_s, **changes)


def select_cases(names: tuple[str, ...] = ()) -> dict[str, dict]:
    """The cases named (all when none is); SceneError names an unknown one."""
    for name in names:
        if name not in CASES:
            raise SceneError(f"--case {name!r}: unknown; allowed: {', '.join(CASES)}")
    return {n: c for n, c in CASES.items() if not names or n in names}


def run_bench(
    duration_s: float = 0.03,
    fresh_cache: bool = True,
    repeat: int = 7,
    cases: tuple[str, ...] = (),
) -> dict:
    """Run each case (all by default) ``repeat`` times: compile time from the first run, the step
    cost from the fastest (the others carry cold caches or another process's load; on a shared
    2-core host the same kernel measured 0.47-0.75 us/step from one run to the next)."""
    from signatelec.engines.simulate import simulate

    selected = select_cases(cases)
    if fresh_cache:
        os.environ["SIGNATELEC_CACHE_DIR"] = tempfile.mkdtemp(prefix="signatelec-bench-")
    rows = []
    for name, changes in selected.items():
        scene = bench_scene(changes, duration_s)
        runs = [simulate(scene).timings for _ in range(max(1, repeat))]
        t = dict(min(runs, key=lambda r: r["cpu_us_per_step"]))
        t["compile_s"] = runs[0]["compile_s"]
        rows.append(
            {
                "case": name,
                "changes": changes,
                "kernel": t["kernel"],
                "compile_s": t["compile_s"],
                "run_s": t["run_s"],
                "n_steps": t["n_steps"],
                "us_per_step": t["us_per_step"],
                "cpu_us_per_step": t["cpu_us_per_step"],
                "electrical_us_per_instant": t.get("electrical_us_per_instant"),
                "bearing_time_s": duration_s,
                "repeat": len(runs),
            }
        )
    # CPU time: on a shared host the wall time also counts the other processes
    seed = rows[0]["cpu_us_per_step"] if "seed" in selected else None
    for row in rows:
        row["relative_cost"] = row["cpu_us_per_step"] / seed if seed else None
    return {
        "signatelec": __version__,
        "machine": machine(),
        "dt_s": Scene().numerics.dt_s,
        "rows": rows,
    }


def format_table(report: dict) -> str:
    head = (
        f"{'case':24s} {'us/step':>8s} {'cpu us':>7s} {'rel':>5s} {'run s':>7s} "
        f"{'compile s':>9s} {'elec us/inst':>12s}"
    )
    lines = [head, "-" * len(head)]
    for r in report["rows"]:
        el = r["electrical_us_per_instant"]
        elec = "-" if el is None else f"{el:.1f}"
        rel = "-" if r["relative_cost"] is None else f"{r['relative_cost']:.2f}"
        lines.append(
            f"{r['case']:24s} {r['us_per_step']:8.3f} {r['cpu_us_per_step']:7.3f} "
            f"{rel:>5s} {r['run_s']:7.3f} {r['compile_s']:9.2f} {elec:>12s}"
        )
    return "\n".join(lines)


def tier_marginal_cost(repeat: int = 7, sample_rate_hz: float = 20000.0) -> dict:
    """Marginal CPU per simulated second of the DEM and of the quasi-static tier on the seed's
    scene, in this process, interleaved: each engine run at two durations (the DEM 5 and 25 ms of
    steady running, the tier 2 and 10 s, whose instants map onto one ball-pass period), the CPU
    difference over the duration difference; the best of ``repeat`` pairs, as for the cases (the
    others carry another process's load), and the median. User and system CPU are given apart
    (the kernel samples ticks to tell them: noisy over runs of 10-30 ms). The tier writes
    ~1.2 kB of tables per instant, over the memory of the tables freed before it
    (:mod:`signatelec.engines.quasistatic.buffers`): fresh pages cost it more. A first run of each
    engine at each duration, outside the figures, compiles or loads the kernels and grows the
    process to the long runs' memory once (the host's first 250 MB for the tier's 10 s: about
    0.4 s of system time here, once per process, not per simulated second)."""
    import resource

    from signatelec.engines.simulate import simulate

    seed = Scene().with_overrides(sample_rate_hz=sample_rate_hz)
    setup = seed.setup_time_s
    quasistatic = seed.with_overrides(fidelity="quasistatic")
    spans = {
        "dem": (seed, setup + 0.005, setup + 0.025),
        "quasistatic": (quasistatic, setup + 2.0, setup + 10.0),
    }

    def cpu_s(scene: Scene, duration_s: float) -> tuple[float, float]:
        scene = scene.with_overrides(duration_s=duration_s)
        before = resource.getrusage(resource.RUSAGE_SELF)
        simulate(scene)
        after = resource.getrusage(resource.RUSAGE_SELF)
        return after.ru_utime - before.ru_utime, after.ru_stime - before.ru_stime

    for scene, short, long in spans.values():
        cpu_s(scene, short)  # compile or load, outside the figures
        cpu_s(scene, long)  # the process's first growth to the long run's memory, likewise
    total: dict[str, list[float]] = {name: [] for name in spans}
    user: dict[str, list[float]] = {name: [] for name in spans}
    for _ in range(max(1, repeat)):
        for name, (scene, short, long) in spans.items():
            (u1, s1), (u2, s2) = cpu_s(scene, short), cpu_s(scene, long)
            total[name].append((u2 + s2 - u1 - s1) / (long - short))
            user[name].append((u2 - u1) / (long - short))
    best = {name: min(v) for name, v in total.items()}
    median = {name: sorted(v)[len(v) // 2] for name, v in total.items()}
    best_user = {name: min(v) for name, v in user.items()}
    return {
        "sample_rate_hz": sample_rate_hz,
        "dem_cpu_s_per_simulated_s": best["dem"],
        "quasistatic_cpu_s_per_simulated_s": best["quasistatic"],
        "ratio": best["dem"] / best["quasistatic"],
        "median_ratio": median["dem"] / median["quasistatic"],
        "user_ratio": best_user["dem"] / best_user["quasistatic"],
        "runs": total,
        "user_runs": user,
    }


def startup_cost(repeat: int = 7, out_dir: str | None = None) -> dict:
    """Whole-process cost of ``signatelec simulate`` on the seed's scene, warm (its kernel and
    byte code cached by a first run, not counted): CPU (user + system, of the child process)
    and wall time, and the time to first step the run records
    (``timings["process_to_first_step_s"]``); medians of ``repeat`` runs, and each run's."""
    import json
    import resource
    import statistics
    import subprocess
    import sys
    import time

    import pyarrow.parquet as pq

    from signatelec.io import METADATA_KEY

    work = out_dir or tempfile.mkdtemp(prefix="signatelec-startup-")
    out = os.path.join(work, "seed")
    command = [
        sys.executable,
        "-c",
        "import sys; from signatelec.cli import main; sys.argv[0] = 'signatelec'; main()",
        "simulate",
        "--quiet",
        "--out",
        out,
    ]
    runs: dict[str, list[float]] = {"cpu_s": [], "wall_s": [], "first_step_s": []}
    for attempt in range(max(1, repeat) + 1):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(command, check=True)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if not attempt:
            continue  # compiles or loads the kernel, writes the byte code: not warm
        meta = json.loads(
            pq.read_schema(os.path.join(out, "signals.parquet")).metadata[METADATA_KEY]
        )
        runs["cpu_s"].append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        runs["wall_s"].append(wall)
        runs["first_step_s"].append(meta["timings"]["process_to_first_step_s"])
    report = {f"median_{k}": statistics.median(v) for k, v in runs.items()}
    report.update(runs=runs, repeat=len(runs["cpu_s"]), load_average=os.getloadavg())
    return report


#: Batch sizes of the ensemble kernel's bench (``signatelec bench --batch-sizes``).
BATCH_SIZES = (1, 2, 4, 8, 16, 32)


def run_batch_bench(
    sizes: tuple[int, ...] = BATCH_SIZES, duration_s: float = 0.03, rounds: int = 5
) -> list[dict]:
    """CPU microseconds per scene-step of the seed scene through the ensemble kernel
    (:func:`signatelec.engines.dem.batch.simulate_batch`) for each batch size, against the
    single-scene kernel measured in the same rounds, interleaved (single, then each size, in
    every round), so a load on the shared host weighs on both alike: medians of ``rounds``.
    A batch of B < LANES scenes runs in a kernel of B lanes; larger ones in lane groups of
    LANES. The scenes differ in load (0.9-1.1 x the seed's), so no two lanes are the same.
    Each size's compile (or cache load) time is that of its first call, outside the figures."""
    import statistics

    from signatelec.engines.dem.batch import LANES, simulate_batch
    from signatelec.engines.dem.run import simulate_dem

    base = bench_scene({}, duration_s)
    n_steps = base.n_steps
    loads = [base.operating.radial_load_n * (0.9 + 0.2 * i / 31) for i in range(max(sizes))]
    scenes = [base.with_overrides(radial_load_n=f) for f in loads]
    simulate_dem(base)  # compile (or load) first, timed apart
    compile_s = {}
    for size in sizes:
        compile_s[size] = simulate_batch(scenes[:1], lanes=min(size, LANES))[0].timings["compile_s"]
    single, batch = [], {size: [] for size in sizes}
    for _ in range(max(1, rounds)):
        single.append(simulate_dem(base).timings["run_cpu_s"] / n_steps)
        for size in sizes:
            results = simulate_batch(scenes[:size], lanes=min(size, LANES))
            cpu = sum(r.timings["run_cpu_s"] for r in results)
            batch[size].append(cpu / (size * n_steps))
    single_us = 1e6 * statistics.median(single)
    rows = []
    for size in sizes:
        us = 1e6 * statistics.median(batch[size])
        rows.append(
            {
                "batch_size": size,
                "lanes": min(size, LANES),
                "cpu_us_per_scene_step": us,
                "single_cpu_us_per_step": single_us,
                "speed_up": single_us / us,
                "rounds": len(batch[size]),
                "compile_s": compile_s[size],
            }
        )
    return rows


def format_batch_table(rows: list[dict]) -> str:
    head = (
        f"{'batch':>5s} {'lanes':>5s} {'cpu us/scene-step':>17s} {'single':>7s} {'speed-up':>8s} "
        f"{'compile s':>9s}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['batch_size']:5d} {r['lanes']:5d} {r['cpu_us_per_scene_step']:17.3f} "
            f"{r['single_cpu_us_per_step']:7.3f} {r['speed_up']:8.2f} {r['compile_s']:9.2f}"
        )
    return "\n".join(lines)
