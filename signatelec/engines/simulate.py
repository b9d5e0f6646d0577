"""One entry point for every engine: the scene's ``numerics.fidelity`` picks the one that runs."""

from __future__ import annotations

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
    """
    from signatelec.engines.budget import check_run

    scene = scene or Scene()
    check_run(scene)
    if scene.numerics.fidelity == "quasistatic":
        from signatelec.engines.quasistatic.tier import simulate_quasistatic

        return simulate_quasistatic(scene, progress=progress)
    from signatelec.engines.dem.run import simulate_dem

    return simulate_dem(scene, progress=progress)
