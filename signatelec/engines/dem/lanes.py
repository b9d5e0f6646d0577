"""Layout of the ensemble kernel's (:mod:`.ensemble`) work array and recording, and the pieces
of its step loop that no kernel flag changes.

Every body, contact, parameter (:data:`.records.PARAM_ROWS`) and accumulator of the single-scene
kernel is a row of LANES float64 values of one flat array ``W``: ``W[row * LANES + lane]``; a
recorded instant is ``REC_ROWS`` such rows. The rows depend on the number of balls only
(:func:`work_rows`, :func:`record_rows`); the specialised ensemble kernel unpacks them into
module constants, which numba compiles in (constant offsets let LLVM prove rows apart and
vectorise the lane loops). :mod:`.batch` packs and unpacks the same rows.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from numba import njit

from signatelec.engines.dem.primitives import FASTMATH
from signatelec.engines.dem.records import NONFINITE, OK, PARAM_ROWS

# --- rows of the parameters in W (records.PARAM_ROWS) ---------------------------------------
P_DT, P_RB, P_RC, P_RIN, P_RP, P_MB, P_IB, P_MC, P_MI, P_G, P_MU, P_LIMIT, P_LOBE_AMP = (
    PARAM_ROWS[name]
    for name in (
        "dt_s", "ball_radius_m", "cage_ball_radius_m", "inner_race_radius_m", "pitch_radius_m",
        "ball_mass_kg", "ball_inertia_kg_m2", "cage_ball_mass_kg", "inner_ring_mass_kg",
        "gravity_m_s2", "friction_coefficient", "max_overlap_fraction", "lobe_amplitude_m",
    )
)  # fmt: skip
P_CAGE_M, P_CAGE_I, P_GAP, P_STEP_COS, P_STEP_SIN = (
    PARAM_ROWS[name]
    for name in (
        "rigid_cage_mass_kg", "rigid_cage_inertia_kg_m2", "pocket_gap_m", "pocket_step_cos",
        "pocket_step_sin",
    )
)  # fmt: skip
P_NCOEF = PARAM_ROWS["normal_coefficient"]  # 6 rows each, by contact type; then 2 by raceway
P_NDAMP, P_TSTIFF, P_TDAMP = (
    PARAM_ROWS[f"{name}_factor"]
    for name in ("normal_damping", "tangential_stiffness", "tangential_damping")
)

#: The parameter rows the ensemble kernel reads, in the order it unpacks them.
PARAMETER_ROWS = (
    P_DT, P_RB, P_RC, P_RIN, P_RP, P_MB, P_IB, P_MC, P_MI, P_G, P_MU, P_LIMIT, P_LOBE_AMP, P_NCOEF,
    P_NDAMP, P_TSTIFF, P_TDAMP,
)  # fmt: skip


class WorkRows(NamedTuple):
    """First row of each block of W for Z balls (blocks of one row unless stated)."""

    NB: int  # bodies, 2 Z + 1
    N2: int  # body coordinates
    RING: int  # the inner ring's body
    POS: int  # N2 rows, [body, xy] as State.pos (the parameters come first)
    VEL: int  # N2
    ACC: int  # N2
    ACC_NEW: int  # N2
    SPIN: int  # Z
    SPIN_ACC: int  # Z
    SPIN_OLD: int  # Z
    XI: int  # 4 per ball, as State.xi[:, :4]
    ROT: int  # Z: each ball's rotation angle, State.xi[:, XI_ROTATION] (ball defects)
    ROOTS: int  # 20 per ball, as State.roots
    FCON: int  # 6 per ball, as State.fcon
    SCHED: int  # 4, as State.sched
    ENERGY_ROW: int  # 4, as State.energy
    STATUS: int  # 4, as State.status (as floats)
    FLAG: int  # this step's overlap: 0, or 1 + kind + 8 body (one masked store a contact)
    RATE: int  # the outer race radius' rate
    TIME: int  # the time of this force evaluation
    PHI: int  # the inner ring's angle at that time (inner defects, unbalance)
    RING_FX: int  # accumulators of one force evaluation: the inner ring's force,
    RING_FY: int
    DRIVE: int  # the drive torque,
    LOSS: int  # energy dissipated, work in, elastic energy
    WORK: int
    ELASTIC: int
    INV_MB: int  # reciprocal masses
    INV_MC: int
    DTS: int  # N2: each lane's dt, once per body coordinate (the update loops read it)
    EVERY: int  # each lane's record interval, steps
    COUNTDOWN: int  # steps to its next recorded one
    REC_INDEX: int  # its next free recorded instant
    SURF: int  # 3: under the ball of this contact loop, the inner drop, lobes, outer drop
    POCKET: int  # 5: the rigid cage's pocket direction u_k (x, y), its force (x, y), torque
    SAVED: int  # 18: the rows a ball's contact loop changes, as they were before it, and
    # whether each lane needs the loop again with the cold roots
    ROWS: int  # the total


def work_rows(balls: int) -> WorkRows:
    """The rows of W for ``balls`` balls (:class:`WorkRows`)."""
    nb = 2 * balls + 1
    sizes = {
        "POS": 2 * nb, "VEL": 2 * nb, "ACC": 2 * nb, "ACC_NEW": 2 * nb, "SPIN": balls,
        "SPIN_ACC": balls, "SPIN_OLD": balls, "XI": 4 * balls, "ROT": balls,
        "ROOTS": 20 * balls, "FCON": 6 * balls, "SCHED": 4, "ENERGY_ROW": 4, "STATUS": 4,
        "FLAG": 1, "RATE": 1, "TIME": 1, "PHI": 1, "RING_FX": 1, "RING_FY": 1, "DRIVE": 1,
        "LOSS": 1, "WORK": 1, "ELASTIC": 1, "INV_MB": 1, "INV_MC": 1, "DTS": 2 * nb,
        "EVERY": 1, "COUNTDOWN": 1, "REC_INDEX": 1, "SURF": 3, "POCKET": 5,
        "SAVED": 18,
    }  # fmt: skip
    rows = {"NB": nb, "N2": 2 * nb, "RING": 2 * balls}
    row = PARAM_ROWS["_total"]
    for name, size in sizes.items():
        rows[name] = row
        row += size
    return WorkRows(**rows, ROWS=row)


class RecordRows(NamedTuple):
    """First row of each block of one recorded instant for Z balls."""

    REC_TIME: int  # 1
    REC_POS: int  # positions then velocities, 2 N2
    REC_SPIN: int  # Z
    REC_FCON: int  # 6 Z
    REC_SCHED: int  # 4
    REC_ENERGY: int  # 4 (the kinetic energy in the last)
    REC_ROT: int  # Z: the balls' rotation angles (ball defects)
    REC_ROWS: int  # the total


def record_rows(balls: int) -> RecordRows:
    """The rows of one recorded instant for ``balls`` balls (:class:`RecordRows`)."""
    n2 = 2 * (2 * balls + 1)
    rows, row = [], 0
    for size in (1, 2 * n2, balls, 6 * balls, 4, 4, balls):
        rows.append(row)
        row += size
    return RecordRows(*rows, row)


@njit(error_model="numpy", _nrt=False)
def copy_rows(W, w_row, rec, i, rec_row, n_rows, lane, lanes):
    """Lane ``lane`` of rows ``w_row`` .. ``w_row + n_rows`` of W into its recorded instant
    ``i`` from ``rec_row``."""
    for r in range(n_rows):
        rec[i, (rec_row + r) * lanes + lane] = W[(w_row + r) * lanes + lane]


@njit(fastmath=FASTMATH, error_model="numpy", _nrt=False)
def kinetic_energy(W, lane, lanes, balls, vel_row, spin_row):
    """:func:`.primitives.kinetic_energy` of one lane, J (the cage balls' or the rigid cage's:
    the other's mass is 0)."""
    mb = W[P_MB * lanes + lane]
    ib = W[P_IB * lanes + lane]
    mc = W[P_MC * lanes + lane]
    v = vel_row * lanes + lane
    ring = 2 * balls
    e = (
        0.5
        * W[P_MI * lanes + lane]
        * (W[v + 2 * ring * lanes] ** 2 + W[v + (2 * ring + 1) * lanes] ** 2)
    )
    cage = v + 2 * balls * lanes  # the rigid cage's centre, then its angle
    e += 0.5 * W[P_CAGE_M * lanes + lane] * (W[cage] ** 2 + W[cage + lanes] ** 2)
    e += 0.5 * W[P_CAGE_I * lanes + lane] * W[cage + 2 * lanes] ** 2
    for k in range(balls):
        e += 0.5 * mb * (W[v + 2 * k * lanes] ** 2 + W[v + (2 * k + 1) * lanes] ** 2)
        e += 0.5 * ib * W[(spin_row + k) * lanes + lane] ** 2
        c = balls + k
        e += 0.5 * mc * (W[v + 2 * c * lanes] ** 2 + W[v + (2 * c + 1) * lanes] ** 2)
    return e


# No fastmath: under its flags LLVM folds math.isfinite(x) to True.
@njit(error_model="numpy", _nrt=False)
def check_finite(W, step, lane, lanes, nb, pos_row, vel_row, status_row):
    """Flag (status NONFINITE) lane ``lane``, if still OK and its positions or velocities are
    not finite."""
    if W[status_row * lanes + lane] != OK:
        return
    for b in range(nb):
        x = W[(pos_row + 2 * b) * lanes + lane] + W[(pos_row + 2 * b + 1) * lanes + lane]
        v = W[(vel_row + 2 * b) * lanes + lane] + W[(vel_row + 2 * b + 1) * lanes + lane]
        if not math.isfinite(x + v):
            W[status_row * lanes + lane] = NONFINITE
            W[(status_row + 1) * lanes + lane] = step
            W[(status_row + 2) * lanes + lane] = b
            W[(status_row + 3) * lanes + lane] = -1
            return
