"""One entry point for every engine: the scene's ``numerics.fidelity`` picks the one that runs."""

from __future__ import annotations

from signatelec.config.scene import Scene
from signatelec.engines.results import DivergenceError, SimulationResult


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
    from signatelec.engines.budget import check_run, divergence_advice

    scene = scene or Scene()
    check_run(scene)
    if scene.numerics.fidelity == "quasistatic":
        from signatelec.engines.quasistatic.tier import simulate_quasistatic

        return simulate_quasistatic(scene, progress=progress)
    from signatelec.engines.dem.run import simulate_dem

    try:
        return simulate_dem(scene, progress=progress)
    except DivergenceError as exc:
        # the engine names the step and the body; the advice depends on how close dt was to
        # the stability limit, which decides whether a smaller dt can help at all
        where, _, advice = str(exc).rpartition("; ")
        if not where or "dt" not in advice:
            raise
        raise DivergenceError(f"{where}; {divergence_advice(scene)}") from None
