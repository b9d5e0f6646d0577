"""The ensemble kernel (engines/dem/ensemble.py, engines/dem/batch.py) against the single-scene
kernel: every recorded column of every scene of a batch equal to round-off, the effects it does
not carry refused in one line, and a dataset's traces the same batched or one by one.

Equal "to round-off": the two kernels evaluate the same expressions, but LLVM contracts and
orders them differently in vector and scalar code, so they part in the last bits (measured:
<= 2e-12 of each column's largest value over 12 ms, growing to ~1e-9 by 30 ms of this chaotic,
rattling cage). The comparison horizon is therefore the set-up (7 ms) and 5 ms of steady
running, where every column must agree within 1e-10 of its largest value (measured 1.6e-12).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from signatelec.config.scene import Scene
from signatelec.data import design_traces, spec_from_dict
from signatelec.data.runner import batched, run_trace, run_traces
from signatelec.engines.dem import batch as batch_module
from signatelec.engines.dem.batch import simulate_batch
from signatelec.engines.dem.run import simulate_dem
from signatelec.engines.dem.spec import KernelSpec
from signatelec.engines.results import SimulationResult

#: The horizon over which the two kernels must agree (module docstring).
HORIZON_S = 0.012
#: Largest difference allowed, relative to a column's largest magnitude (measured <= 2e-12).
TOLERANCE = 1e-10


def _scenes(horizon_s=HORIZON_S, **changes) -> list[Scene]:
    """Three different operating points of one kernel: load, clearance, speed and ball phase."""
    base = Scene().with_overrides(duration_s=horizon_s, **changes)
    return [
        base,
        base.with_overrides(radial_load_n=9000.0, clearance_m=10e-6, initial_ball_angle_rad=0.1),
        # another record interval: a lane of its own in the same call
        base.with_overrides(
            radial_load_n=3000.0, clearance_m=-5e-6, omega_rad_s=400.0, sample_rate_hz=10000.0
        ),
    ]


def assert_same(single: SimulationResult, batch: SimulationResult) -> float:
    """Every column of both tables equal: floats within TOLERANCE of the column's largest
    magnitude (NaN where NaN, inf where inf), everything else exactly. Returns the largest."""
    worst = 0.0
    for table in ("signals", "balls"):
        a, b = getattr(single, table), getattr(batch, table)
        assert list(a.columns) == list(b.columns)
        assert len(a) == len(b) > 0
        for column in a.columns:
            x, y = a[column].to_numpy(), b[column].to_numpy()
            if x.dtype.kind != "f":
                assert (x == y).all(), column
                continue
            finite = np.isfinite(x)
            assert (finite == np.isfinite(y)).all() and (x[~finite] == y[~finite]).all() | (
                np.isnan(x[~finite]) & np.isnan(y[~finite])
            ).all(), column
            scale = np.abs(x[finite]).max(initial=0.0)
            if scale > 0.0:
                err = np.abs(x[finite] - y[finite]).max() / scale
                assert err <= TOLERANCE, (table, column, err)
                worst = max(worst, err)
    return worst


@pytest.mark.parametrize(
    "changes",
    [
        {},  # the seed's kernel: cage balls, Coulomb friction, critical damping, Hertz, Verlet
        # no cage, energy balance, symplectic Euler, linear law, spring, compensated centrifugal:
        # the balls knock on each other without a cage; the kernels part faster (measured
        # 1.9e-10 of the drive torque by 12 ms), so 2 ms of steady running
        {
            "horizon_s": 0.009,
            "cage": "none",
            "energy": True,
            "integrator": "euler",
            "contact_law": "linear",
            "tangential": "spring",
            "centrifugal": "compensated",
        },
    ],
    ids=["seed", "other-models"],
)
def test_batch_equals_single_scene_kernel(changes, monkeypatch):
    scenes = _scenes(**changes)
    assert scenes[2].record_every != scenes[0].record_every
    groups = []
    run_group = batch_module._run_group
    monkeypatch.setattr(batch_module, "_run_group", lambda *a: groups.append(a) or run_group(*a))
    batch = simulate_batch(scenes, lanes=4)  # one lane padded
    assert len(groups) == 1
    for scene, result in zip(scenes, batch, strict=True):
        assert result.timings["kernel"].endswith("x4")
        assert_same(simulate_dem(scene), result)


def _scene(sections: dict, defects: list, steady_s: float, **changes) -> Scene:
    """A scene of ``defects`` and ``sections`` running ``steady_s`` after its set-up."""
    scene = Scene.from_dict({"defects": defects, **sections}).with_overrides(**changes)
    return scene.with_overrides(duration_s=scene.setup_time_s + steady_s)


def _spall(location, angle_rad, length_m, depth_m, **more) -> dict:
    return {"location": location, "angle_rad": angle_rad, "length_m": length_m} | (
        {"depth_m": depth_m} | more
    )


#: Operating points of the three scenes of an effect set: load, clearance, speed, ball phase.
POINTS = [
    {},
    {"radial_load_n": 9000.0, "clearance_m": 10e-6, "initial_ball_angle_rad": 0.1},
    {"radial_load_n": 3000.0, "clearance_m": -5e-6, "omega_rad_s": 400.0},
]
#: Spalls of the three scenes (several per scene, rectangular and smooth, on every surface). No
#: ball starts on an outer spall: its first touch there (an overlap of ~1e-9 m in the clearance
#: phase) turns one ulp of its position into ~5e-10 of the resistance, R ~ delta^{-1/2}.
SPALLS = [
    [
        _spall("outer", 0.25, 1.5e-3, 50e-6),
        _spall("inner", 0.5, 1.0e-3, 30e-6),
        _spall("ball", 1.0, 0.8e-3, 20e-6, ball=0),
    ],
    [
        _spall("outer", 0.3, 2.5e-3, 80e-6, profile="smooth"),
        _spall("outer", -0.4, 0.5e-3, 40e-6),
        _spall("inner", 3.0, 2.0e-3, 60e-6, profile="smooth"),
        _spall("ball", 2.0, 1.5e-3, 50e-6, ball=6),
    ],
    [
        _spall("outer", -0.2, 1.0e-3, 30e-6, profile="smooth"),
        _spall("inner", 0.0, 3.0e-3, 100e-6),
        _spall("ball", 3.5, 2.0e-3, 80e-6, ball=12, profile="smooth"),
        _spall("ball", 0.2, 1.0e-3, 50e-6, ball=0),
    ],
]


def _abnormal_loads(i: int) -> dict:
    """Scene i's unbalance, load table (a ramp ending 0.10-0.18 ms after the set-up), lobed race."""
    return {
        "loads": {
            "unbalance_force_n": 200.0 * (1 + i),
            "unbalance_phase_rad": 0.7 * i,
            "load_table_time_s": [4e-5 * (1 + i), 1e-4 + 4e-5 * i],
            "load_table_radial_load_n": [5820.0, 7000.0 - 1000.0 * i],
        },
        "housing": {"out_of_round_lobes": 2 + i, "out_of_round_amplitude_m": 1e-6 * (1 + i)},
    }


def _effect_set(name: str) -> list[Scene]:
    """Three scenes of one kernel with their own defects or abnormal loads.

    Over a spall's edge, or where a lightly loaded ball re-enters its contact, the damping
    C_n ~ delta^{1/4} makes the force steep in the overlap and the two kernels' round-off
    differences grow there: measured 1.5e-9 of the tangential forces at 10 ms with these
    spalls; under the linear law (its damping steps at contact) 2e-8 of the drive torque as a
    load ramp presses a ball onto a rectangular spall's edge, and 1e-10-3e-10 spikes at the
    spin-up's start with the linear law or the tangential spring (whose pairing with cage
    none the seed-kernel test above holds). The horizons, profiles and models keep to where the
    kernels agree within TOLERANCE, each with the spalls met and the loads applied.
    """
    if name == "defects":  # the seed's models; 2 ms of steady running (measured 2.8e-12)
        return [_scene({}, SPALLS[i], 0.002, **POINTS[i]) for i in range(3)]
    # "loads-other-models": the abnormal loads, a smooth outer spall and a ball spall through
    # the energy balance (the unbalance's work) and symplectic Euler (the balls' rotation
    # integrated as their positions); the set-up (the unbalance grows with the speed) and 0.2 ms
    # of steady running (measured 1.1e-11); a clearance in the first scene (touching at once,
    # its balls' first overlaps of ~1e-9 m gave 1e-10 of the current, R ~ delta^{-1/2})
    other = {"energy": True, "integrator": "euler"}
    return [
        _scene(
            _abnormal_loads(i),
            [SPALLS[i][0] | {"profile": "smooth"}, SPALLS[i][-1]],
            0.0002,
            **other,
            **({"clearance_m": 5e-6} | POINTS[i]),
        )
        for i in range(3)
    ]


@pytest.mark.parametrize("effects", ["defects", "loads-other-models"])
def test_defects_and_abnormal_loads_batched_equal_the_single_scene_kernel(effects):
    scenes = _effect_set(effects)
    assert len({KernelSpec.from_scene(s) for s in scenes}) == 1
    batch = simulate_batch(scenes, lanes=4)  # one lane padded
    for scene, result in zip(scenes, batch, strict=True):
        assert result.timings["kernel"].endswith("x4")
        assert_same(simulate_dem(scene), result)
    if effects == "defects":
        # the spalls are met: the run parts from the healthy one (the seed's kernel)
        healthy = simulate_dem(_scene({}, [], 0.002, **POINTS[0]))
        torque = healthy.signals["drive_torque_n_m"].to_numpy()
        change = np.abs(batch[0].signals["drive_torque_n_m"].to_numpy() - torque).max()
        assert change > 1e-3 * np.abs(torque).max()
        # the balls' rotation angles, tracked for the ball spalls, recorded by the batch
        assert np.abs(batch[2].balls["ball_rotation_rad"].to_numpy()).max() > 1.0
    else:  # each scene's load table reached: F_r its last value after the ramp
        for i, result in enumerate(batch):
            assert result.signals["applied_load_n"].iloc[-1] == 7000.0 - 1000.0 * i


def _rigid_cage_scenes(bearing: str | None, **models) -> list[Scene]:
    """Three rigid-cage scenes of one bearing (the seed's, or a catalogue one) and ``models``:
    load, clearance, speed and ball phase, the set-up and 2 ms of steady running."""
    sections = {"effects": {"cage": "rigid"}}
    if bearing is not None:
        sections["bearing"] = {"designation": bearing}
    points = [
        {"radial_load_n": 2000.0},
        {"radial_load_n": 4000.0, "clearance_m": 10e-6, "initial_ball_angle_rad": 0.1},
        {"radial_load_n": 1000.0, "clearance_m": -5e-6, "omega_rad_s": 400.0},
    ]
    return [_scene(sections, [], 0.002, **point, **models) for point in points]


# the seed's bearing and models; a catalogue bearing (9 balls) through the energy balance (the
# rigid cage's kinetic energy and gravity work) and symplectic Euler (measured <= 2.3e-11)
@pytest.mark.parametrize(
    "bearing, models",
    [(None, {}), ("6205", {"energy": True, "integrator": "euler"})],
    ids=["seed", "6205-energy-euler"],
)
def test_the_rigid_cage_batched_equals_the_single_scene_kernel(bearing, models):
    scenes = _rigid_cage_scenes(bearing, **models)
    assert len({KernelSpec.from_scene(s) for s in scenes}) == 1
    batch = simulate_batch(scenes, lanes=4)  # one lane padded
    for scene, result in zip(scenes, batch, strict=True):
        assert result.timings["kernel"].endswith("x4")
        assert_same(simulate_dem(scene), result)
    # the pockets push the balls: the rigid cage's contacts are met in the compared runs
    assert (batch[0].balls["pocket_force_n"].to_numpy() > 0.0).any()


SPEC = {
    "dataset": {"name": "ens", "seed": 7, "fidelity": "dem", "duration_s": 0.002, "settle_s": 0.0},
    "design": [
        {
            "kind": "grid",
            "factors": {
                "radial_load_fraction": {"values": [0.15, 0.3]},
                "clearance_m": {"values": [-5e-6, 10e-6]},
            },
        }
    ],
    "measurement": {"sample_rate_hz": 10000.0, "oversample": 2},
}


def test_dataset_traces_are_the_same_batched_or_one_by_one():
    spec = spec_from_dict(SPEC)
    ctx = spec.context
    assert batched(ctx)
    # and a dataset of spalls and abnormal loads runs batched too (the kernel equal above)
    scene = _abnormal_loads(0) | {"defects": SPALLS[0]}
    assert batched(spec_from_dict(SPEC | {"scene": scene}).context)
    tasks = design_traces(spec)
    together = run_traces(ctx, tasks)
    for task, rec in zip(tasks, together, strict=True):
        alone = run_trace(ctx, task)
        assert rec["status"] == alone["status"] == "ok"
        for key, value in alone.items():
            if key in ("cpu_s", "warnings"):
                continue
            if isinstance(value, np.ndarray) and not value.size:  # a signal not measured
                assert not rec[key].size, key
            elif isinstance(value, np.ndarray):  # the signals, clean and measured
                scale = np.abs(value).max()
                # the measured signal is quantised: a level may flip where the clean one moved
                step = ctx.measurement.quantisation_ohm if key == "resistance_ohm" else 0.0
                assert np.abs(rec[key] - value).max() <= TOLERANCE * scale + step, key
            elif isinstance(value, float) and not pd.isna(value):
                assert rec[key] == pytest.approx(value, rel=TOLERANCE, abs=0.0), key
            else:
                assert rec[key] == value or (pd.isna(rec[key]) and pd.isna(value)), key


def test_each_batched_trace_carries_its_own_warnings_only():
    """A trace's warnings are those of its own run: batched as alone. A light load (210 N on a
    6208) concentrates the 0.1 A in small Hertz contacts, above the seed's 0.1 A/mm^2
    (section 3), while 2000 N spreads it below; run in one lane group, the heavy trace must not
    carry the light one's current-density warning."""
    spec = spec_from_dict(
        SPEC
        | {
            "dataset": SPEC["dataset"] | {"fidelity": "fast"},
            "design": [
                {
                    "kind": "grid",
                    "factors": {
                        "radial_load_n": {"values": [210.0, 2000.0]},
                        "clearance_m": {"values": [30e-6]},
                        "omega_rad_s": {"values": [250.0]},
                    },
                }
            ],
            "scene": {"bearing": {"designation": "6208"}},
        }
    )
    ctx, tasks = spec.context, design_traces(spec)
    assert batched(ctx)
    together = run_traces(ctx, tasks)
    alone = [run_trace(ctx, task) for task in tasks]
    by_load = {rec["radial_load_n"]: rec["warnings"] for rec in together}
    assert "CurrentDensityWarning" in by_load[210.0]
    assert by_load[2000.0] == ""
    for rec, own in zip(together, alone, strict=True):
        assert rec["status"] == own["status"] == "ok"
        assert rec["warnings"] == own["warnings"]
