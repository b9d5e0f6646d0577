"""DEM kernel of the 2D bearing: one source, specialised per KernelSpec.

:mod:`signatelec.engines.dem.build` writes this file with its spec block (below) set from a
:class:`~signatelec.engines.dem.spec.KernelSpec` into the kernel cache and compiles that copy with
numba (``cache=True``), so a model that is not chosen is not in the machine code at all. The
spec block holds one boolean per option value the kernel branches on, ``<OPTION>_<VALUE>``
(``CAGE_BALLS``, ``FRICTION_NONE``, ...), or ``<OPTION>`` for a switch (``ENERGY``).

Arguments (:mod:`signatelec.engines.dem.records`): ``p`` a parameter record (``p.dt_s``), ``s``
a :class:`~.records.State`, ``rec`` a :class:`~.records.Recording`. Z balls, N = 2 Z + 1 bodies,
arrays [body, xy]: rows 0..Z-1 the balls, Z..2Z-1 the cage balls (cage ball j sits between ball
j and ball (j + 1) % Z), row 2Z the inner ring. The outer ring is fixed, centred at the origin;
its race radius follows the clearance phase (seed eq. 14). Contact forces ``s.fcon`` (Z, 6),
[ball, kind]: 0 inner normal, 1 outer normal, 2 inner tangential, 3 outer tangential (positive
along t = perp(n)), 4 contact with the next body on the pitch circle (cage ball j, ball j+1
without cage, or ball j's pocket of the rigid cage), 5 contact of cage ball j with ball j+1.
With the rigid cage (CAGE_RIGID) rows Z..2Z-1 hold its coordinates: row Z the centre (x, y), row
Z+1 column 0 the angle theta of pocket 0 (records.py). Every array is float64 unless stated;
nothing is allocated in the time loop.

Integrators: velocity Verlet (2nd order; dissipative forces take the predicted velocity
v + a dt, which keeps 2nd order) or symplectic Euler (1st order, v then x).
"""

# fmt: off
# --- kernel spec: build.specialise rewrites this block from a KernelSpec ----------------------
# (here: the flags this source reads, at the seed scene's values)
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
# --- end of kernel spec -----------------------------------------------------------------------
# fmt: on

import math

from numba import njit

from signatelec.engines.dem.primitives import (
    FASTMATH,
    contact_drop,
    coulomb_limit,
    damped_normal_force,
    first_non_finite,
    inline,
    kinetic_energy,
    lobe_shift,
    ring_angle_rad,
    rquart_warm,
    rsqrt_warm,
    schedule,
    scheduled_load,
    unbalance_force,
)
from signatelec.engines.dem.records import (
    NONFINITE,
    OK,
    OVERLAP,
    R_INNER,
    R_OUTER,
    R_SIDE0,
    R_WALL,
    REC_ROTATION,
    XI_ROTATION,
)
from signatelec.physics import contact as _contact
from signatelec.physics.defect_geometry import INNER_SIDE, OUTER_SIDE

# The contact laws are the functions of signatelec.physics.contact themselves, inlined.
hertz_elastic_energy = inline(_contact.hertz_elastic_energy)
linear_normal_force = inline(_contact.linear_normal_force)
linear_elastic_energy = inline(_contact.linear_elastic_energy)
tangential_force = inline(_contact.tangential_force)
#: Geometry with defects or lobes: a contact's overlap may be <= 0 (a ball over a spall).
SURFACE = DEFECTS_OUTER or DEFECTS_INNER or DEFECTS_BALL or OUT_OF_ROUND
#: Entry points, cached on disk (their callees are compiled into them).
_entry = njit(cache=True, fastmath=FASTMATH, error_model="numpy", _nrt=False)


@inline
def normal_law(overlap, closing_speed, kind, p, roots, k, slot):
    """Elastic and total normal force of one contact of type ``kind`` (seed eqs 3, 5, 8, 9).

    Returns (elastic force, total force, sqrt(delta), delta^{1/4}); the damping is critical with
    the tangent stiffness, C_n = factor delta^{1/4} = contact.hertz_critical_damping (Hertz) or
    constant (linear); sqrt(delta) and delta^{1/4} are reused by the tangential law. The Hertz
    force is contact.hertz_normal_force written with those roots, warm-started from
    roots[k, slot] (the kernel calls this with delta > 0 only); tests/test_kernel_contacts.py
    holds the two equal.
    """
    root = 1.0
    quarter = 1.0
    if SURFACE and not overlap > 0.0:
        return 0.0, 0.0, 0.0, 0.0  # the local surface has dropped away: no contact
    coef = p.normal_coefficient[kind]
    if CONTACT_LAW_LINEAR:
        fe = linear_normal_force(overlap, coef)
    else:
        if not overlap > 0.0:
            # d2 < reach^2 but d = d2 / sqrt(d2) rounded up to reach: touching, no force
            return 0.0, 0.0, 0.0, 0.0
        if DAMPING_CRITICAL:
            y = rquart_warm(overlap, roots, k, slot)
            quarter = overlap * y * y * y
            root = quarter * quarter
        else:
            root = overlap * rsqrt_warm(overlap, roots, k, slot)
        fe = coef * overlap * root
    if DAMPING_CRITICAL:
        fn = damped_normal_force(fe, p.normal_damping_factor[kind] * quarter, closing_speed)
    else:
        fn = max(fe, 0.0)
    return fe, fn, root, quarter


@inline
def normal_contact(overlap, closing_speed, kind, limit_m, body, p, s, k, slot, step):
    """One contact of type ``kind`` with ``overlap`` (> 0 for a Hertz law): its normal force.

    Flags an overlap beyond ``limit_m`` in ``s.status`` (body, kind). Returns (normal force,
    sqrt(delta), delta^{1/4}, energy dissipated by the normal damping over the step, elastic
    energy); the energies are 0 unless the spec has ENERGY.
    """
    if overlap > limit_m:
        s.status[0] = OVERLAP
        s.status[1] = step
        s.status[2] = body
        s.status[3] = kind
    fe, fn, root, quarter = normal_law(overlap, closing_speed, kind, p, s.roots, k, slot)
    loss = 0.0
    elastic = 0.0
    if ENERGY:
        loss = (fn - fe) * closing_speed * p.dt_s
        if CONTACT_LAW_LINEAR:
            elastic = linear_elastic_energy(overlap, p.normal_coefficient[kind])
        else:
            elastic = hertz_elastic_energy(overlap, p.normal_coefficient[kind])
    return fn, root, quarter, loss, elastic


@inline
def tangential_law(k, side, root, quarter, slip_speed, fn, p, xi):
    """Tangential force on a ball/raceway contact: Mindlin stiffness (eq. 7), critical damping
    (eq. 5), seed displacement v_t dt or accumulated spring, Coulomb limit (eq. 4).

    The seed's delta_t = v_t dt makes F_t = -(K_t dt + C_t) v_t: the model itself depends on dt,
    so any integrator converges at first order with it; the accumulated spring does not.
    """
    dt = p.dt_s
    if CONTACT_LAW_LINEAR:
        kt = p.tangential_stiffness_factor[side]
    else:
        kt = p.tangential_stiffness_factor[side] * root  # tangential_stiffness_from_overlap
    ct = 0.0
    if DAMPING_CRITICAL:
        ct = p.tangential_damping_factor[side] * quarter  # critical_damping, K_t ~ sqrt(delta)
    if TANGENTIAL_SPRING:
        # trapezoid rule on d(delta_t)/dt = v_t (xi[:, 2:4] keeps the previous slip speed):
        # second order, like the Verlet step
        disp = xi[k, side] + 0.5 * (xi[k, 2 + side] + slip_speed) * dt
        xi[k, 2 + side] = slip_speed
    else:
        disp = slip_speed * dt
    ft = coulomb_limit(tangential_force(kt, disp, ct, slip_speed), fn, p.friction_coefficient)
    if TANGENTIAL_SPRING:
        # On slip, the spring keeps the displacement that gives the Coulomb force.
        if kt > 0.0:
            xi[k, side] = -(ft + ct * slip_speed) / kt
        else:
            xi[k, side] = 0.0
    return ft


@_entry
def forces(t, p, s, acc, step):
    """Accelerations ``acc`` (N, 2) of every body at time t from the positions and (predicted)
    velocities of ``s``; also writes s.spin_acc, s.fcon, s.sched, s.energy, s.xi, s.roots and,
    on an overlap beyond ``p.max_overlap_fraction`` of a radius, s.status."""
    pos, vel, spin, roots, fcon, xi = s.pos, s.vel, s.spin, s.roots, s.fcon, s.xi
    z = spin.shape[0]
    ring = 2 * z
    dt = p.dt_s
    rb, rc, rin, rp = p.ball_radius_m, p.cage_ball_radius_m, p.inner_race_radius_m, p.pitch_radius_m
    mb, mc, mi = p.ball_mass_kg, p.cage_ball_mass_kg, p.inner_ring_mass_kg
    ball_limit = p.max_overlap_fraction * rb
    cage_limit = p.max_overlap_fraction * rc
    r_out, r_rate, fr, omega = schedule(t, p)
    s.sched[0] = r_out
    s.sched[1] = fr
    phi = ring_angle_rad(t, p) if DEFECTS_INNER or UNBALANCE else 0.0  # inner-ring angle
    if LOAD_TABLE:
        fr = scheduled_load(t, p, fr)
        s.sched[1] = fr
    s.sched[2] = omega
    drive_torque = 0.0
    loss = 0.0
    work = 0.0
    elastic = 0.0
    # External loads: F_r along -y on the inner ring (seed 2.2.2), gravity on every body. The
    # ring's force and each ball's force and torque gather in locals (no loop-carried stores).
    g = p.gravity_m_s2 if GRAVITY_STANDARD else 0.0
    ring_fx = 0.0
    ring_fy = -fr - mi * g
    if not CAGE_BALLS:
        for k in range(z):
            acc[z + k, 0] = 0.0
            acc[z + k, 1] = 0.0
    if UNBALANCE:
        ufx, ufy = unbalance_force(phi, omega, p)
        ring_fx += ufx
        ring_fy += ufy
        if ENERGY:
            work += (ufx * vel[ring, 0] + ufy * vel[ring, 1]) * dt
    if ENERGY:
        work += -fr * vel[ring, 1] * dt
        if GRAVITY_STANDARD:
            wsum = mi * vel[ring, 1]
            for k in range(z):
                wsum += mb * vel[k, 1] + mc * vel[z + k, 1]
            if CAGE_RIGID:
                wsum += p.rigid_cage_mass_kg * vel[z, 1]
            work += -g * wsum * dt
    inv_ib = 1.0 / p.ball_inertia_kg_m2

    for k in range(z):
        x = pos[k, 0]
        y = pos[k, 1]
        ball_fx = 0.0
        ball_fy = -mb * g
        torque = 0.0
        # --- ball / inner raceway -----------------------------------------------------
        dx = x - pos[ring, 0]
        dy = y - pos[ring, 1]
        d2 = dx * dx + dy * dy
        reach = rin + rb
        if d2 < reach * reach:
            inv = rsqrt_warm(d2, roots, k, R_INNER)
            nx = dx * inv
            ny = dy * inv
            rvx = vel[k, 0] - vel[ring, 0]
            rvy = vel[k, 1] - vel[ring, 1]
            vclose = -(rvx * nx + rvy * ny)
            ov = reach - d2 * inv
            if DEFECTS_INNER or DEFECTS_BALL:  # the overlap with the local surface
                ov -= contact_drop(INNER_SIDE, math.atan2(dx, -dy), phi, k, p, s.xi[k, XI_ROTATION])
            fn, rd, qd, dloss, de = normal_contact(
                ov, vclose, 0, ball_limit, k, p, s, k, R_INNER + 1, step
            )
            loss += dloss
            elastic += de
            fx = fn * nx
            fy = fn * ny
            ft = 0.0
            if FRICTION_COULOMB:
                vt = -rvx * ny + rvy * nx - spin[k] * rb - omega * rin
                ft = tangential_law(k, 0, rd, qd, vt, fn, p, xi)
                fx += -ft * ny
                fy += ft * nx
                torque -= rb * ft
                drive_torque += rin * ft
                if ENERGY:
                    loss += -ft * vt * dt
            ball_fx += fx
            ball_fy += fy
            ring_fx -= fx
            ring_fy -= fy
            fcon[k, 0] = fn
            fcon[k, 2] = ft
        else:
            fcon[k, 0] = 0.0
            fcon[k, 2] = 0.0
            if TANGENTIAL_SPRING:
                xi[k, 0] = 0.0
                xi[k, 2] = 0.0
        # --- ball / outer raceway -----------------------------------------------------
        r2 = x * x + y * y
        inside = r_out - rb
        if OUT_OF_ROUND:
            inside -= p.lobe_amplitude_m
        if r2 > inside * inside or CENTRIFUGAL_COMPENSATED:
            inv = rsqrt_warm(r2, roots, k, R_OUTER)
            r = r2 * inv
            nx = x * inv
            ny = y * inv
            if CENTRIFUGAL_COMPENSATED:
                # cancel the centrifugal load: add the centripetal force m v_t^2 / r (inward)
                vtan = -vel[k, 0] * ny + vel[k, 1] * nx
                fcp = mb * vtan * vtan / r
                ball_fx -= fcp * nx
                ball_fy -= fcp * ny
                if ENERGY:
                    work += -fcp * (vel[k, 0] * nx + vel[k, 1] * ny) * dt
        if r2 > inside * inside:
            vclose = vel[k, 0] * nx + vel[k, 1] * ny - r_rate
            ov = r + rb - r_out
            if DEFECTS_OUTER or DEFECTS_BALL or OUT_OF_ROUND:  # the local surface
                theta = math.atan2(x, -y)
                if OUT_OF_ROUND:
                    ov -= lobe_shift(t, theta, p)
                if DEFECTS_OUTER or DEFECTS_BALL:
                    ov -= contact_drop(OUTER_SIDE, theta, phi, k, p, s.xi[k, XI_ROTATION])
            fn, rd, qd, dloss, de = normal_contact(
                ov, vclose, 1, ball_limit, k, p, s, k, R_OUTER + 1, step
            )
            loss += dloss
            elastic += de
            fx = -fn * nx
            fy = -fn * ny
            ft = 0.0
            if FRICTION_COULOMB:
                vt = -vel[k, 0] * ny + vel[k, 1] * nx + spin[k] * rb
                ft = tangential_law(k, 1, rd, qd, vt, fn, p, xi)
                fx += -ft * ny
                fy += ft * nx
                torque += rb * ft
                if ENERGY:
                    loss += -ft * vt * dt
            ball_fx += fx
            ball_fy += fy
            fcon[k, 1] = fn
            fcon[k, 3] = ft
            if ENERGY:
                work += -fn * r_rate * dt
        else:
            fcon[k, 1] = 0.0
            fcon[k, 3] = 0.0
            if TANGENTIAL_SPRING:
                xi[k, 1] = 0.0
                xi[k, 3] = 0.0
        acc[k, 0] = ball_fx
        acc[k, 1] = ball_fy
        s.spin_acc[k] = torque * inv_ib

    if CAGE_BALLS:
        reach = rb + rc
        inv_mc = 1.0 / mc
        for j in range(z):
            c = z + j
            cx = pos[c, 0]
            cy = pos[c, 1]
            cage_fx = 0.0
            cage_fy = -mc * g
            # cage ball / its two frictionless boundaries at r_p -+ r_c (table 2 "cage/cage")
            r2 = cx * cx + cy * cy
            inv = rsqrt_warm(r2, roots, j, R_WALL)
            nx = cx * inv
            ny = cy * inv
            ov = r2 * inv - rp  # > 0: on the outer boundary (pushed in); < 0: on the inner one
            if ov != 0.0:
                sgn = 1.0 if ov > 0.0 else -1.0
                vclose = sgn * (vel[c, 0] * nx + vel[c, 1] * ny)
                fn, rd, qd, dloss, de = normal_contact(
                    abs(ov), vclose, 3, cage_limit, c, p, s, j, R_WALL + 1, step
                )
                loss += dloss
                elastic += de
                cage_fx -= sgn * fn * nx
                cage_fy -= sgn * fn * ny
            # cage ball j against ball j (slot R_SIDE0) and ball j + 1 (R_SIDE1): frictionless
            for side in range(2):
                k = j if side == 0 else (j + 1 if j + 1 < z else 0)
                dx = cx - pos[k, 0]
                dy = cy - pos[k, 1]
                d2 = dx * dx + dy * dy
                if d2 < reach * reach:
                    slot = R_SIDE0 + 2 * side
                    inv = rsqrt_warm(d2, roots, j, slot)
                    nx = dx * inv
                    ny = dy * inv
                    vclose = -((vel[c, 0] - vel[k, 0]) * nx + (vel[c, 1] - vel[k, 1]) * ny)
                    fn, rd, qd, dloss, de = normal_contact(
                        reach - d2 * inv, vclose, 2, cage_limit, c, p, s, j, slot + 1, step
                    )
                    loss += dloss
                    elastic += de
                    cage_fx += fn * nx
                    cage_fy += fn * ny
                    acc[k, 0] -= fn * nx
                    acc[k, 1] -= fn * ny
                    fcon[j, 4 + side] = fn
                else:
                    fcon[j, 4 + side] = 0.0
            acc[c, 0] = cage_fx * inv_mc
            acc[c, 1] = cage_fy * inv_mc
    if CAGE_RIGID:
        # One rigid ring guided by the balls: centre (x, y) in row z, angle theta in row z + 1.
        # Pocket k is a sphere of radius R_b + gap centred at c + r_p u_k, u_k the unit vector
        # at angle theta + 2 pi k / Z from -y (rotated from u_0 pocket by pocket: no trig in the
        # loop). Ball k touches it when its centre is more than the gap from the pocket centre:
        # conformal Hertz contact of type 5 (config.bearing.contact_properties), frictionless
        # like every cage contact of the seed (table 2); the force passes through the pocket
        # centre, so its torque about the cage centre is r_p u_k x F.
        gap = p.pocket_gap_m
        step_c = p.pocket_step_cos
        step_s = p.pocket_step_sin
        ccx = pos[z, 0]
        ccy = pos[z, 1]
        vcx = vel[z, 0]
        vcy = vel[z, 1]
        theta = pos[z + 1, 0]
        wc = vel[z + 1, 0]
        ux = math.sin(theta)
        uy = -math.cos(theta)
        cage_fx = 0.0
        cage_fy = -p.rigid_cage_mass_kg * g
        cage_torque = 0.0
        for k in range(z):
            ox = rp * ux
            oy = rp * uy
            dx = pos[k, 0] - (ccx + ox)
            dy = pos[k, 1] - (ccy + oy)
            d2 = dx * dx + dy * dy
            if d2 > gap * gap:
                inv = rsqrt_warm(d2, roots, k, R_SIDE0)
                nx = dx * inv
                ny = dy * inv
                # closing: ball centre away from the pocket centre (a cage point: v_c + w x r)
                vclose = (vel[k, 0] - vcx + wc * oy) * nx + (vel[k, 1] - vcy - wc * ox) * ny
                fn, rd, qd, dloss, de = normal_contact(
                    d2 * inv - gap, vclose, 5, ball_limit, k, p, s, k, R_SIDE0 + 1, step
                )
                loss += dloss
                elastic += de
                acc[k, 0] -= fn * nx
                acc[k, 1] -= fn * ny
                cage_fx += fn * nx
                cage_fy += fn * ny
                cage_torque += fn * (ox * ny - oy * nx)
                fcon[k, 4] = fn
            else:
                fcon[k, 4] = 0.0
            fcon[k, 5] = 0.0
            ux, uy = ux * step_c - uy * step_s, uy * step_c + ux * step_s
        acc[z, 0] = cage_fx / p.rigid_cage_mass_kg
        acc[z, 1] = cage_fy / p.rigid_cage_mass_kg
        acc[z + 1, 0] = cage_torque / p.rigid_cage_inertia_kg_m2
        acc[z + 1, 1] = 0.0
    if CAGE_NONE:
        reach = 2.0 * rb
        for k in range(z):
            m = k + 1 if k + 1 < z else 0
            dx = pos[m, 0] - pos[k, 0]
            dy = pos[m, 1] - pos[k, 1]
            d2 = dx * dx + dy * dy
            if d2 < reach * reach:
                inv = rsqrt_warm(d2, roots, k, R_SIDE0)
                nx = dx * inv
                ny = dy * inv
                vclose = -((vel[m, 0] - vel[k, 0]) * nx + (vel[m, 1] - vel[k, 1]) * ny)
                fn, rd, qd, dloss, de = normal_contact(
                    reach - d2 * inv, vclose, 4, ball_limit, k, p, s, k, R_SIDE0 + 1, step
                )
                loss += dloss
                elastic += de
                acc[m, 0] += fn * nx
                acc[m, 1] += fn * ny
                acc[k, 0] -= fn * nx
                acc[k, 1] -= fn * ny
                fcon[k, 4] = fn
            else:
                fcon[k, 4] = 0.0
            fcon[k, 5] = 0.0

    # forces -> accelerations
    inv_mb = 1.0 / mb
    for k in range(z):
        acc[k, 0] *= inv_mb
        acc[k, 1] *= inv_mb
    acc[ring, 0] = ring_fx / mi
    acc[ring, 1] = ring_fy / mi
    s.sched[3] = drive_torque
    if ENERGY:
        s.energy[0] += work + drive_torque * omega * dt
        s.energy[1] += loss
        s.energy[2] = elastic


# Not inlined: inlined into run(), this rarely taken branch slowed every step by 30 % (energy on).
@njit(error_model="numpy", _nrt=False)
def record(p, s, rec, i, t):
    """Copy the state into recorded instant ``i`` at time ``t``."""
    z = s.spin.shape[0]
    rec.time_s[i] = t
    for b in range(2 * z + 1):
        rec.pos[i, b, 0] = s.pos[b, 0]
        rec.pos[i, b, 1] = s.pos[b, 1]
        rec.vel[i, b, 0] = s.vel[b, 0]
        rec.vel[i, b, 1] = s.vel[b, 1]
    for k in range(z):
        rec.spin[i, k] = s.spin[k]
        for q in range(6):
            rec.fcon[i, k, q] = s.fcon[k, q]
    for q in range(4):
        rec.sched[i, q] = s.sched[q]
    if DEFECTS_BALL:
        for k in range(z):
            rec.fcon[i, k, REC_ROTATION] = s.xi[k, XI_ROTATION]
    if ENERGY:
        rec.energy[i, 0] = s.energy[0]
        rec.energy[i, 1] = s.energy[1]
        rec.energy[i, 2] = s.energy[2]
        rec.energy[i, 3] = kinetic_energy(p, s)


# No fastmath in the time loop: reassociating v dt + a dt^2 / 2 would let an overflowing
# acceleration stay finite and slip past the divergence check (the step costs the same).
@njit(cache=True, error_model="numpy", _nrt=False)
def run(p, s, rec, step0, n_steps, record_every, rec_index0):
    """Advance state ``s`` by ``n_steps`` from step ``step0``; record into ``rec`` from index
    ``rec_index0`` every ``record_every`` steps.

    Returns the next free record index. Stops at once when ``s.status[0]`` becomes non-zero.
    """
    pos, vel, acc, spin, spin_acc, work2 = s.pos, s.vel, s.acc, s.spin, s.spin_acc, s.scratch
    z = spin.shape[0]
    nb = 2 * z + 1
    dt = p.dt_s
    half_dt2 = 0.5 * dt * dt
    rec_index = rec_index0
    acc_new = work2[:nb]
    # flat views: the update loops run over 2 N contiguous values (and vectorise)
    n2 = 2 * nb
    pos_f = pos.reshape(n2)
    vel_f = vel.reshape(n2)
    acc_f = acc.reshape(n2)
    acc_new_f = work2.reshape(2 * work2.shape[0])[:n2]
    countdown = record_every - step0 % record_every  # steps to the next recorded one
    for i_step in range(n_steps):
        step = step0 + i_step
        t_new = (step + 1) * dt
        if INTEGRATOR_VERLET:
            # positions, then predicted velocities for the dissipative forces (in place)
            for i in range(n2):
                pos_f[i] += vel_f[i] * dt + acc_f[i] * half_dt2
                vel_f[i] += acc_f[i] * dt
            if DEFECTS_BALL:  # each ball's rotation angle, as its position
                for k in range(z):
                    s.xi[k, XI_ROTATION] += spin[k] * dt + spin_acc[k] * half_dt2
            for k in range(z):
                spin[k] += spin_acc[k] * dt
                work2[nb + k, 0] = spin_acc[k]
            t_eval = t_new
        else:
            t_eval = step * dt  # symplectic Euler: forces at (x_n, v_n)
        forces(t_eval, p, s, acc_new, step)
        if INTEGRATOR_VERLET:
            # v_{n+1} = v_pred + (a_new - a_old) dt / 2
            for i in range(n2):
                vel_f[i] += 0.5 * (acc_new_f[i] - acc_f[i]) * dt
                acc_f[i] = acc_new_f[i]
            for k in range(z):
                spin[k] += 0.5 * (spin_acc[k] - work2[nb + k, 0]) * dt
        else:
            # then v_{n+1}, then x_{n+1}
            for i in range(n2):
                acc_f[i] = acc_new_f[i]
                vel_f[i] += acc_f[i] * dt
                pos_f[i] += vel_f[i] * dt
            for k in range(z):
                spin[k] += spin_acc[k] * dt
                if DEFECTS_BALL:
                    s.xi[k, XI_ROTATION] += spin[k] * dt
        if s.status[0] != OK:
            return rec_index
        countdown -= 1
        if countdown == 0:
            countdown = record_every
            bad = first_non_finite(pos, vel)
            if bad >= 0:
                s.status[0] = NONFINITE
                s.status[1] = step
                s.status[2] = bad
                s.status[3] = -1
                return rec_index
            if rec_index < rec.time_s.shape[0]:
                record(p, s, rec, rec_index, t_new)
                rec_index += 1
    return rec_index


@_entry
def start(p, s):
    """Initial accelerations at t = 0 (needed by velocity Verlet)."""
    forces(0.0, p, s, s.acc, 0)
    s.energy[0] = 0.0
    s.energy[1] = 0.0
