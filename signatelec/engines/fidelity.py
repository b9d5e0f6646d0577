"""Fidelity presets: named bundles of tier, numerics and effects (the fidelity ladder).

``apply_fidelity(scene, name)`` returns the scene run at one rung of the fidelity ladder:

- ``"quasistatic"``: the quasi-static tier (:mod:`signatelec.engines.quasistatic.tier`), steady
  phase only, no dynamics.
- ``"dem"``: the DEM with the scene's own numerics (the paper's: velocity Verlet, dt = 1e-7 s,
  every seed effect, unless the scene says otherwise).
- the presets of :data:`PRESETS`, chosen from the accuracy-cost study
  (:mod:`signatelec.studies.accuracy_cost`), which measures each one's error against a
  dt = 1e-8 s reference and its CPU cost relative to the paper's setting:
  ``docs/accuracy_cost/accuracy_cost.md``, rows ``preset <name>``. The figures are quoted from
  there only, so that they are those of the last run:

  - ``"fast"``: cage balls 80x heavier (mass scaling), symplectic Euler, dt at 0.9 of the
    stability limit that leaves: the cheap DEM setting that stays within the study's 1 % on
    mean resistance and ball-pass amplitude;
  - ``"balanced"``: the paper's physics (no mass scaling), symplectic Euler, dt at 0.9 of the
    stability limit;
  - ``"reference"``: dt = 1e-8 s, every seed effect: the study's reference.

  Both cheaper presets use symplectic Euler, whose stability limit with contact damping is
  about twice velocity Verlet's (damping at v_n rather than at the predicted velocity; see
  :mod:`signatelec.physics.stability`) for the same accuracy at a given dt. Near the
  ``fast`` preset's dt the per-sample work (electrical network and tables at 20 kHz) becomes a
  large part of the cost, so a larger dt no longer pays.

Cage-mass scaling is a numerical device: the stability limit of the seed's scene is set by the
light polyamide cage balls (about 5 mg against 8 g for a steel ball); they carry no current and
forces of the order of a newton, so their inertia hardly shows in the resistance, and making
them heavier lets dt grow to the steel balls' own limit. The scaled material is part of the
scene's bearing (``cage_material`` named "polyamide (mass x80)"), written with the results.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace

from signatelec.config.bearing import MATERIALS, Material
from signatelec.config.options import FIDELITIES, OPTIONS
from signatelec.config.scene import Scene, SceneError

_SCALED = re.compile(r"^(?P<base>.*) \(mass x(?P<factor>[0-9.eE+-]+)\)$")


@dataclass(frozen=True)
class Preset:
    """A named bundle: tier, integrator, time step, cage-mass scaling, effect overrides.

    ``dt_s`` is absolute; ``dt_limit_fraction`` sets dt to that fraction of the scene's
    stability limit (after the mass scaling). Effects not named keep the scene's.
    """

    description: str
    fidelity: str = "dem"
    integrator: str = "verlet"
    dt_s: float | None = None
    dt_limit_fraction: float | None = None
    cage_mass_scale: float = 1.0
    effects: tuple[tuple[str, object], ...] = ()


PRESETS: dict[str, Preset] = {
    "fast": Preset(
        "DEM, cage balls 80x heavier, symplectic Euler, dt = 0.9 x stability limit",
        integrator="euler",
        dt_limit_fraction=0.9,
        cage_mass_scale=80.0,
    ),
    "balanced": Preset(
        "DEM, the paper's physics, symplectic Euler, dt = 0.9 x stability limit",
        integrator="euler",
        dt_limit_fraction=0.9,
    ),
    "reference": Preset(
        "DEM, dt = 1e-8 s, every seed effect: the accuracy-cost study's reference",
        dt_s=1e-8,
        effects=tuple((o.name, o.default) for o in OPTIONS if o.section == "effects")
        + (("spin_up", True),),
    ),
}

#: Every name ``apply_fidelity`` and ``signatelec simulate --fidelity`` accept.
FIDELITY_NAMES: tuple[str, ...] = (*FIDELITIES, *PRESETS)


def unscaled_cage_material(material: Material) -> Material:
    """The material before :func:`scale_cage_mass` (itself when it was not scaled)."""
    match = _SCALED.match(material.name)
    if match is None:
        return material
    factor = float(match["factor"])
    base = replace(material, name=match["base"], density_kg_m3=material.density_kg_m3 / factor)
    catalogue = MATERIALS.get(base.name)
    # give the catalogue's exact density back when the division only rounds it
    if catalogue is not None and abs(catalogue.density_kg_m3 / base.density_kg_m3 - 1) < 1e-12:
        return catalogue
    return base


def cage_mass_scale(scene: Scene) -> float:
    """How many times heavier than its unscaled material the scene's cage balls are."""
    material = scene.bearing.cage_material
    return material.density_kg_m3 / unscaled_cage_material(material).density_kg_m3


def scale_cage_mass(scene: Scene, factor: float) -> Scene:
    """The scene with cage balls ``factor`` times as heavy as the unscaled material's.

    The density of the cage material is multiplied (radius, stiffness and friction unchanged)
    and the material renamed "<name> (mass x<factor>)"; factor 1 restores the material. Raises
    :class:`SceneError` when the density leaves the bearing's allowed range.
    """
    b = scene.bearing
    base = unscaled_cage_material(b.cage_material)
    if factor == 1.0:
        material = base
    else:
        material = replace(
            base, name=f"{base.name} (mass x{factor:g})", density_kg_m3=base.density_kg_m3 * factor
        )
    try:
        return replace(scene, bearing=b.with_(cage_material=material))
    except ValueError as exc:
        raise SceneError(f"cage mass scale {factor:g}: {exc}") from None


def apply_fidelity(scene: Scene, fidelity: str | Preset, *, record_grid: bool = True) -> Scene:
    """The scene at ``fidelity``: a tier (``"quasistatic"``, ``"dem"``), a preset's name or a
    :class:`Preset` (the accuracy-cost study's settings are presets too).

    A preset sets, in this order, its effects, the cage-mass scaling, the integrator and the time
    step (absolute, or from the stability limit of the scene as it then is: load, clearance and
    speed matter), with ``record_grid`` brought down to the grid of the scene's record rate
    (:func:`~signatelec.physics.stability.record_grid_dt_s`: the run records at
    ``numerics.sample_rate_hz`` exactly, so set the rate before the preset; without it, a
    caller that resamples the records itself saves the up to 1/k more steps, k the steps per
    recorded instant); the rest of the scene is kept. Unknown names raise :class:`SceneError`.
    """
    if isinstance(fidelity, Preset):
        preset = fidelity
    elif fidelity in FIDELITIES:
        return scene.with_overrides(fidelity=fidelity)
    elif fidelity in PRESETS:
        preset = PRESETS[fidelity]
    else:
        raise SceneError(f"fidelity = {fidelity!r}: must be one of {', '.join(FIDELITY_NAMES)}")
    overrides = {"fidelity": preset.fidelity, "integrator": preset.integrator}
    scene = scale_cage_mass(
        scene.with_overrides(**overrides, **dict(preset.effects)), preset.cage_mass_scale
    )
    from signatelec.physics.stability import record_grid_dt_s, stability_limit

    dt_s = preset.dt_s
    if preset.dt_limit_fraction is not None:
        dt_s = preset.dt_limit_fraction * float(stability_limit(scene).dt_limit_s)
    if record_grid:  # a whole number of steps per recorded instant: the rate asked
        dt_s = record_grid_dt_s(dt_s, scene.numerics.sample_rate_hz)
    return scene.with_overrides(dt_s=dt_s)
