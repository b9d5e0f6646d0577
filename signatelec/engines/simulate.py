"""One entry point for every engine: the scene's ``numerics.fidelity`` picks the one that runs."""

from __future__ import annotations

import time
from pathlib import Path

from signatelec.config.scene import Scene
from signatelec.engines.results import SimulationResult


def simulate(
    scene: Scene | None = None, *, progress: bool = False, out_dir: str | Path | None = None
) -> SimulationResult:
    """Simulate ``scene`` (default: the seed's scene).

    ``numerics.fidelity = "dem"`` runs the DEM kernel
    (:func:`signatelec.engines.dem.run.simulate_dem`);
    ``"quasistatic"`` the quasi-static tier
    (:func:`signatelec.engines.quasistatic.tier.simulate_quasistatic`: steady phase only, no time
    step). Raises :class:`~signatelec.config.scene.SceneError` for a scene the engine refuses or
    whose run exceeds the limits of :mod:`signatelec.engines.budget` (checked first) and
    :class:`~signatelec.engines.results.DivergenceError` when a run leaves the physical range.
    ``effects.lubrication = "ehl"`` adds the lubricated bearing's columns
    (:mod:`signatelec.engines.lubrication`) to either engine's tables, streamed or not.

    Without ``out_dir`` the tables are returned in memory. With it, they are written to
    ``out_dir/balls.parquet`` and ``signals.parquet`` as the run goes, in blocks of recorded
    instants (:mod:`signatelec.engines.stream`: memory bounded whatever the duration), under the
    output-directory contract of :mod:`signatelec.io` (the directory appears, or is replaced, only
    when the run completes); the result then holds the timings and the steady-phase means only.
    """
    from signatelec.engines.budget import check_run

    scene = scene or Scene()
    check_run(scene, out_dir=out_dir)
    if scene.numerics.fidelity == "quasistatic":
        from signatelec.engines.quasistatic.tier import simulate_quasistatic as engine
    else:
        from signatelec.engines.dem.run import simulate_dem as engine
    if out_dir is None:
        return post_process(engine(scene, progress=progress))

    from signatelec.engines.stream import TableStream
    from signatelec.io import check_output_dir, is_simulate_output, replace_directory

    check_output_dir(str(out_dir), "simulate", previous=is_simulate_output)
    with replace_directory(out_dir, "simulate", previous=is_simulate_output) as tmp:
        stream = TableStream(tmp, scene)
        try:
            result = engine(scene, progress=progress, stream=stream)
            stream.finish(result.timings)
        finally:
            stream.close()
    result.out_dir = Path(out_dir)
    result.steady_signal_means = stream.steady_means()
    return result


def post_process(result: SimulationResult) -> SimulationResult:
    """Add to an in-memory ``result`` the columns its scene computes from the recorded
    kinematics and loads (the lubricated contacts); nothing of it runs when they are off."""
    if result.scene.effects.lubrication != "none":
        from signatelec.engines.lubrication import add_lubrication

        t0 = time.perf_counter()
        add_lubrication(result)
        result.timings["lubrication_s"] = time.perf_counter() - t0
    return result
