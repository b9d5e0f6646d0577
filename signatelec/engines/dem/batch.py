"""Many scenes per kernel call: :func:`simulate_batch` runs DEM scenes through the ensemble
kernel (:mod:`signatelec.engines.dem.ensemble`), LANES scenes of one kernel in lockstep.

Scenes are grouped by their kernel (:class:`~.spec.KernelSpec`) and number of balls (each lane
records at its own interval: the scenes of a dataset, whose time steps and so record intervals
differ, share lane groups); each group runs in lane groups of ``lanes`` scenes (the last one
padded with copies of its last scene, whose results are dropped). Each scene keeps its own
time step: the lanes share the step index, not the time, so a scene's run is the one the
single-scene kernel makes, to round-off (tests/test_ensemble.py). A group runs to the longest
of its scenes; a shorter scene's lane runs on, unrecorded, after its end (the cost of mixing
durations in one lane group).
"""

from __future__ import annotations

import time
import warnings
from collections import defaultdict

import numpy as np

from signatelec.config.scene import Scene, SceneError
from signatelec.engines.dem.build import get_kernel, prepare
from signatelec.engines.dem.records import OK, PARAM_ROWS, REC_ROTATION, Recording
from signatelec.engines.dem.run import (
    _divergence_message,
    checked_limit,
    dem_result,
    initial_state,
    kernel_parameters,
)
from signatelec.engines.dem.spec import KernelSpec
from signatelec.engines.results import DivergenceError, SimulationResult

#: Scenes per lane group: 8 float64 lanes fill one AVX-512 register.
LANES = 8


def _pack(lanes: int, scenes: list[Scene], kern):
    """The parameter records PR and the work rows W (parameters, then state) of ``scenes``, one
    per lane."""
    PR = np.zeros(lanes, dtype=kernel_parameters(scenes[0]).dtype)
    W = np.zeros((kern.ROWS, lanes))
    for lane, scene in enumerate(scenes):
        p = kernel_parameters(scene)
        PR[lane] = p
        for name in p.dtype.names:
            row = PARAM_ROWS[name]
            values = np.ravel(p[name])
            W[row : row + values.size, lane] = values
        W[kern.EVERY, lane] = scene.record_every
        st = initial_state(scene)
        for row, values in ((kern.POS, st.pos), (kern.VEL, st.vel), (kern.SPIN, st.spin)):
            W[row : row + values.size, lane] = values.ravel()
    return PR, W.ravel()


def _recording(kern, rec: np.ndarray, lane: int) -> Recording:
    """Lane ``lane`` of the ensemble's recorded rows, as the single-scene kernel's Recording."""
    n, z, nb = rec.shape[0], kern.BALLS, kern.NB
    r = rec.reshape(n, kern.REC_ROWS, kern.LANES)[:, :, lane]
    motion = r[:, kern.REC_POS : kern.REC_SPIN]
    fcon = np.zeros((n, z, 7))
    fcon[:, :, :6] = r[:, kern.REC_FCON : kern.REC_SCHED].reshape(n, z, 6)
    fcon[:, :, REC_ROTATION] = r[:, kern.REC_ROT : kern.REC_ROT + z]  # 0 without ball defects
    return Recording(
        time_s=r[:, kern.REC_TIME],
        pos=motion[:, : 2 * nb].reshape(n, nb, 2),
        vel=motion[:, 2 * nb :].reshape(n, nb, 2),
        spin=r[:, kern.REC_SPIN : kern.REC_FCON],
        fcon=fcon,
        sched=r[:, kern.REC_SCHED : kern.REC_ENERGY],
        energy=r[:, kern.REC_ENERGY : kern.REC_ROWS],
    )


def _run_group(spec: KernelSpec, scenes: list[Scene], limits: list, lanes: int) -> list:
    """Run up to ``lanes`` scenes of one kernel (``limits`` their stability limits); a result or
    a DivergenceError per scene."""
    z = scenes[0].bearing.n_balls
    padded = scenes + [scenes[-1]] * (lanes - len(scenes))
    kern = get_kernel(spec, {"BALLS": z, "LANES": lanes})
    PR, W = _pack(lanes, padded, kern)
    n_steps = max(s.n_steps for s in scenes)
    rec = np.zeros((max(s.n_steps // s.record_every for s in padded), kern.REC_ROWS * lanes))
    t0 = time.perf_counter()
    kern = prepare(kern, spec, {"start": (PR, W), "run": (PR, W, rec, 0, 0)})
    kern.start(PR, W)
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    chunk = max(1, n_steps // 200)
    step = 0
    status = W.reshape(kern.ROWS, lanes)[kern.STATUS : kern.STATUS + 4]
    while step < n_steps and (status[0] == OK).any():
        count = min(chunk, n_steps - step)
        kern.run(PR, W, rec, step, count)
        step += count
    # the batch's time, shared among its scenes by their steps
    share = np.array([s.n_steps for s in padded], float) / sum(s.n_steps for s in padded)
    run_s = (time.perf_counter() - t0) * share
    run_cpu_s = (time.process_time() - cpu0) * share
    out = []
    for lane, (scene, limit) in enumerate(zip(scenes, limits, strict=True)):
        if status[0, lane] != OK and status[1, lane] < scene.n_steps:
            message = _divergence_message(scene, status[:, lane].astype(np.int64))
            out.append(DivergenceError(message))
            continue
        n_rec = scene.n_steps // scene.record_every
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = dem_result(
                scene,
                _recording(kern, rec, lane),
                n_rec,
                limit,
                f"{spec.key} x{lanes}",
                compile_s,
                run_s[lane],
                run_cpu_s[lane],
            )  # fmt: skip
        result.warnings.extend(caught)
        out.append(result)
    return out


def _post_process(result: SimulationResult) -> SimulationResult:
    """``engines.simulate.post_process`` of one scene's result, its warnings kept with it."""
    from signatelec.engines.simulate import post_process

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = post_process(result)
    result.warnings.extend(caught)
    return result


def simulate_batch(
    scenes: list[Scene], *, lanes: int = LANES, return_exceptions: bool = False
) -> list[SimulationResult | Exception]:
    """Simulate DEM ``scenes`` (``numerics.fidelity = "dem"``) through the ensemble kernel,
    ``lanes`` scenes per lane group; one :class:`SimulationResult` per scene, in order.

    Raises :class:`SceneError` (one line) for a scene that the run limits refuse or whose dt is
    above its stability limit, before anything runs; a :class:`DivergenceError` for a scene
    that diverges (its message names the step, body and contact; no cure is probed) or, with
    ``return_exceptions``, the error in that scene's place.

    Each result holds the warnings of its own scene's run (``result.warnings``: the scenes run
    together, so catching around the call cannot tell whose each one is); they are also
    warned again, after the batch, as a single run would warn them.
    """
    from signatelec.engines.budget import check_run

    groups: dict[tuple, list[int]] = defaultdict(list)
    limits = []
    for i, scene in enumerate(scenes):
        if scene.numerics.fidelity != "dem":
            raise SceneError(
                f"numerics.fidelity = {scene.numerics.fidelity!r}: simulate_batch runs the DEM "
                "only; run it with simulate()"
            )
        check_run(scene)
        limits.append(checked_limit(scene))
        spec = KernelSpec.from_scene(scene)
        groups[(spec, scene.bearing.n_balls)].append(i)
    results: list = [None] * len(scenes)
    for (spec, _), members in groups.items():
        for start in range(0, len(members), lanes):
            chunk = members[start : start + lanes]
            group = _run_group(spec, [scenes[i] for i in chunk], [limits[i] for i in chunk], lanes)
            for i, res in zip(chunk, group, strict=True):
                results[i] = res
    results = [r if isinstance(r, Exception) else _post_process(r) for r in results]
    for res in results:  # each scene's warnings, told to the caller as a single run tells them
        for w in [] if isinstance(res, Exception) else res.warnings:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if not return_exceptions:
        for res in results:
            if isinstance(res, Exception):
                raise res
    return results
