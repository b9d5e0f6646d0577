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

from signatelec.config.scene import SceneError
from signatelec.data.design import TraceTask, operating_point, trace_rng
from signatelec.data.spec import TraceContext
from signatelec.measurement.model import MeasurementError, MeasurementModel
from signatelec.physics.regimes import regime_of

STATUS_OK, STATUS_FAILED = "ok", "failed"
#: The record's signal columns (the rest are labels).
SIGNALS = ("resistance_ohm", "resistance_clean_ohm")


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
        if imports:
            sig = result.signals.tail(40)
            model = MeasurementModel(sample_rate_hz=rate / 4.0, anti_alias_order=2)
            t = sig["time_s"].to_numpy()
            with contextlib.suppress(MeasurementError):
                model.clean(t, sig["resistance_ohm"].to_numpy(), t[0], 8)
            if ctx.needs_epsilon:
                import signatelec.physics.quasistatic  # noqa: F401  (the clearance of an epsilon)
    return time.perf_counter() - t0


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
        "resistance_ohm": np.zeros(0),
        "resistance_clean_ohm": np.zeros(0),
        # the regime from the design, kept when the clearance cannot be had
        "regime": point.design_regime,
    }


def _solve_clearance(ctx: TraceContext, rec: dict) -> float:
    """The clearance of the record's target epsilon (signatelec.physics.quasistatic)."""
    from signatelec.physics.quasistatic import clearance_for_epsilon

    try:
        return clearance_for_epsilon(
            ctx.scene.bearing, rec["radial_load_n"], rec["omega_rad_s"], rec["epsilon_target"]
        )
    except ValueError as exc:
        raise EpsilonError(str(exc)) from None


def run_trace(ctx: TraceContext, task: TraceTask) -> dict:
    """Simulate one trace and measure it: a record of labels and signals (never raises for a
    scene that is not allowed, a divergence or an unreachable epsilon: those give status
    "failed" and the error)."""
    from signatelec.engines.fidelity import apply_fidelity
    from signatelec.engines.results import DivergenceError
    from signatelec.engines.simulate import simulate

    cpu0 = time.thread_time()
    m = ctx.measurement
    rec = _new_record(ctx, task)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            if not math.isnan(rec["epsilon_target"]):
                rec["clearance_m"] = _solve_clearance(ctx, rec)
                rec["regime"] = regime_of(rec["clearance_m"])
            scene = ctx.scene.with_overrides(
                radial_load_n=rec["radial_load_n"],
                clearance_m=rec["clearance_m"],
                omega_rad_s=rec["omega_rad_s"],
                initial_ball_angle_rad=rec["initial_ball_angle_rad"],
            )
            scene = apply_fidelity(scene, ctx.fidelity)
            dt = scene.numerics.dt_s
            rec["dt_s"], rec["integrator"] = dt, scene.numerics.integrator
            n = int(round(ctx.duration_s * m.sample_rate_hz))
            t0 = scene.setup_time_s + ctx.settle_s + m.guard_s
            end = t0 + (n - 1) / m.sample_rate_hz + m.guard_s
            scene = scene.with_overrides(
                duration_s=end + 2.0 * dt, sample_rate_hz=m.simulation_rate_hz(dt)
            )
            rec["simulation_rate_hz"] = 1.0 / (scene.record_every * dt)
            rec["t0_s"], rec["n_samples"] = t0, n
            result = simulate(scene)
            sig = result.signals
            keep = sig["time_s"].to_numpy() >= t0 - m.guard_s - 1e-12
            clean = m.clean(
                sig["time_s"].to_numpy()[keep], sig["resistance_ohm"].to_numpy()[keep], t0, n
            )
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
            rec["resistance_clean_ohm"] = clean
            rec["resistance_mean_ohm"] = float(np.mean(clean))
            rec["resistance_ohm"] = m.measure(clean, draw, rng)
        messages = dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught)
        rec["warnings"] = " | ".join(messages)
    except (SceneError, DivergenceError, EpsilonError, MeasurementError) as exc:
        rec["status"] = STATUS_FAILED
        rec["error"] = f"{type(exc).__name__}: {exc}"
        rec["resistance_ohm"] = np.zeros(0)
        rec["resistance_clean_ohm"] = np.zeros(0)
    rec["cpu_s"] = time.thread_time() - cpu0
    return rec
