"""``signatelec bench``: what each effect costs, in microseconds per time step.

Each case is the seed scene with some effects switched off (or swapped); every case compiles its
own specialised kernel, whose compile time is reported apart from the run time. Run with a fresh
kernel cache (the default) so the compile time is a real compile, not a cache load.
"""

from __future__ import annotations

import os
import platform
import tempfile
from dataclasses import replace

from signatelec._version import __version__
from signatelec.config.scene import Effects, Numerics, Scene

#: (name, what changes from the seed scene)
CASES: tuple[tuple[str, dict], ...] = (
    ("seed (all effects)", {}),
    ("no electrical", {"electrical": False}),
    ("no cage", {"cage": False}),
    ("no friction", {"friction": False}),
    ("no damping", {"damping": False}),
    ("no gravity", {"gravity": False}),
    ("centrifugal compensated", {"centrifugal": False}),
    ("linear law", {"contact_law": "linear"}),
    ("harris law", {"contact_law": "harris"}),
    ("spring tangential", {"tangential": "spring"}),
    ("energy balance on", {"energy": True}),
    (
        "minimal (no cage, friction, gravity, electrical)",
        {"cage": False, "friction": False, "gravity": False, "electrical": False},
    ),
    ("symplectic Euler", {"integrator": "euler"}),
)


def bench_scene(changes: dict, duration_s: float) -> Scene:
    base = Scene()
    effect_changes = {k: v for k, v in changes.items() if k in Effects.__dataclass_fields__}
    numeric_changes = {k: v for k, v in changes.items() if k in Numerics.__dataclass_fields__}
    return replace(
        base,
        effects=replace(base.effects, **effect_changes),
        numerics=replace(base.numerics, duration_s=duration_s, **numeric_changes),
    )


def run_bench(duration_s: float = 0.03, fresh_cache: bool = True, repeat: int = 7) -> dict:
    """Run every case ``repeat`` times: compile time from the first run, the step cost from the
    fastest (the others carry cold caches or another process's load; on a shared 2-core host the
    same kernel measured 0.47-0.75 us/step from one run to the next)."""
    from signatelec.engines.simulate import simulate

    if fresh_cache:
        os.environ["SIGNATELEC_CACHE_DIR"] = tempfile.mkdtemp(prefix="signatelec-bench-")
    rows = []
    for name, changes in CASES:
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
    seed = rows[0]["us_per_step"]
    for row in rows:
        row["relative_cost"] = row["us_per_step"] / seed
    return {
        "signatelec": __version__,
        "machine": {
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
        },
        "dt_s": Scene().numerics.dt_s,
        "rows": rows,
    }


def format_table(report: dict) -> str:
    head = (
        f"{'case':50s} {'us/step':>8s} {'cpu us':>7s} {'rel':>5s} {'run s':>7s} "
        f"{'compile s':>9s} {'elec us/inst':>12s}"
    )
    lines = [head, "-" * len(head)]
    for r in report["rows"]:
        el = r["electrical_us_per_instant"]
        elec = "-" if el is None else f"{el:.1f}"
        lines.append(
            f"{r['case']:50s} {r['us_per_step']:8.3f} {r['cpu_us_per_step']:7.3f} "
            f"{r['relative_cost']:5.2f} {r['run_s']:7.3f} {r['compile_s']:9.2f} {elec:>12s}"
        )
    return "\n".join(lines)
