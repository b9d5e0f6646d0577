"""One entry point for every engine: the scene's ``numerics.fidelity`` picks the one that runs."""

from __future__ import annotations

import time

from signatelec.config.scene import Scene
from signatelec.engines.results import SimulationResult


def simulate(scene: Scene | None = None, *, progress: bool = False) -> SimulationResult:
    """Simulate ``scene`` (default: the seed's scene).

    ``numerics.fidelity = "dem"`` runs the DEM kernel
    (:func:`signatelec.engines.dem.run.simulate_dem`);
    ``"quasistatic"`` the quasi-static tier
    (:func:`signatelec.engines.quasistatic.tier.simulate_quasistatic`: steady phase only, no time
    step). Raises :class:`~signatelec.config.scene.SceneError` for a scene the engine refuses or
    whose run exceeds the limits of :mod:`signatelec.engines.budget` (checked first) and
    :class:`~signatelec.engines.results.DivergenceError` when a run leaves the physical range.
    ``effects.lubrication = "ehl"`` adds the lubricated bearing's columns
    (:func:`signatelec.engines.lubrication.add_lubrication`) to either engine's tables.
    """
    from signatelec.engines.budget import check_run

    scene = scene or Scene()
    check_run(scene)
    if scene.numerics.fidelity == "quasistatic":
        from signatelec.engines.quasistatic.tier import simulate_quasistatic

        result = simulate_quasistatic(scene, progress=progress)
    else:
        from signatelec.engines.dem.run import simulate_dem

        result = simulate_dem(scene, progress=progress)
    if scene.effects.lubrication != "none":
        # post-processing of the recorded kinematics and loads: nothing of it runs when off
        from signatelec.engines.lubrication import add_lubrication

        t0 = time.perf_counter()
        add_lubrication(result)
        result.timings["lubrication_s"] = time.perf_counter() - t0
    return result
