"""The traces of a spec: grid, random and Latin-hypercube designs, their seeds, and the operating
point of each trace (its load, speed and clearance, or the target epsilon that sets the clearance).

Seeds: trace ``i`` (its id, counted over all blocks) owns
``numpy.random.SeedSequence(seed).spawn(n)[i]``, i.e. ``SeedSequence(seed, spawn_key=(i,))``:
its child 0 draws the trace's factors in a random design, its child 1 every measurement random
number. A trace's noise therefore depends only on the root seed and its id, whatever the number
of traces, workers or the order they run in. A Latin hypercube, being joint, draws from
``SeedSequence(seed, spawn_key=(LHS_KEY, block))``.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from signatelec.config.constraints import CONDITIONS, HEALTHY
from signatelec.config.scene import Scene
from signatelec.data.spec import DEFAULT_SPALL_DEPTH_M, DEFAULT_SPALL_LENGTH_M, Spec, spall_of
from signatelec.physics.regimes import regime_of, regime_of_epsilon

#: Spawn-key word of the Latin-hypercube streams (trace streams use one-word keys (i,)).
LHS_KEY = 0x4C4853
#: How a part file names the seeding rule (schema metadata ``seeding``).
SEEDING = (
    "trace i: numpy.random.SeedSequence(root_seed).spawn(n)[i] = "
    "SeedSequence(root_seed, spawn_key=(i,)); child 0 of it: design draws (random "
    "design), child 1: measurement; Latin hypercube block b: "
    f"SeedSequence(root_seed, spawn_key=({LHS_KEY}, b))"
)


@dataclass(frozen=True)
class TraceTask:
    """One trace to simulate: its id, design block and factor values."""

    trace_id: int
    block: int
    values: tuple[tuple[str, float | str], ...]

    @property
    def factors(self) -> dict[str, float | str]:
        return dict(self.values)


def trace_seed_sequence(root_seed: int, trace_id: int) -> np.random.SeedSequence:
    """``SeedSequence(root_seed).spawn(n)[trace_id]`` for any n > trace_id."""
    return np.random.SeedSequence(root_seed, spawn_key=(trace_id,))


def trace_rng(root_seed: int, trace_id: int, stream: int) -> np.random.Generator:
    """Stream 0: the trace's design draws (random design); stream 1: its measurement."""
    return np.random.default_rng(trace_seed_sequence(root_seed, trace_id).spawn(2)[stream])


def trace_seed_json(root_seed: int, trace_id: int) -> dict:
    """The trace's seed as a part file records it (schema metadata ``trace_seed``)."""
    return {"entropy": root_seed, "spawn_key": [trace_id]}


def design_traces(spec: Spec) -> list[TraceTask]:
    """Every trace of the spec, ids 0..n-1 over the blocks in order."""
    tasks: list[TraceTask] = []
    for block_index, block in enumerate(spec.designs):
        names = [f.name for f in block.factors]
        first = len(tasks)
        if block.kind == "grid":
            rows = list(itertools.product(*(f.grid_levels() for f in block.factors)))
        elif block.kind == "random":
            rows = []
            for k in range(block.n_traces):
                rng = trace_rng(spec.seed, first + k, 0)
                u = rng.random(len(block.factors))
                rows.append([f.from_unit(x) for f, x in zip(block.factors, u, strict=True)])
        else:
            from scipy.stats import qmc

            seq = np.random.SeedSequence(spec.seed, spawn_key=(LHS_KEY, block_index))
            d = max(len(block.factors), 1)
            sample = qmc.LatinHypercube(d=d, rng=np.random.default_rng(seq)).random(block.n_traces)
            rows = [
                [f.from_unit(x) for f, x in zip(block.factors, row, strict=False)] for row in sample
            ]
        for k, row in enumerate(rows):
            values = tuple(
                (n, v if isinstance(v, str) else float(v)) for n, v in zip(names, row, strict=True)
            )
            tasks.append(TraceTask(first + k, block_index, values))
    return tasks


@dataclass(frozen=True)
class OperatingPoint:
    """A trace's operating point from its factors over the base scene's values."""

    radial_load_n: float
    omega_rad_s: float
    initial_ball_angle_rad: float
    #: The design's clearance, m; NaN when a target epsilon sets it (solved in the run).
    clearance_m: float
    #: The design's target epsilon (seed eq. 15); NaN when the design gives the clearance.
    epsilon_target: float

    @property
    def design_regime(self) -> str:
        """The regime the design asks for (the partition of a trace whose run fails)."""
        if math.isnan(self.epsilon_target):
            return regime_of(self.clearance_m)
        return regime_of_epsilon(self.epsilon_target)


def operating_point(task: TraceTask, scene: Scene) -> OperatingPoint:
    """``radial_load_fraction`` is of the bearing's C_r (``dynamic_load_rating_n``)."""
    f = task.factors
    op = scene.operating
    if "radial_load_fraction" in f:
        load = f["radial_load_fraction"] * scene.bearing.dynamic_load_rating_n
    else:
        load = f.get("radial_load_n", op.radial_load_n)
    target = f.get("epsilon", math.nan)
    return OperatingPoint(
        radial_load_n=load,
        omega_rad_s=f.get("omega_rad_s", op.omega_rad_s),
        initial_ball_angle_rad=f.get("initial_ball_angle_rad", op.initial_ball_angle_rad),
        clearance_m=f.get("clearance_m", op.clearance_m) if math.isnan(target) else math.nan,
        epsilon_target=target,
    )


# --- the bearing's condition ------------------------------------------------------------------

#: An unbalance's force when the design gives none, as a fraction of the trace's F_r.
DEFAULT_UNBALANCE_FRACTION = 0.1


def condition_scene(task: TraceTask, scene: Scene) -> Scene:
    """``scene`` with the condition the task's factors ask for (none: the base scene's): a
    spall (``spall_length_m``, ``spall_depth_m``, ``spall_angle_rad``) or an unbalance
    (``unbalance_force_n``, default :data:`DEFAULT_UNBALANCE_FRACTION` of F_r;
    ``unbalance_phase_rad``). SceneError when the scene does not allow it."""
    f = task.factors
    condition = f.get("condition")
    if condition is None or condition == HEALTHY:
        return scene
    if condition == "unbalance":
        force = f.get(
            "unbalance_force_n", DEFAULT_UNBALANCE_FRACTION * scene.operating.radial_load_n
        )
        return scene.with_overrides(
            unbalance_force_n=force, unbalance_phase_rad=f.get("unbalance_phase_rad", 0.0)
        )
    spall = spall_of(
        str(condition),
        f.get("spall_length_m", DEFAULT_SPALL_LENGTH_M),
        f.get("spall_depth_m", DEFAULT_SPALL_DEPTH_M),
        f.get("spall_angle_rad", 0.0),
    )
    return replace(scene, defects=(*scene.defects, spall))


def condition_labels(scene: Scene) -> dict:
    """The condition labels of the scene a trace simulates: ``condition`` (the first defect's
    location, else ``unbalance`` when a load turns with the shaft, else ``healthy``), the first
    spall's ``spall_length_m``, ``spall_depth_m``, ``spall_angle_rad`` (NaN without one) and
    ``unbalance_force_n`` (0 without one)."""
    unbalance = scene.loads.unbalance_amplitude_n(scene.operating.omega_rad_s)
    nan = math.nan
    labels = {
        "condition": CONDITIONS[0],
        "spall_length_m": nan,
        "spall_depth_m": nan,
        "spall_angle_rad": nan,
        "unbalance_force_n": unbalance,
    }
    if scene.defects:
        d = scene.defects[0]
        labels.update(
            condition=d.location,
            spall_length_m=d.length_m,
            spall_depth_m=d.depth_m,
            spall_angle_rad=d.angle_rad,
        )
    elif unbalance > 0.0:
        labels["condition"] = "unbalance"
    return labels
