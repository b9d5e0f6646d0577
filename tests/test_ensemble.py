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

from signatelec.config.scene import Scene, SceneError
from signatelec.data import design_traces, spec_from_dict
from signatelec.data.runner import batched, run_trace, run_traces
from signatelec.engines.dem.batch import simulate_batch
from signatelec.engines.dem.run import simulate_dem
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
        base.with_overrides(radial_load_n=3000.0, clearance_m=-5e-6, omega_rad_s=400.0),
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
def test_batch_equals_single_scene_kernel(changes):
    scenes = _scenes(**changes)
    batch = simulate_batch(scenes, lanes=4)  # one lane padded
    for scene, result in zip(scenes, batch, strict=True):
        assert result.timings["kernel"].endswith("x4")
        assert_same(simulate_dem(scene), result)


@pytest.mark.parametrize(
    ("changes", "named"),
    [
        ({"cage": "rigid"}, 'effects.cage = "rigid"'),
        ({"defects": [{"location": "outer", "length_m": 1.5e-3, "depth_m": 50e-6}]}, "outer race"),
    ],
)
def test_effects_not_carried_are_refused_in_one_line(changes, named):
    if "defects" in changes:
        scene = Scene.from_dict({"defects": changes["defects"]})
    else:
        scene = Scene().with_overrides(**changes)
    with pytest.raises(SceneError) as info:
        simulate_batch([scene])
    message = str(info.value)
    assert named in message and "\n" not in message


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
