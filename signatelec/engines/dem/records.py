"""Named records the DEM kernel reads and writes: parameters, state, recordings.

Every array is float64 unless stated; nothing here is allocated in the time loop. Z balls, N = 2 Z
+ 1 bodies. Bodies, [body, xy]: rows 0..Z-1 the balls, Z..2Z-1 the cage balls (cage ball j sits
between ball j and ball (j + 1) % Z), row 2Z the inner ring. With the rigid cage, rows Z..2Z-1
hold its coordinates instead: row Z its centre (x, y), row Z + 1 its angle theta (column 0; the
angle of pocket 0 from -y, like a ball's), rows Z + 2.. stay zero; the time loop integrates them
like every other row. The outer ring is fixed, centred at the origin. Contact types index the
six-element parameter fields: 0 ball/inner raceway, 1 ball/outer raceway, 2 ball/cage ball, 3
cage ball/cage boundary, 4 ball/ball, 5 ball/rigid-cage pocket (signatelec.config.bearing
INNER, OUTER, BALL_CAGE, CAGE_WALL, BALL_BALL, BALL_POCKET).

The namedtuple classes live in this importable module so that numba's on-disk cache finds the
same types in every process.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from signatelec.config.defects import MAX_DEFECTS, MAX_LOAD_TABLE_POINTS
from signatelec.physics.defect_geometry import TABLE_ROWS

#: Scalar parameters of one run (a numpy structured scalar; the kernel reads ``p.dt_s``).
PARAMS = np.dtype(
    [
        ("dt_s", "f8"),
        ("ball_radius_m", "f8"),
        ("cage_ball_radius_m", "f8"),
        ("inner_race_radius_m", "f8"),
        ("outer_race_radius_m", "f8"),  # before the clearance phase (table 1)
        ("clearance_m", "f8"),  # eq. 14: the outer race radius ends at R_out + clearance
        ("pitch_radius_m", "f8"),
        ("ball_mass_kg", "f8"),
        ("ball_inertia_kg_m2", "f8"),
        ("cage_ball_mass_kg", "f8"),  # 0 without cage balls
        ("rigid_cage_mass_kg", "f8"),  # 0 without the rigid cage
        ("rigid_cage_inertia_kg_m2", "f8"),
        ("pocket_gap_m", "f8"),  # R_pocket - R_b: free play of a ball centre in its pocket
        ("pocket_step_cos", "f8"),  # cos, sin of 2 pi / Z, the angle between pockets
        ("pocket_step_sin", "f8"),
        ("inner_ring_mass_kg", "f8"),
        ("radial_load_n", "f8"),
        ("omega_rad_s", "f8"),
        ("clearance_end_s", "f8"),  # ends of the set-up phases (engines.results.phase_times)
        ("load_end_s", "f8"),
        ("spin_up_end_s", "f8"),
        ("gravity_m_s2", "f8"),
        ("friction_coefficient", "f8"),
        ("max_overlap_fraction", "f8"),  # a run stops beyond this overlap / body radius
        # by contact type: F = c delta^{3/2} (Hertz, Harris) or c delta (linear)
        ("normal_coefficient", "f8", (6,)),
        # by contact type: C_n = factor delta^{1/4} (Hertz, eq. 5 with eq. 9) or factor (linear)
        ("normal_damping_factor", "f8", (6,)),
        # inner, outer raceway: K_t = factor sqrt(delta) (Mindlin, eq. 7) or factor (linear)
        ("tangential_stiffness_factor", "f8", (2,)),
        # inner, outer raceway: C_t = factor delta^{1/4} (Hertz) or factor (linear), eq. 5
        ("tangential_damping_factor", "f8", (2,)),
        # defects and abnormal loads (read only by kernels with their flags, spec.SCENE_FLAGS)
        ("defect_count", "i8"),
        ("defect_table", "f8", (TABLE_ROWS, MAX_DEFECTS)),  # physics.defect_geometry.defect_table
        ("contact_radius_m", "f8", (2,)),  # in-plane equivalent radii, inner and outer race
        ("lobes", "f8"),  # out-of-round outer race: A cos(n theta)
        ("lobe_amplitude_m", "f8"),
        ("unbalance_n_s2", "f8"),  # unbalance force / omega^2 (m e), N s^2
        ("unbalance_phase_rad", "f8"),
        ("load_table_count", "i8"),
        ("load_table_time_s", "f8", (MAX_LOAD_TABLE_POINTS,)),  # after the set-up
        ("load_table_load_n", "f8", (MAX_LOAD_TABLE_POINTS,)),
    ]
)


def _param_rows() -> dict[str, int]:
    """First row of each field of :data:`PARAMS` in the ensemble kernel's parameter array (one
    row per scalar, fields flattened in record order)."""
    rows, row = {}, 0
    for name in PARAMS.names:
        rows[name] = row
        row += int(np.prod(PARAMS.fields[name][0].shape, dtype=int))
    rows["_total"] = row
    return rows


#: Rows of the ensemble kernel's parameters, by field of :data:`PARAMS` ("_total": their count).
PARAM_ROWS = _param_rows()


def new_parameters() -> np.void:
    """A zeroed parameter record (fields by name: ``p["dt_s"] = 1e-7``)."""
    return np.zeros(1, PARAMS)[0]


#: Status codes written to status[0]; status[1] step, status[2] body, status[3] contact type
#: (-1: not finite).
OK, OVERLAP, NONFINITE = 0, 1, 2
#: Warm-started roots per contact, ``roots`` (Z, 20), [ball, slot]: 0-1 inner raceway (distance,
#: overlap), 2-3 outer raceway, 4-5 cage ball j on its boundaries, 6-7 cage ball j on ball j (or
#: ball k on ball k + 1 without cage, or ball k in its pocket of the rigid cage), 8-9 cage ball j
#: on ball j + 1; slot + 10 holds an overlap root of the step before.
R_INNER, R_OUTER, R_WALL, R_SIDE0, R_SIDE1 = 0, 2, 4, 6, 8
#: Column of State.xi holding the ball's rotation angle, and of Recording.fcon recording it.
XI_ROTATION, REC_ROTATION = 4, 6


class State(NamedTuple):
    """Everything the time loop carries from one step to the next."""

    pos: np.ndarray  # (N, 2) positions, m
    vel: np.ndarray  # (N, 2) velocities, m/s
    acc: np.ndarray  # (N, 2) accelerations, m/s^2
    spin: np.ndarray  # (Z,) ball spin, rad/s
    spin_acc: np.ndarray  # (Z,) ball spin acceleration, rad/s^2
    # (Z, 5) per-ball contact state, [ball, slot]: 0-1 tangential spring displacement on the
    # inner, outer raceway (m), 2-3 the slip speeds of the step before (m/s), XI_ROTATION the
    # ball's rotation angle (rad, integrated spin; tracked with ball defects only). Kept here, not
    # in a State field of its own: a 13th field made the seed's step 40 % slower (numba passes the
    # tuple to forces() field by field).
    xi: np.ndarray
    roots: np.ndarray  # (Z, 20) warm-started roots, see R_INNER ...
    # (Z, 6) contact forces, N, [ball, kind]: 0 inner normal, 1 outer normal, 2 inner tangential,
    # 3 outer tangential (positive along t = perp(n)), 4 contact with the next body on the pitch
    # circle (cage ball j, or ball j + 1 without cage, or ball j's pocket of the rigid cage, on
    # the ball), 5 contact of cage ball j with ball j + 1
    fcon: np.ndarray
    # (4,) at the last force evaluation: outer race radius (m), applied F_r (N), inner-ring
    # speed (rad/s), drive torque on the inner ring (N m)
    sched: np.ndarray
    # (4,) energy balance, J: work in, dissipated, elastic, (kinetic, recordings only)
    energy: np.ndarray
    # (N + Z, 2) scratch: new accelerations (rows 0..N-1), old spin accelerations (column 0 of
    # rows N..N+Z-1)
    scratch: np.ndarray
    status: np.ndarray  # (4,) int64, see OK, OVERLAP, NONFINITE


class Recording(NamedTuple):
    """What the time loop writes every ``record_every`` steps, R recorded instants."""

    time_s: np.ndarray  # (R,)
    pos: np.ndarray  # (R, N, 2)
    vel: np.ndarray  # (R, N, 2)
    spin: np.ndarray  # (R, Z)
    # (R, Z, 7), as State.fcon in columns 0-5; column REC_ROTATION the ball's rotation angle
    # (State.xi[:, XI_ROTATION], rad; with ball defects only). A column, not a field: a field
    # more would change the time loop's machine code.
    fcon: np.ndarray
    sched: np.ndarray  # (R, 4), as State.sched
    energy: np.ndarray  # (R, 4), as State.energy with the kinetic energy in column 3


def new_state(pos: np.ndarray) -> State:
    """State at rest at positions ``pos`` (N, 2)."""
    z = (pos.shape[0] - 1) // 2
    return State(
        pos=np.ascontiguousarray(pos, dtype=float),
        vel=np.zeros_like(pos, dtype=float),
        acc=np.zeros_like(pos, dtype=float),
        spin=np.zeros(z),
        spin_acc=np.zeros(z),
        xi=np.zeros((z, 5)),
        roots=np.zeros((z, 20)),
        fcon=np.zeros((z, 6)),
        sched=np.zeros(4),
        energy=np.zeros(4),
        scratch=np.zeros((3 * z + 1, 2)),
        status=np.zeros(4, np.int64),
    )


def new_recording(n_instants: int, z: int) -> Recording:
    nb = 2 * z + 1
    return Recording(
        time_s=np.zeros(n_instants),
        pos=np.zeros((n_instants, nb, 2)),
        vel=np.zeros((n_instants, nb, 2)),
        spin=np.zeros((n_instants, z)),
        fcon=np.zeros((n_instants, z, 7)),
        sched=np.zeros((n_instants, 4)),
        energy=np.zeros((n_instants, 4)),
    )
