"""One trace: its scene simulated at the spec's fidelity, then measured.

:func:`run_trace` gives a record (a dict of the label columns of ``datasets/README.md`` and the
two signals); a scene the simulator refuses, a divergence, an unreachable target epsilon or a
signal that cannot be measured give ``status = "failed"`` and the error, never an exception, so
a job goes on. :func:`warm_up` compiles (or loads) the kernels before the first trace.
"""

from __future__ import annotations

import contextlib
import math
import time
import warnings
from typing import Any

import numpy as np

from signatelec.config.constraints import Checker
from signatelec.config.scene import Scene, SceneError
from signatelec.data.design import (
    TraceTask,
    condition_labels,
    condition_scene,
    operating_point,
    trace_rng,
)
from signatelec.data.spec import Spec, SpecError, TraceContext
from signatelec.measurement.model import MeasurementError, MeasurementModel
from signatelec.physics.regimes import regime_of

STATUS_OK, STATUS_FAILED = "ok", "failed"
#: The measured and the clean trace's columns of each signal a spec may measure
#: (``dataset.signal``); the rest of a record are labels.
TRACE_COLUMNS = {
    "resistance_ohm": ("resistance_ohm", "resistance_clean_ohm"),
    "capacitance_f": ("capacitance_f", "capacitance_clean_f"),
    "impedance_ohm": ("impedance_ohm", "impedance_clean_ohm"),
}
SIGNALS = tuple(c for pair in TRACE_COLUMNS.values() for c in pair)


class EpsilonError(ValueError):
    """No clearance gives the target epsilon at the trace's load and speed."""


def labels(rec: dict) -> dict:
    """A record without its signals."""
    return {k: v for k, v in rec.items() if k not in SIGNALS}


def warm_up(ctx: TraceContext, *, imports: bool = True) -> float:
    """Compile (or load) the kernels the traces need by a tiny simulation of each effect set
    (the set-up phases plus a few recorded instants of the base scene at the spec's fidelity);
    with ``imports``, also import what a trace imports on first use (scipy.signal, the
    quasi-static solver of a target epsilon) so no trace pays for it.

    The kernel (signatelec.engines.dem.spec.KernelSpec) depends on the effects, the energy
    output, the bearing's friction and the fidelity's integrator, which every trace of a spec
    shares. Returns the seconds spent.
    """
    from signatelec.engines.fidelity import apply_fidelity
    from signatelec.engines.simulate import simulate

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = apply_fidelity(ctx.scene, ctx.fidelity)
        dt = scene.numerics.dt_s
        rate = min(1.0 / dt, 4.0 * ctx.measurement.sample_rate_hz)
        tiny = scene.with_overrides(
            duration_s=scene.setup_time_s + 40.0 / rate, sample_rate_hz=rate
        )
        result = simulate(tiny)
        if batched(ctx):  # and the ensemble kernel the traces run in
            from signatelec.engines.dem.batch import simulate_batch

            simulate_batch([tiny])
        if imports:
            sig = result.signals.tail(40)
            model = MeasurementModel(sample_rate_hz=rate / 4.0, anti_alias_order=2)
            t = sig["time_s"].to_numpy()
            with contextlib.suppress(MeasurementError):
                model.clean(t, sig["resistance_ohm"].to_numpy(), t[0], 8)
            if ctx.needs_epsilon:
                import signatelec.physics.quasistatic  # noqa: F401  (the clearance of an epsilon)
    return time.perf_counter() - t0


def trace_scene(ctx: TraceContext, scene: Scene) -> tuple[Scene, float, int]:
    """The scene a trace simulates from its operating point's ``scene``: the fidelity's time
    step, the record rate of the measurement and a duration covering the set-up, the settling,
    the window and its guards. Also the window's first instant ``t0_s`` and its sample count."""
    from signatelec.engines.fidelity import apply_fidelity

    m = ctx.measurement
    # the measurement resamples the records at its own rate, so the step stays the preset's
    # (simulation_rate_hz is the rate recorded)
    scene = apply_fidelity(scene, ctx.fidelity, record_grid=False)
    dt = scene.numerics.dt_s
    n = int(round(ctx.duration_s * m.sample_rate_hz))
    t0 = scene.setup_time_s + ctx.settle_s + m.guard_s
    end = t0 + (n - 1) / m.sample_rate_hz + m.guard_s
    scene = scene.with_overrides(duration_s=end + 2.0 * dt, sample_rate_hz=m.simulation_rate_hz(dt))
    return scene, t0, n


def check_budget(spec: Spec, *, concurrent: int | None = 1) -> None:
    """Refuse (:class:`SpecError`) a spec whose traces would exceed the run limits of
    :mod:`signatelec.engines.budget` (steps, recorded instants) or, ``concurrent`` at once, this
    machine's available memory (None: the traces run elsewhere, on a cluster). The base
    scene's trace stands for all: every trace shares its window and record rate (the time step
    of the fast and balanced presets varies a little with the operating point)."""
    from signatelec.engines import budget

    ctx = spec.context
    m = ctx.measurement
    check = Checker(SpecError, f"spec {spec.path!r}")
    try:
        scene, _, _ = trace_scene(ctx, ctx.scene)
    except SceneError:
        return  # each trace fails on its own, with the reason
    need = budget.run_budget(scene)
    rate = f"measurement.sample_rate_hz = {m.sample_rate_hz:g}"
    if need.n_steps > budget.MAX_STEPS:
        check.fail(
            "dataset.duration_s",
            ctx.duration_s,
            f"at fidelity {ctx.fidelity} (dt = {scene.numerics.dt_s:g} s) a trace, with its "
            f"set-up and guards, takes {need.n_steps:.3g} steps, more than the "
            f"{budget.MAX_STEPS:.0e} a run may take; shorten dataset.duration_s or settle_s",
        )
    if need.n_instants > budget.MAX_RECORDED_INSTANTS:
        check.fail(
            "dataset.duration_s",
            ctx.duration_s,
            f"at {rate} (x oversample {m.oversample}) a trace records {need.n_instants:.3g} "
            f"instants, more than the {budget.MAX_RECORDED_INSTANTS:.0e} a run may record; "
            "lower measurement.sample_rate_hz or oversample, or shorten dataset.duration_s",
        )
    available = budget.available_memory_bytes() if concurrent else None
    if available is not None and need.memory_bytes * concurrent > available:
        at_once = f" x {concurrent} workers at once" if concurrent > 1 else ""
        check.fail(
            "dataset.duration_s",
            ctx.duration_s,
            f"at {rate} (x oversample {m.oversample}) a trace records {need.n_instants:.3g} "
            f"instants, ~{budget.format_bytes(need.memory_bytes)}{at_once}, more than this "
            f"machine's {budget.format_bytes(available)} available; lower "
            "measurement.sample_rate_hz or oversample, shorten dataset.duration_s, or use "
            "fewer workers",
        )


def _new_record(ctx: TraceContext, task: TraceTask) -> dict[str, Any]:
    """The record before the run: design labels, NaN measured labels, empty signals."""
    point = operating_point(task, ctx.scene)
    b, m = ctx.scene.bearing, ctx.measurement
    nan = math.nan
    return {
        "trace_id": task.trace_id,
        "design": task.block,
        "seed": ctx.root_seed,
        "status": STATUS_OK,
        "error": "",
        "warnings": "",
        "radial_load_n": point.radial_load_n,
        "radial_load_fraction": point.radial_load_n / b.dynamic_load_rating_n,
        "clearance_m": point.clearance_m,
        "epsilon": nan,
        "epsilon_target": point.epsilon_target,
        "omega_rad_s": point.omega_rad_s,
        "initial_ball_angle_rad": point.initial_ball_angle_rad,
        "fidelity": ctx.fidelity,
        "dt_s": nan,
        "integrator": "",
        "simulation_rate_hz": nan,
        "sample_rate_hz": m.sample_rate_hz,
        "duration_s": ctx.duration_s,
        "t0_s": nan,
        "n_samples": 0,
        "noise_fraction": nan,
        "drift_fraction": nan,
        "offset_ohm": nan,
        "quantisation_ohm": m.quantisation_ohm,
        "resistance_mean_ohm": nan,
        "delta_r_m": nan,
        "max_ball_load_n": nan,
        "ball_pass_frequency_hz": b.ball_pass_frequency_hz(point.omega_rad_s),
        "cpu_s": nan,
        **_design_condition(ctx, task),
        **dict.fromkeys(SIGNALS, np.zeros(0)),
        "signal": ctx.signal,
        # the regime from the design, kept when the clearance cannot be had
        "regime": point.design_regime,
    }


def _design_condition(ctx: TraceContext, task: TraceTask) -> dict:
    """The condition labels the design asks for (kept when the scene cannot be had)."""
    try:
        return condition_labels(condition_scene(task, ctx.scene))
    except SceneError:
        f = task.factors
        labels = condition_labels(ctx.scene)
        labels["condition"] = str(f.get("condition", labels["condition"]))
        return labels


def _solve_clearance(ctx: TraceContext, rec: dict) -> float:
    """The clearance of the record's target epsilon (signatelec.physics.quasistatic)."""
    from signatelec.physics.quasistatic import clearance_for_epsilon

    try:
        return clearance_for_epsilon(
            ctx.scene.bearing, rec["radial_load_n"], rec["omega_rad_s"], rec["epsilon_target"]
        )
    except ValueError as exc:
        raise EpsilonError(str(exc)) from None


def _trace_scene(ctx: TraceContext, task: TraceTask, rec: dict) -> tuple[Scene, float, int]:
    """The scene of the record's trace (its clearance solved from a target epsilon, the
    condition its factors ask for), with the record's simulation and condition labels filled
    in; its window's first instant and sample count."""
    if not math.isnan(rec["epsilon_target"]):
        rec["clearance_m"] = _solve_clearance(ctx, rec)
        rec["regime"] = regime_of(rec["clearance_m"])
    scene = ctx.scene.with_overrides(
        radial_load_n=rec["radial_load_n"],
        clearance_m=rec["clearance_m"],
        omega_rad_s=rec["omega_rad_s"],
        initial_ball_angle_rad=rec["initial_ball_angle_rad"],
    )
    scene = condition_scene(task, scene)
    rec.update(condition_labels(scene))
    scene, t0, n = trace_scene(ctx, scene)
    dt = scene.numerics.dt_s
    rec["dt_s"], rec["integrator"] = dt, scene.numerics.integrator
    rec["simulation_rate_hz"] = 1.0 / (scene.record_every * dt)
    rec["t0_s"], rec["n_samples"] = t0, n
    return scene, t0, n


def _measure(ctx: TraceContext, task: TraceTask, rec: dict, result, t0: float, n: int) -> None:
    """The record's measured labels and signals from the simulation ``result``."""
    m = ctx.measurement
    sig = result.signals
    keep = sig["time_s"].to_numpy() >= t0 - m.guard_s - 1e-12
    clean = m.clean(sig["time_s"].to_numpy()[keep], sig[ctx.signal].to_numpy()[keep], t0, n)
    t = sig["time_s"].to_numpy()
    window = sig[(t >= t0 - 1e-12) & (t <= t0 + (n - 1) / m.sample_rate_hz + 1e-12)]
    rec["epsilon"] = float(window["epsilon"].mean())
    rec["delta_r_m"] = float(window["delta_r_m"].mean())
    rec["max_ball_load_n"] = float(window["max_ball_load_n"].mean())
    rng = trace_rng(ctx.root_seed, task.trace_id, 1)
    draw = m.draw(rng)
    rec["noise_fraction"] = draw.noise_fraction
    rec["drift_fraction"] = draw.drift_fraction
    rec["offset_ohm"] = draw.offset_ohm
    measured, clean_column = TRACE_COLUMNS[ctx.signal]
    rec[clean_column] = clean
    rec["resistance_mean_ohm"] = float(window["resistance_ohm"].mean())
    if ctx.signal == "resistance_ohm":
        rec["resistance_mean_ohm"] = float(np.mean(clean))
    rec[measured] = m.measure(clean, draw, rng)


#: What makes a trace fail (status "failed" and the error) rather than stop the job.
_TRACE_ERRORS = (SceneError, EpsilonError, MeasurementError)


def _failed(rec: dict, exc: Exception) -> None:
    rec["status"] = STATUS_FAILED
    rec["error"] = f"{type(exc).__name__}: {exc}"
    rec.update(dict.fromkeys(SIGNALS, np.zeros(0)))


def _key(w) -> str:
    return f"{w.category.__name__}: {w.message}"


def _warnings(caught) -> str:
    return " | ".join(dict.fromkeys(_key(w) for w in caught))


def run_trace(ctx: TraceContext, task: TraceTask) -> dict:
    """Simulate one trace and measure it: a record of labels and signals (never raises for a
    scene that is not allowed, a divergence or an unreachable epsilon: those give status
    "failed" and the error)."""
    from signatelec.engines.results import DivergenceError
    from signatelec.engines.simulate import simulate

    cpu0 = time.thread_time()
    rec = _new_record(ctx, task)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene, t0, n = _trace_scene(ctx, task, rec)
            _measure(ctx, task, rec, simulate(scene), t0, n)
        rec["warnings"] = _warnings(caught)
    except (*_TRACE_ERRORS, DivergenceError) as exc:
        _failed(rec, exc)
    rec["cpu_s"] = time.thread_time() - cpu0
    return rec


def batched(ctx: TraceContext) -> bool:
    """Whether the spec's traces run through the ensemble kernel (:func:`run_traces`): DEM
    traces (the ensemble kernel carries every effect of the single-scene one)."""
    from signatelec.engines.fidelity import apply_fidelity

    try:
        scene = apply_fidelity(ctx.scene, ctx.fidelity)
    except SceneError:
        return False
    return scene.numerics.fidelity == "dem"


def run_traces(ctx: TraceContext, tasks: list[TraceTask]) -> list[dict]:
    """:func:`run_trace` of each task, their simulations run together through the ensemble
    kernel (:func:`signatelec.engines.dem.batch.simulate_batch`): the same records, the CPU time
    of the batch shared among its traces by their steps."""
    from signatelec.engines.dem.batch import LANES, simulate_batch
    from signatelec.engines.results import SimulationResult
    from signatelec.engines.simulate import simulate

    cpu0 = time.thread_time()
    recs = [_new_record(ctx, task) for task in tasks]
    ready = []  # (index, scene, t0, n) of the traces that reach the simulation
    caught: dict[int, list] = {}
    for i, rec in enumerate(recs):
        try:
            with warnings.catch_warnings(record=True) as caught[i]:
                warnings.simplefilter("always")
                ready.append((i, *_trace_scene(ctx, tasks[i], rec)))
        except _TRACE_ERRORS as exc:
            _failed(rec, exc)
    with warnings.catch_warnings(record=True) as shared:
        warnings.simplefilter("always")
        try:
            results = simulate_batch([r[1] for r in ready], lanes=LANES, return_exceptions=True)
        except SceneError:  # a scene the batch refuses: each on its own, with its own error
            results = [None] * len(ready)
    # what the batch warned beside its scenes' own warnings (a kernel cache, say) is every
    # trace's; a scene's own warnings are its trace's alone
    own_keys = {_key(w) for r in results if isinstance(r, SimulationResult) for w in r.warnings}
    batch_wide = [w for w in shared if _key(w) not in own_keys]
    for (i, scene, t0, n), result in zip(ready, results, strict=True):
        rec = recs[i]
        try:
            own = result.warnings if isinstance(result, SimulationResult) else []
            with warnings.catch_warnings(record=True) as more:
                warnings.simplefilter("always")
                if not isinstance(result, SimulationResult):
                    # alone, as run_trace: its own error, a divergence with its measured cure
                    result = simulate(scene)
                _measure(ctx, tasks[i], rec, result, t0, n)
            rec["warnings"] = _warnings([*caught[i], *batch_wide, *own, *more])
        except Exception as exc:
            if not isinstance(exc, (*_TRACE_ERRORS, RuntimeError)):
                raise
            _failed(rec, exc)
    steps = [r[1].n_steps for r in ready]
    cpu = time.thread_time() - cpu0
    for rec in recs:
        rec["cpu_s"] = cpu / len(recs)
    for (i, *_), n_steps in zip(ready, steps, strict=True):
        recs[i]["cpu_s"] = cpu * n_steps / max(sum(steps), 1)
    return recs
