"""Ensemble DEM kernel: LANES scenes of one KernelSpec advanced in lockstep, one source
specialised (:mod:`.build`) per KernelSpec (the flags of :mod:`.kernel`), BALLS and LANES.

Every body, contact, parameter and accumulator of the single-scene kernel is a row of LANES
float64 values of one flat array ``W`` (rows: :mod:`.lanes`). The lane loop is the innermost
loop of every contact, its trip count and row offsets compile-time constants, one array written:
LLVM vectorises it (8 lanes of AVX-512). A contact that opens or closes is a select, not a
branch. The physics is that of :mod:`.kernel`, in the same order and with the same functions
(physics.contact; primitives: warm roots, damping, Coulomb limit, the schedule, the load table,
the unbalance, the local surface of defects and lobes from physics.defects); the schedule, with
its cosines, and the local surface, with its loop over the defects, run per lane from ``PR``,
the lanes' parameter records (a defect's geometry is a scene's own: each lane reads its table).
The schedule (:mod:`.ensemble_schedule`) and the cages' contacts (cage balls, ball on ball, the
rigid cage's pockets: :mod:`.ensemble_cages`) are made for this kernel's constants and compiled
into it.

A vector loop computes both sides of every select: with the cold roots in it (a square root and
a division each, .primitives.rsqrt_next), every contact of every step pays them in every lane,
though under 1 % of the updates need them, and the divider bounds the loop. A ball's contact
loop, and a cage ball's boundary contact, therefore run first without them (the Householder
steps alone), keeping the rows they change; the lanes where a warm root was not exact where it
counts (0.07 % of the seed's ball loops, 0.5-0.8 % in its set-up) get their rows back and run
again with them, alone (a function of its own): the single kernel's values in either case, and
a lane's values never depend on the other lanes of its batch (a dataset's traces are the same
however they are grouped). The cage balls' contacts with the balls, which open and close often
(up to 5 % of their loops need a cold root), keep the cold roots.
"""

# fmt: off
# --- kernel spec: build.specialise rewrites this block from a KernelSpec ----------------------
CAGE_BALLS = True
CAGE_RIGID = False
CAGE_NONE = False
FRICTION_COULOMB = True
DAMPING_CRITICAL = True
CONTACT_LAW_LINEAR = False
TANGENTIAL_SPRING = False
GRAVITY_STANDARD = True
CENTRIFUGAL_COMPENSATED = False
ENERGY = False
INTEGRATOR_VERLET = True
DEFECTS_OUTER = False
DEFECTS_INNER = False
DEFECTS_BALL = False
UNBALANCE = False
LOAD_TABLE = False
OUT_OF_ROUND = False
BALLS = 13
LANES = 8
# --- end of kernel spec -----------------------------------------------------------------------
# fmt: on

import math

from numba import njit

from signatelec.engines.dem.ensemble_cages import cage_contacts
from signatelec.engines.dem.ensemble_schedule import schedule_lanes
from signatelec.engines.dem.lanes import (
    PARAMETER_ROWS,
    check_finite,
    copy_rows,
    kinetic_energy,
    record_rows,
    work_rows,
)
from signatelec.engines.dem.primitives import (
    FASTMATH,
    contact_drop,
    coulomb_limit,
    damped_normal_force,
    inline,
    lobe_shift,
    rquart_next,
    rquart_step,
    rsqrt_next,
    rsqrt_step,
)
from signatelec.engines.dem.records import OK, OVERLAP, R_INNER, R_OUTER, R_SIDE0
from signatelec.physics import contact as _contact
from signatelec.physics.defect_geometry import INNER_SIDE, OUTER_SIDE

hertz_elastic_energy = inline(_contact.hertz_elastic_energy)
linear_normal_force = inline(_contact.linear_normal_force)
linear_elastic_energy = inline(_contact.linear_elastic_energy)
tangential_force = inline(_contact.tangential_force)
_entry = njit(cache=True, fastmath=FASTMATH, error_model="numpy", _nrt=False)
#: A ball's contact loop with the cold roots: rare (under 1 % of loops, seed scene), so a
#: function of its own, compiled once, not a second copy inlined into every ball loop.
_cold_loop = njit(fastmath=FASTMATH, error_model="numpy", _nrt=False)
#: Row SAVED + AGAIN: 1 in a lane whose contact loop runs again with the cold roots.
AGAIN = 17

# --- rows of W and of a recorded instant (.lanes; module constants: numba compiles them in) ---
(
    P_DT, P_RB, P_RC, P_RIN, P_RP, P_MB, P_IB, P_MC, P_MI, P_G, P_MU, P_LIMIT, P_LOBE_AMP, P_NCOEF,
    P_NDAMP, P_TSTIFF, P_TDAMP,
) = PARAMETER_ROWS  # fmt: skip
(
    NB, N2, RING, POS, VEL, ACC, ACC_NEW, SPIN, SPIN_ACC, SPIN_OLD, XI, ROT, ROOTS, FCON, SCHED,
    ENERGY_ROW, STATUS, FLAG, RATE, TIME, PHI, RING_FX, RING_FY, DRIVE, LOSS, WORK, ELASTIC,
    INV_MB, INV_MC, DTS, EVERY, COUNTDOWN, REC_INDEX, SURF, POCKET, SAVED, ROWS,
) = work_rows(BALLS)  # fmt: skip
REC_TIME, REC_POS, REC_SPIN, REC_FCON, REC_SCHED, REC_ENERGY, REC_ROT, REC_ROWS = record_rows(BALLS)
#: Geometry with defects or lobes: a contact's overlap may be <= 0 (a ball over a spall).
SURFACE = DEFECTS_OUTER or DEFECTS_INNER or DEFECTS_BALL or OUT_OF_ROUND
#: The forces of step n are evaluated at (n + 1) dt (Verlet) or n dt (symplectic Euler).
T_SHIFT = 1 if INTEGRATOR_VERLET else 0


@inline
def root_lane(x, y, cold):
    """:func:`.primitives.rsqrt_next` of ``x`` from ``y`` and True if ``cold``; else the
    Householder step alone and whether it is exact (no square root, no division)."""
    if cold:
        return rsqrt_next(x, y), True
    return rsqrt_step(x, y)


@inline
def _keep(W, lane, row, slot, restore):
    """Lane ``lane`` of row ``row`` of W into row SAVED + ``slot``, or back (``restore``)."""
    if restore:
        W[row * LANES + lane] = W[(SAVED + slot) * LANES + lane]
    else:
        W[(SAVED + slot) * LANES + lane] = W[row * LANES + lane]


@inline
def normal_lane(overlap, closing_speed, kind, limit_m, body, inside, W, lane, root_row, cold):
    """:func:`.kernel.normal_contact` for one lane, masked by ``inside`` (the contact is open):
    (normal force, sqrt(delta), delta^{1/4}, damping loss, elastic energy, whether the lane
    needed a cold root), zeros when closed. The warm roots at ``root_row`` change only where
    the single-scene kernel changes them (a select: in a vector loop both the warm step and, if
    ``cold``, the cold root are computed; without, the lane's result stands only if exact)."""
    over = inside and overlap > limit_m  # selects, not a branch: the loop stays vectorised
    W[FLAG * LANES + lane] = 1.0 + kind + 8.0 * body if over else W[FLAG * LANES + lane]
    touch = inside
    if SURFACE or not CONTACT_LAW_LINEAR:  # a ball over a spall, or touching without force
        touch = inside and overlap > 0.0
    coef = W[(P_NCOEF + kind) * LANES + lane]
    root = 1.0
    quarter = 1.0
    exact = True
    if CONTACT_LAW_LINEAR:
        fe = linear_normal_force(overlap, coef)
    else:
        at = root_row * LANES + lane
        y_old = W[at]
        if DAMPING_CRITICAL:
            y_older = W[at + 10 * LANES]
            if cold:
                y = rquart_next(overlap, y_old, y_older)
            else:
                y, exact = rquart_step(overlap, y_old, y_older)
            W[at + 10 * LANES] = y_old if touch else y_older
            W[at] = y if touch else y_old
            quarter = overlap * y * y * y
            root = quarter * quarter
        else:
            y, exact = root_lane(overlap, y_old, cold)
            W[at] = y if touch else y_old
            root = overlap * y
        fe = coef * overlap * root
    if DAMPING_CRITICAL:
        fn = damped_normal_force(fe, W[(P_NDAMP + kind) * LANES + lane] * quarter, closing_speed)
    else:
        fn = max(fe, 0.0)
    loss = 0.0
    elastic = 0.0
    if ENERGY:
        loss = (fn - fe) * closing_speed * W[P_DT * LANES + lane]
        if CONTACT_LAW_LINEAR:
            elastic = linear_elastic_energy(overlap, coef)
        else:
            elastic = hertz_elastic_energy(overlap, coef)
        loss, elastic = (loss if touch else 0.0), (elastic if inside else 0.0)
    need = touch and not exact
    if touch:
        return fn, root, quarter, loss, elastic, need
    return 0.0, 0.0, 0.0, loss, elastic, need


@inline
def tangential_lane(k, side, root, quarter, slip_speed, fn, W, lane, inside):
    """:func:`.kernel.tangential_law` for one lane; the spring's state changes only ``inside``."""
    dt = W[P_DT * LANES + lane]
    if CONTACT_LAW_LINEAR:
        kt = W[(P_TSTIFF + side) * LANES + lane]
    else:
        kt = W[(P_TSTIFF + side) * LANES + lane] * root
    ct = 0.0
    if DAMPING_CRITICAL:
        ct = W[(P_TDAMP + side) * LANES + lane] * quarter
    if TANGENTIAL_SPRING:
        at = (XI + 4 * k + side) * LANES + lane
        disp = W[at] + 0.5 * (W[at + 2 * LANES] + slip_speed) * dt
        W[at + 2 * LANES] = slip_speed if inside else 0.0
    else:
        disp = slip_speed * dt
    ft = coulomb_limit(tangential_force(kt, disp, ct, slip_speed), fn, W[P_MU * LANES + lane])
    if TANGENTIAL_SPRING:
        kept = 0.0
        if kt > 0.0:
            kept = -(ft + ct * slip_speed) / kt
        W[at] = kept if inside else 0.0
    return ft


# The schedule of every lane (.ensemble_schedule), made for this kernel's constants.
_schedule_lanes = schedule_lanes(globals())

# The cages' contacts (.ensemble_cages), made for this kernel's constants and normal law.
_cage_ball_lanes, _pair_lanes, _rigid_cage_lanes = cage_contacts(
    globals(), normal_lane, root_lane, _keep, _cold_loop
)


@_entry
def forces(step, PR, W):
    """The new accelerations (rows ACC_NEW, SPIN_ACC) of every lane at its time (step + T_SHIFT)
    dt; also the contact forces, schedule, roots, springs, energy and this step's FLAG."""
    _schedule_lanes(step, PR, W)
    if not CAGE_BALLS:
        for i in range(2 * BALLS * LANES, 4 * BALLS * LANES):
            W[ACC_NEW * LANES + i] = 0.0
    for k in range(BALLS):
        _ball_lanes(k, PR, W)
    # The last cage ball's next ball (0) apart: no index is a select (scalar code). A body's
    # F / m joins the loop of its last contact (a small loop of its own stays scalar).
    if CAGE_BALLS:
        for j in range(BALLS - 1):
            _cage_ball_lanes(j, j + 1, j > 0, False, W)
        _cage_ball_lanes(BALLS - 1, 0, True, True, W)
    if CAGE_RIGID:
        _rigid_cage_lanes(W)
    if CAGE_NONE:  # ball k + 1 on ball k
        for k in range(BALLS - 1):
            _pair_lanes(k + 1, k, 4, P_RB, k, ROOTS + 20 * k + R_SIDE0, FCON + 6 * k + 4, W, 0)
        last = BALLS - 1
        _pair_lanes(0, last, 4, P_RB, last, ROOTS + 20 * last + R_SIDE0, FCON + 6 * last + 4, W, 0)
    for k in range(0 if CAGE_BALLS else BALLS):
        for lane in range(LANES):
            inv_mb = W[INV_MB * LANES + lane]
            W[(ACC_NEW + 2 * k) * LANES + lane] *= inv_mb
            W[(ACC_NEW + 2 * k + 1) * LANES + lane] *= inv_mb
    for lane in range(LANES):
        mi = W[P_MI * LANES + lane]
        W[(ACC_NEW + 2 * RING) * LANES + lane] = W[RING_FX * LANES + lane] / mi
        W[(ACC_NEW + 2 * RING + 1) * LANES + lane] = W[RING_FY * LANES + lane] / mi
        drive = W[DRIVE * LANES + lane]
        W[(SCHED + 3) * LANES + lane] = drive
        if ENERGY:
            omega = W[(SCHED + 2) * LANES + lane]
            dt = W[P_DT * LANES + lane]
            e = ENERGY_ROW * LANES + lane
            W[e] += W[WORK * LANES + lane] + drive * omega * dt
            W[e + LANES] += W[LOSS * LANES + lane]
            W[e + 2 * LANES] = W[ELASTIC * LANES + lane]


@inline
def _ball_lanes(k, PR, W):
    """Ball k on its raceways, every lane: its force (into ACC_NEW), spin acceleration, the
    inner ring's reaction and the drive torque (:func:`.kernel.forces`, ball loop). The local
    surface (defects, lobes) lowers each overlap as in the kernel, from each lane's PR."""
    bx = (POS + 2 * k) * LANES
    ring = (POS + 2 * RING) * LANES
    # The local surface first, in a loop of its own: scalar (its loop over the defects), it
    # leaves the contacts' loop vector; only at the contacts that touch, as in the kernel.
    for lane in range(LANES if SURFACE else 0):
        x = W[bx + lane]
        y = W[bx + LANES + lane]
        phi = W[PHI * LANES + lane]
        rot = W[(ROT + k) * LANES + lane]
        rb = W[P_RB * LANES + lane]
        dx = x - W[ring + lane]
        dy = y - W[ring + LANES + lane]
        reach = W[P_RIN * LANES + lane] + rb
        if (DEFECTS_INNER or DEFECTS_BALL) and dx * dx + dy * dy < reach * reach:
            theta = math.atan2(dx, -dy)
            W[SURF * LANES + lane] = contact_drop(INNER_SIDE, theta, phi, k, PR[lane], rot)
        inside = W[SCHED * LANES + lane] - rb
        if OUT_OF_ROUND:
            inside -= W[P_LOBE_AMP * LANES + lane]
        if not x * x + y * y > inside * inside:
            continue
        theta = math.atan2(x, -y)
        if OUT_OF_ROUND:
            W[(SURF + 1) * LANES + lane] = lobe_shift(W[TIME * LANES + lane], theta, PR[lane])
        if DEFECTS_OUTER or DEFECTS_BALL:
            W[(SURF + 2) * LANES + lane] = contact_drop(OUTER_SIDE, theta, phi, k, PR[lane], rot)
    # Without the cold roots first; the lanes that needed one (rare) again with them from the
    # rows as they were (the loop is the single kernel's in either case, and a lane's values
    # do not depend on the other lanes of its batch).
    if _ball_contacts(k, W, False):
        for lane in range(LANES):
            if W[(SAVED + AGAIN) * LANES + lane] != 0.0:
                _ball_state(k, W, lane, True)
        _ball_contacts_cold(k, W)


@inline
def _ball_state(k, W, lane, restore):
    """Keep in rows SAVED the rows of W that ball k's contact loop changes in lane ``lane``
    (its roots, FLAG, the sums, its springs), or put them back (``restore``)."""
    root = ROOTS + 20 * k
    _keep(W, lane, root + R_INNER, 0, restore)
    _keep(W, lane, root + R_INNER + 1, 1, restore)
    _keep(W, lane, root + R_INNER + 11, 2, restore)
    _keep(W, lane, root + R_OUTER, 3, restore)
    _keep(W, lane, root + R_OUTER + 1, 4, restore)
    _keep(W, lane, root + R_OUTER + 11, 5, restore)
    _keep(W, lane, FLAG, 6, restore)
    _keep(W, lane, DRIVE, 7, restore)
    _keep(W, lane, RING_FX, 8, restore)
    _keep(W, lane, RING_FY, 9, restore)
    if ENERGY:
        _keep(W, lane, LOSS, 10, restore)
        _keep(W, lane, ELASTIC, 11, restore)
        _keep(W, lane, WORK, 12, restore)
    if TANGENTIAL_SPRING:
        for i in range(4):
            _keep(W, lane, XI + 4 * k + i, 13 + i, restore)


@inline
def _ball_contacts(k, W, cold):
    """The contacts of :func:`_ball_lanes`, with the cold roots if ``cold``; the number of
    lanes that needed one (0 if ``cold``)."""
    bx = (POS + 2 * k) * LANES
    ring = (POS + 2 * RING) * LANES
    vb = (VEL + 2 * k) * LANES
    vr = (VEL + 2 * RING) * LANES
    root = (ROOTS + 20 * k) * LANES
    fc = (FCON + 6 * k) * LANES
    cold_lanes = 0
    for lane in range(LANES):
        if cold and W[(SAVED + AGAIN) * LANES + lane] == 0.0:
            continue  # a lane the first pass left exact
        if not cold:  # the rows as they were, for a second pass with the cold roots
            _ball_state(k, W, lane, False)
        dt = W[P_DT * LANES + lane]
        rb = W[P_RB * LANES + lane]
        rin = W[P_RIN * LANES + lane]
        mb = W[P_MB * LANES + lane]
        g = W[P_G * LANES + lane] if GRAVITY_STANDARD else 0.0
        ball_limit = W[P_LIMIT * LANES + lane] * rb
        omega = W[(SCHED + 2) * LANES + lane]
        r_out = W[SCHED * LANES + lane]
        r_rate = W[RATE * LANES + lane]
        spin = W[(SPIN + k) * LANES + lane]
        x = W[bx + lane]
        y = W[bx + LANES + lane]
        vx = W[vb + lane]
        vy = W[vb + LANES + lane]
        ball_fx = 0.0
        ball_fy = -mb * g
        torque = 0.0
        loss = W[LOSS * LANES + lane]
        elastic = W[ELASTIC * LANES + lane]
        work = W[WORK * LANES + lane]
        # --- ball / inner raceway
        dx = x - W[ring + lane]
        dy = y - W[ring + LANES + lane]
        d2 = dx * dx + dy * dy
        reach = rin + rb
        inside = d2 < reach * reach
        at = root + R_INNER * LANES + lane
        inv_old = W[at]
        inv, exact = root_lane(d2, inv_old, cold)
        W[at] = inv if inside else inv_old
        need = inside and not exact
        nx = dx * inv
        ny = dy * inv
        rvx = vx - W[vr + lane]
        rvy = vy - W[vr + LANES + lane]
        vclose = -(rvx * nx + rvy * ny)
        ov = reach - d2 * inv
        if DEFECTS_INNER or DEFECTS_BALL:  # the overlap with the local surface
            ov -= W[SURF * LANES + lane]
        fn, rd, qd, dloss, de, need_root = normal_lane(
            ov, vclose, 0, ball_limit, k, inside, W, lane, ROOTS + 20 * k + R_INNER + 1, cold
        )
        need = need or need_root
        loss += dloss
        elastic += de
        fx = fn * nx
        fy = fn * ny
        ft = 0.0
        if FRICTION_COULOMB:
            vt = -rvx * ny + rvy * nx - spin * rb - omega * rin
            ft = tangential_lane(k, 0, rd, qd, vt, fn, W, lane, inside)
            ft = ft if inside else 0.0
            fx += -ft * ny
            fy += ft * nx
            torque -= rb * ft
            W[DRIVE * LANES + lane] += rin * ft
            if ENERGY:
                loss += -ft * vt * dt if inside else 0.0
        fx = fx if inside else 0.0
        fy = fy if inside else 0.0
        ball_fx += fx
        ball_fy += fy
        W[RING_FX * LANES + lane] -= fx
        W[RING_FY * LANES + lane] -= fy
        W[fc + lane] = fn
        W[fc + 2 * LANES + lane] = ft
        # --- ball / outer raceway
        r2 = x * x + y * y
        inside_r = r_out - rb
        if OUT_OF_ROUND:
            inside_r -= W[P_LOBE_AMP * LANES + lane]
        inside = r2 > inside_r * inside_r
        at = root + R_OUTER * LANES + lane
        inv_old = W[at]
        inv, exact = root_lane(r2, inv_old, cold)
        W[at] = inv if (inside or CENTRIFUGAL_COMPENSATED) else inv_old
        need = need or ((inside or CENTRIFUGAL_COMPENSATED) and not exact)
        r = r2 * inv
        nx = x * inv
        ny = y * inv
        if CENTRIFUGAL_COMPENSATED:
            vtan = -vx * ny + vy * nx
            fcp = mb * vtan * vtan / r
            ball_fx -= fcp * nx
            ball_fy -= fcp * ny
            if ENERGY:
                work += -fcp * (vx * nx + vy * ny) * dt
        vclose = vx * nx + vy * ny - r_rate
        ov = r + rb - r_out
        if OUT_OF_ROUND:  # the local surface
            ov -= W[(SURF + 1) * LANES + lane]
        if DEFECTS_OUTER or DEFECTS_BALL:
            ov -= W[(SURF + 2) * LANES + lane]
        fn, rd, qd, dloss, de, need_root = normal_lane(
            ov, vclose, 1, ball_limit, k, inside, W, lane, ROOTS + 20 * k + R_OUTER + 1, cold
        )
        need = need or need_root
        W[(SAVED + AGAIN) * LANES + lane] = 1.0 if need else 0.0
        cold_lanes += need
        loss += dloss
        elastic += de
        fx = -fn * nx
        fy = -fn * ny
        ft = 0.0
        if FRICTION_COULOMB:
            vt = -vx * ny + vy * nx + spin * rb
            ft = tangential_lane(k, 1, rd, qd, vt, fn, W, lane, inside)
            ft = ft if inside else 0.0
            fx += -ft * ny
            fy += ft * nx
            torque += rb * ft
            if ENERGY:
                loss += -ft * vt * dt if inside else 0.0
        ball_fx = ball_fx + fx if inside else ball_fx
        ball_fy = ball_fy + fy if inside else ball_fy
        W[fc + LANES + lane] = fn
        W[fc + 3 * LANES + lane] = ft
        if ENERGY:
            work += -fn * r_rate * dt
            W[LOSS * LANES + lane] = loss
            W[ELASTIC * LANES + lane] = elastic
            W[WORK * LANES + lane] = work
        W[(ACC_NEW + 2 * k) * LANES + lane] = ball_fx
        W[(ACC_NEW + 2 * k + 1) * LANES + lane] = ball_fy
        W[(SPIN_ACC + k) * LANES + lane] = torque / W[P_IB * LANES + lane]  # as kernel.py's
    return cold_lanes


@_cold_loop
def _ball_contacts_cold(k, W):
    """:func:`_ball_contacts` with the cold roots."""
    _ball_contacts(k, W, True)


@njit(error_model="numpy", _nrt=False)
def record(W, rec, i, lane, step):
    """Copy lane ``lane``'s state into its recorded instant ``i`` (rows REC_*) after ``step``."""
    rec[i, REC_TIME * LANES + lane] = (step + 1) * W[P_DT * LANES + lane]
    copy_rows(W, POS, rec, i, REC_POS, 2 * N2, lane, LANES)  # positions then velocities
    copy_rows(W, SPIN, rec, i, REC_SPIN, BALLS, lane, LANES)
    copy_rows(W, FCON, rec, i, REC_FCON, 6 * BALLS, lane, LANES)
    copy_rows(W, SCHED, rec, i, REC_SCHED, 4, lane, LANES)
    if DEFECTS_BALL:
        copy_rows(W, ROT, rec, i, REC_ROT, BALLS, lane, LANES)
    if ENERGY:
        copy_rows(W, ENERGY_ROW, rec, i, REC_ENERGY, 3, lane, LANES)
        e = kinetic_energy(W, lane, LANES, BALLS, VEL, SPIN)
        rec[i, (REC_ENERGY + 3) * LANES + lane] = e


# No fastmath in the time loop (as kernel.run: the divergence check must see an overflow).
@njit(cache=True, error_model="numpy", _nrt=False)
def run(PR, W, rec, step0, n_steps):
    """Advance every lane of ``W`` by ``n_steps`` from step ``step0`` (:func:`.kernel.run`, lane
    by lane); each lane records into its column of ``rec`` every W[EVERY] steps of its own (its
    record interval: lanes of other time steps or sample rates share a call), at its next free
    index W[REC_INDEX].

    Returns the number of lanes still running. A lane that diverges keeps its first status (the
    lanes are independent: its values reach no other lane) and runs on; the run stops when
    every lane has diverged."""
    for i_step in range(n_steps):
        step = step0 + i_step
        # flat loops at constant offsets (dt from DTS): LLVM proves the rows apart, vectorises
        if INTEGRATOR_VERLET:
            for r in range(N2 * LANES):
                dt = W[DTS * LANES + r]
                a = W[ACC * LANES + r]
                W[POS * LANES + r] += W[VEL * LANES + r] * dt + a * (0.5 * dt * dt)
                W[VEL * LANES + r] += a * dt
            if DEFECTS_BALL:  # each ball's rotation angle, as its position
                for r in range(BALLS * LANES):
                    dt = W[DTS * LANES + r]
                    spin_step = W[SPIN_ACC * LANES + r] * (0.5 * dt * dt)
                    W[ROT * LANES + r] += W[SPIN * LANES + r] * dt + spin_step
            for r in range(BALLS * LANES):
                dt = W[DTS * LANES + r]
                W[SPIN * LANES + r] += W[SPIN_ACC * LANES + r] * dt
                W[SPIN_OLD * LANES + r] = W[SPIN_ACC * LANES + r]
        forces(step, PR, W)
        if INTEGRATOR_VERLET:
            for r in range(N2 * LANES):
                a_new = W[ACC_NEW * LANES + r]
                W[VEL * LANES + r] += 0.5 * (a_new - W[ACC * LANES + r]) * W[DTS * LANES + r]
                W[ACC * LANES + r] = a_new
            for r in range(BALLS * LANES):
                dt = W[DTS * LANES + r]
                W[SPIN * LANES + r] += (
                    0.5 * (W[SPIN_ACC * LANES + r] - W[SPIN_OLD * LANES + r]) * dt
                )
        else:
            for r in range(N2 * LANES):
                dt = W[DTS * LANES + r]
                a_new = W[ACC_NEW * LANES + r]
                W[ACC * LANES + r] = a_new
                W[VEL * LANES + r] += a_new * dt
                W[POS * LANES + r] += W[VEL * LANES + r] * dt
            for r in range(BALLS * LANES):
                W[SPIN * LANES + r] += W[SPIN_ACC * LANES + r] * W[DTS * LANES + r]
                if DEFECTS_BALL:
                    W[ROT * LANES + r] += W[SPIN * LANES + r] * W[DTS * LANES + r]
        running = 0
        for lane in range(LANES):  # a vector reduction; lane by lane only when one stops
            running += W[STATUS * LANES + lane] == OK and W[FLAG * LANES + lane] == 0.0
        for lane in range(LANES if running < LANES else 0):
            if W[STATUS * LANES + lane] == OK:
                if W[FLAG * LANES + lane] != 0.0:
                    code = W[FLAG * LANES + lane] - 1.0
                    W[STATUS * LANES + lane] = OVERLAP
                    W[(STATUS + 1) * LANES + lane] = step
                    W[(STATUS + 2) * LANES + lane] = code // 8.0
                    W[(STATUS + 3) * LANES + lane] = code % 8.0
        if running == 0:
            return 0
        due = 0
        for lane in range(LANES):  # each lane's countdown to its next recorded step (a vector)
            left = W[COUNTDOWN * LANES + lane] - 1.0
            due += left == 0.0
            W[COUNTDOWN * LANES + lane] = W[EVERY * LANES + lane] if left == 0.0 else left
        for lane in range(LANES if due else 0):
            if W[COUNTDOWN * LANES + lane] == W[EVERY * LANES + lane]:  # just reset: due
                check_finite(W, step, lane, LANES, NB, POS, VEL, STATUS)
                i = int(W[REC_INDEX * LANES + lane])
                if i < rec.shape[0]:
                    record(W, rec, i, lane, step)
                    W[REC_INDEX * LANES + lane] = i + 1
    return running


@_entry
def start(PR, W):
    """Initial accelerations at t = 0 of every lane (needed by velocity Verlet)."""
    for lane in range(LANES):  # reciprocal masses, once per run
        W[INV_MB * LANES + lane] = 1.0 / W[P_MB * LANES + lane]
        W[INV_MC * LANES + lane] = 1.0 / W[P_MC * LANES + lane]
    for r in range(N2 * LANES):  # each lane's dt, once per body coordinate (run's loops)
        W[DTS * LANES + r] = W[P_DT * LANES + r % LANES]
    for lane in range(LANES):  # step 0: each lane's first record after EVERY steps
        W[COUNTDOWN * LANES + lane] = W[EVERY * LANES + lane]
        W[REC_INDEX * LANES + lane] = 0.0
    forces(-T_SHIFT, PR, W)
    for r in range(N2 * LANES):
        W[ACC * LANES + r] = W[ACC_NEW * LANES + r]
    for r in range(2 * LANES):
        W[ENERGY_ROW * LANES + r] = 0.0
