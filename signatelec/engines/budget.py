"""What a run will cost, checked before it runs: time steps, recorded instants, memory.

:func:`check_run` refuses (``SceneError``, one line naming the setting to change) a scene whose
run would take more than :data:`MAX_STEPS` time steps, record more than
:data:`MAX_RECORDED_INSTANTS` instants, need more memory than the machine has available, or
record no instant after the set-up; and a DEM scene that no allowed time step can run (its
stability limit below the smallest ``dt_s``) or whose stable steps would exceed the step limit.
A run that diverges names the cure it measured (:func:`signatelec.engines.dem.run.measured_cure`).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from signatelec.config.constraints import DT_MIN_S, Checker
from signatelec.config.scene import Scene, SceneError
from signatelec.engines.results import phase_times
from signatelec.engines.stream import STREAM_BLOCK_INSTANTS

#: Most time steps one DEM run may take: the default dt (1e-7 s) over the longest duration
#: (100 s); about 8 minutes at the kernel's 0.5 us per step.
MAX_STEPS = 1_000_000_000
#: Most instants one run may record (each row of the ball table repeats per ball).
MAX_RECORDED_INSTANTS = 100_000_000
#: Peak memory per recorded instant and ball: the kernel's record arrays, the ball and signal
#: tables and the electrical network at once. Measured on the seed scene (13 balls, all effects,
#: 2e5-9e5 instants: 3.6-5.3 kB per instant, DEM the larger) and rounded up.
BYTES_PER_BALL_INSTANT = 420
BYTES_PER_INSTANT = 256
#: Time one step takes, for the step limit's message (the kernel's, seed scene).
SECONDS_PER_STEP = 0.5e-6


@dataclass(frozen=True)
class RunBudget:
    """What a scene's run implies."""

    n_steps: int
    n_instants: int
    n_steady_instants: int
    memory_bytes: int


def format_bytes(n_bytes: float) -> str:
    """``n_bytes`` in GiB (MiB below 0.1 GiB), three digits."""
    gib = n_bytes / 1024**3
    return f"{gib:.3g} GiB" if gib >= 0.1 else f"{n_bytes / 1024**2:.3g} MiB"


def instant_bytes(n_balls: int) -> int:
    """Peak memory of one recorded instant of a bearing with ``n_balls`` balls, bytes."""
    return BYTES_PER_BALL_INSTANT * n_balls + BYTES_PER_INSTANT


def available_memory_bytes() -> int | None:
    """Memory this process may still take: /proc/meminfo MemAvailable, lowered to the room left
    under a cgroup (v2) memory limit; ``os.sysconf`` elsewhere; None when unknown."""
    available = None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError):
        pass
    if available is None:
        try:
            available = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, AttributeError):
            return None
    cgroup = Path("/sys/fs/cgroup")
    try:
        limit = (cgroup / "memory.max").read_text().strip()
        if limit != "max":
            used = int((cgroup / "memory.current").read_text().strip())
            available = min(available, max(int(limit) - used, 0))
    except (OSError, ValueError):
        pass
    return available


def run_budget(scene: Scene, *, streamed: bool = False) -> RunBudget:
    """Steps, recorded instants (the quasi-static tier records the steady ones only) and peak
    memory of ``scene``'s run; ``streamed``: its tables go to files block by block
    (:mod:`signatelec.engines.stream`), so one block is in memory at a time."""
    nu = scene.numerics
    every = scene.record_every
    dem = nu.fidelity != "quasistatic"
    n_steps = scene.n_steps
    n_rec = n_steps // every
    period = every * nu.dt_s
    setup_end = phase_times(scene)[2]
    # instants k * period, k = 1..n_rec; the steady ones come after the set-up
    last = n_rec * period
    steady = 0 if last <= setup_end else n_rec - min(n_rec, math.floor(setup_end / period))
    instants = n_rec if dem else steady
    held = min(instants, STREAM_BLOCK_INSTANTS) if streamed else instants
    return RunBudget(
        n_steps=n_steps if dem else 0,
        n_instants=instants,
        n_steady_instants=steady,
        memory_bytes=held * instant_bytes(scene.bearing.n_balls),
    )


def check_run(scene: Scene, *, concurrent: int = 1, out_dir: str | Path | None = None) -> RunBudget:
    """The scene's :class:`RunBudget`, or ``SceneError`` when the run cannot or should not start
    (see the module docstring); ``concurrent``: runs that will share the machine's memory;
    ``out_dir``: the run streams its tables there (:func:`run_budget`): one block in memory. A
    disk that fills during the run stops it with nothing written (exit code 75 at the command
    line), as any failed write."""
    streamed = out_dir is not None
    check = Checker(SceneError)
    nu = scene.numerics
    dem = nu.fidelity != "quasistatic"
    if dem:
        _check_steps(check, scene)
    budget = run_budget(scene, streamed=streamed)
    period = scene.record_every * nu.dt_s
    setup_end = phase_times(scene)[2]
    if budget.n_steady_instants == 0:
        floor_hz = 1.0 / (nu.duration_s - setup_end)
        check.fail(
            "numerics.sample_rate_hz",
            nu.sample_rate_hz,
            f"at duration_s = {nu.duration_s:g} s records no instant after the set-up (which "
            f"ends at {setup_end:g} s; one instant every {period:g} s); raise "
            f"numerics.sample_rate_hz above {floor_hz:.4g} Hz or lengthen numerics.duration_s",
        )
    rate = f"{nu.sample_rate_hz:g} Hz"
    if budget.n_instants > MAX_RECORDED_INSTANTS:
        check.fail(
            "numerics.sample_rate_hz",
            nu.sample_rate_hz,
            f"at duration_s = {nu.duration_s:g} s records {budget.n_instants:.3g} instants, "
            f"more than the {MAX_RECORDED_INSTANTS:.0e} a run may record; lower "
            "numerics.sample_rate_hz or numerics.duration_s",
        )
    available = available_memory_bytes()
    need = budget.memory_bytes * concurrent
    if available is not None and need > available:
        runs = f" x {concurrent} runs at once" if concurrent > 1 else ""
        check.fail(
            "numerics.duration_s",
            nu.duration_s,
            f"at sample_rate_hz = {rate}: {budget.n_instants:.3g} recorded instants need "
            f"~{format_bytes(budget.memory_bytes)}{runs}, more than this machine's "
            f"{format_bytes(available)} available; lower numerics.sample_rate_hz or "
            "numerics.duration_s",
        )
    return budget


def _check_steps(check: Checker, scene: Scene) -> None:
    """The step limit, and a stability limit that an allowed dt can meet within it."""
    from signatelec.physics.stability import stability_limit

    nu = scene.numerics
    limit = stability_limit(scene)
    if not limit.dt_limit_s >= DT_MIN_S:
        check.fail(
            "numerics.dt_s",
            nu.dt_s,
            f"no allowed time step runs this scene: its {limit.describe()} is below the smallest "
            f"dt_s, {DT_MIN_S:g} s; the {limit.body}'s contacts are too stiff for its mass "
            "(check the bearing's materials, numerics.linear_stiffness_n_m and the loads)",
        )
    minutes = MAX_STEPS * SECONDS_PER_STEP / 60.0
    stable_steps = nu.duration_s / limit.dt_limit_s
    if stable_steps > MAX_STEPS:
        above = nu.dt_s > limit.dt_limit_s
        where = f"above the {limit.describe()}; at" if above else f"{limit.describe()}: at any"
        check.fail(
            "numerics.dt_s",
            nu.dt_s,
            f"{where} stable dt_s over duration_s = {nu.duration_s:g} s the run needs "
            f"{stable_steps:.3g} steps, more than the {MAX_STEPS:.0e} a run may take "
            f"(~{minutes:.0f} min): shorten numerics.duration_s to at most "
            f"{MAX_STEPS * limit.dt_limit_s:.3g} s",
        )
    if nu.dt_s > limit.dt_limit_s:
        return  # the engine refuses it, naming the stable step
    if scene.n_steps > MAX_STEPS:
        check.fail(
            "numerics.dt_s",
            nu.dt_s,
            f"at duration_s = {nu.duration_s:g} s the run needs {scene.n_steps:.3g} steps, more "
            f"than the {MAX_STEPS:.0e} a run may take (~{minutes:.0f} min at "
            f"{SECONDS_PER_STEP * 1e6:g} us per step); raise numerics.dt_s (stable up to "
            f"{limit.dt_limit_s:.3g} s) or shorten numerics.duration_s",
        )
