"""DEM kernel of the 2D bearing, specialised per effect set.

This file is a template: :mod:`signatelec.engines.dem.build` copies it with the flag block below set
for one effect set and compiles that copy with numba (``cache=True``), so an effect that is off
is not in the machine code at all. Every array is float64 unless stated; nothing is allocated in
the time loop.

Bodies, shape (N, 2) with N = 2 Z + 1, [body, xy]: rows 0..Z-1 the balls, Z..2Z-1 the cage balls
(cage ball j sits between ball j and ball (j + 1) % Z), row 2Z the inner ring. The outer ring is
fixed, centred at the origin; its race radius follows the clearance phase (seed eq. 14).

Contact forces ``fcon``, shape (Z, 6), [ball, kind]: 0 inner normal, 1 outer normal, 2 inner
tangential, 3 outer tangential (positive along t = perp(n)), 4 contact with the next body on the
pitch circle (cage ball j, or ball j+1 without cage), 5 contact of cage ball j with ball j+1.

Integrators: velocity Verlet (2nd order; dissipative forces take the predicted velocity
v + a dt, which keeps 2nd order) or symplectic Euler (1st order, v then x).
"""

# fmt: off
# --- specialisation flags (the line below is rewritten per effect set) -----------------------
CAGE, FRICTION, DAMPING, LINEAR, SPRING, GRAVITY, CENTRIFUGAL, ENERGY, VERLET = (True, True, True, False, False, True, True, False, True)  # noqa: E501
# fmt: on

import math

import numpy as np
from numba import njit

from signatelec.physics import contact as _contact

# No nnan/ninf: the divergence check relies on math.isfinite. The time loop and the functions it
# calls run without numba's reference counting (_nrt=False): they allocate nothing, and the
# atomic increments and decrements of every array passed to forces() each step cost 20 % of it.
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}
_jit = njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
hertz_elastic_energy = _jit(_contact.hertz_elastic_energy)
linear_normal_force = _jit(_contact.linear_normal_force)
linear_elastic_energy = _jit(_contact.linear_elastic_energy)
tangential_force = _jit(_contact.tangential_force)


# Scalar forms of contact.damped_normal_force and contact.coulomb_limit: numpy's maximum, minimum
# and sign carry NaN handling the kernel does not need (tests/test_kernel_contacts.py holds them
# equal to the contact module).
@_jit
def damped_normal_force(elastic_force_n, damping_n_s_m, closing_speed_m_s):
    return max(elastic_force_n + damping_n_s_m * closing_speed_m_s, 0.0)


@_jit
def coulomb_limit(tangential_force_n, normal_force_n, friction_coefficient):
    limit = friction_coefficient * max(normal_force_n, 0.0)
    return min(max(tangential_force_n, -limit), limit)


# Parameter vector layout (see signatelec.engines.dem.run.kernel_parameters).
P_DT, P_RB, P_RC, P_RIN, P_ROUT0, P_CLEAR, P_RP = 0, 1, 2, 3, 4, 5, 6
P_MB, P_IB, P_MC, P_MI, P_FR, P_OMEGA, P_T1, P_T2, P_T3 = 7, 8, 9, 10, 11, 12, 13, 14, 15
P_G, P_MU, P_MAXFRAC = 16, 17, 18
P_COEF = 20  # 5 normal-law coefficients, by contact type
P_MRED = 25  # 5 reduced masses, by contact type
P_KT = 30  # 2 tangential stiffness factors (inner, outer): K_t = P_KT * sqrt(delta) (Hertz)
P_DN = 32  # 5 normal damping factors: C_n = P_DN * delta^{1/4} (Hertz) or P_DN (linear)
P_DTG = 37  # 2 tangential damping factors (inner, outer), same form
N_PARAMS = 40

# Status codes written to status[0]; status[1] step, status[2] body, status[3] contact type.
OK, OVERLAP, NONFINITE = 0, 1, 2

# Warm-started roots. Every contact keeps the inverse square root of its centre distance and the
# inverse fourth root of its overlap in ``roots`` (Z, 20), [ball, slot]: 0-1 inner raceway
# (distance, overlap), 2-3 outer raceway, 4-5 cage ball j on its boundaries, 6-7 cage ball j on
# ball j (or ball k on ball k + 1 without cage), 8-9 cage ball j on ball j + 1; slot + 10 holds an
# overlap root of the step before. A step changes a centre distance by a relative 1e-9 to 1e-5,
# so a Householder correction of order 4 from the old value, with r = 1 - x y^2 (1 - x y^4), is
# exact to below 1 ulp where |r| < 2^-13, and replaces a square root and a division (the
# divider bounds this kernel). Overlaps change faster, so their guess is extrapolated linearly
# from the two steps before; under 1 % of updates (first touches, the zero cache) fall back to
# the roots computed directly (seed scene). tests/test_kernel_contacts.py holds warm and cold
# equal.
R_INNER, R_OUTER, R_WALL, R_SIDE0, R_SIDE1 = 0, 2, 4, 6, 8
WARM = 2.0**-13


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def rsqrt_warm(x, roots, k, slot):
    """1 / sqrt(x), warm-started from roots[k, slot] and stored back there."""
    y = roots[k, slot]
    r = 1.0 - x * y * y
    if abs(r) < WARM:
        # (1 - r)^(-1/2) = 1 + r/2 + 3r^2/8 + 5r^3/16 + O(r^4)
        y = y * (1.0 + r * (0.5 + r * (0.375 + r * 0.3125)))
    else:
        y = 1.0 / math.sqrt(x)
    roots[k, slot] = y
    return y


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def rquart_warm(x, roots, k, slot):
    """x^(-1/4), warm-started from roots[k, slot] and stored back there."""
    y_old = roots[k, slot]
    y = 2.0 * y_old - roots[k, slot + 10]
    y2 = y * y
    r = 1.0 - x * y2 * y2
    if abs(r) < WARM and y > 0.0:
        # (1 - r)^(-1/4) = 1 + r/4 + 5r^2/32 + 15r^3/128 + O(r^4)
        y = y * (1.0 + r * (0.25 + r * (0.15625 + r * 0.1171875)))
    else:
        y = 1.0 / math.sqrt(math.sqrt(x))
    roots[k, slot + 10] = y_old
    roots[k, slot] = y
    return y


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def schedule(t, p):
    """Outer race radius and its rate, applied F_r, inner-ring speed at time t (seed 2.2.1-2.2.2).

    Phase ends t1 (clearance), t2 (load), t3 (spin-up); a zero-length phase is a step.
    Ramps follow (1 - cos(pi s)) / 2, the sinusoidal profile of the seed.
    """
    t1, t2, t3 = p[P_T1], p[P_T2], p[P_T3]
    r_out = p[P_ROUT0] + p[P_CLEAR]
    r_rate = 0.0
    if t < t1:
        s = t / t1
        r_out = p[P_ROUT0] + p[P_CLEAR] * 0.5 * (1.0 - math.cos(math.pi * s))
        r_rate = p[P_CLEAR] * 0.5 * math.pi / t1 * math.sin(math.pi * s)
    fr = p[P_FR]
    if t < t1:
        fr = 0.0
    elif t < t2:
        fr = p[P_FR] * 0.5 * (1.0 - math.cos(math.pi * (t - t1) / (t2 - t1)))
    omega = p[P_OMEGA]
    if t < t2:
        omega = 0.0
    elif t < t3:
        omega = p[P_OMEGA] * 0.5 * (1.0 - math.cos(math.pi * (t - t2) / (t3 - t2)))
    return r_out, r_rate, fr, omega


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def normal_law(overlap, closing_speed, kind, p, roots, k, slot):
    """Elastic and total normal force of one contact of type ``kind`` (seed eqs 3, 5, 8, 9).

    Returns (elastic force, total force, sqrt(delta), delta^{1/4}); the damping is critical with
    the tangent stiffness, C_n = P_DN delta^{1/4} = contact.hertz_critical_damping (Hertz) or
    constant (linear); sqrt(delta) and delta^{1/4} are reused by the tangential law. The Hertz
    force is contact.hertz_normal_force written with those roots, warm-started from
    roots[k, slot] (the kernel calls this with delta > 0 only); tests/test_kernel_contacts.py
    holds the two equal.
    """
    root = 1.0
    quarter = 1.0
    if LINEAR:
        fe = linear_normal_force(overlap, p[P_COEF + kind])
    else:
        if not overlap > 0.0:
            # d2 < reach^2 but d = d2 / sqrt(d2) rounded up to reach: touching, no force
            return 0.0, 0.0, 0.0, 0.0
        if DAMPING:
            y = rquart_warm(overlap, roots, k, slot)
            quarter = overlap * y * y * y
            root = quarter * quarter
        else:
            root = overlap * rsqrt_warm(overlap, roots, k, slot)
        fe = p[P_COEF + kind] * overlap * root
    if DAMPING:
        fn = damped_normal_force(fe, p[P_DN + kind] * quarter, closing_speed)
    else:
        fn = max(fe, 0.0)
    return fe, fn, root, quarter


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def tangential_law(k, side, root, quarter, slip_speed, fn, p, xi, dt):
    """Tangential force on a ball/raceway contact: Mindlin stiffness (eq. 7), critical damping
    (eq. 5), seed displacement v_t dt or accumulated spring, Coulomb limit (eq. 4).

    The seed's delta_t = v_t dt makes F_t = -(K_t dt + C_t) v_t: the model itself depends on dt,
    so any integrator converges at first order with it; the accumulated spring does not.
    """
    if LINEAR:
        kt = p[P_KT + side]
    else:
        kt = p[P_KT + side] * root  # contact.tangential_stiffness_from_overlap
    ct = 0.0
    if DAMPING:
        ct = p[P_DTG + side] * quarter  # critical_damping(kt, m*) with kt ~ sqrt(delta)
    if SPRING:
        # trapezoid rule on d(delta_t)/dt = v_t (xi[:, 2:4] keeps the previous slip speed):
        # second order, like the Verlet step
        disp = xi[k, side] + 0.5 * (xi[k, 2 + side] + slip_speed) * dt
        xi[k, 2 + side] = slip_speed
    else:
        disp = slip_speed * dt
    ft = coulomb_limit(tangential_force(kt, disp, ct, slip_speed), fn, p[P_MU])
    if SPRING:
        # On slip, the spring keeps the displacement that gives the Coulomb force.
        if kt > 0.0:
            xi[k, side] = -(ft + ct * slip_speed) / kt
        else:
            xi[k, side] = 0.0
    return ft


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", _nrt=False)
def forces(t, p, pos, vel, spin, acc, spin_acc, xi, roots, fcon, sched, energy, status, step):  # noqa: E501
    """Accelerations of every body at time t from positions and (predicted) velocities."""
    z = spin.shape[0]
    ring = 2 * z
    dt = p[P_DT]
    rb, rc, rin, rp = p[P_RB], p[P_RC], p[P_RIN], p[P_RP]
    mb, ib, mc, mi = p[P_MB], p[P_IB], p[P_MC], p[P_MI]
    maxfrac = p[P_MAXFRAC]
    r_out, r_rate, fr, omega = schedule(t, p)
    sched[0] = r_out
    sched[1] = fr
    sched[2] = omega
    drive_torque = 0.0
    loss = 0.0
    work = 0.0
    elastic = 0.0
    # External loads: F_r along -y on the inner ring (seed 2.2.2), gravity on every body. The
    # ring's force and each ball's force and torque gather in locals (no loop-carried stores).
    g = p[P_G] if GRAVITY else 0.0
    ring_fx = 0.0
    ring_fy = -fr - mi * g
    if not CAGE:
        for k in range(z):
            acc[z + k, 0] = 0.0
            acc[z + k, 1] = 0.0
    if ENERGY:
        work += -fr * vel[ring, 1] * dt
        if GRAVITY:
            wsum = mi * vel[ring, 1]
            for k in range(z):
                wsum += mb * vel[k, 1] + mc * vel[z + k, 1]
            work += -g * wsum * dt
    inv_ib = 1.0 / ib

    cin = p[P_COEF + 0]
    cout = p[P_COEF + 1]
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
            d = d2 * inv
            nx = dx * inv
            ny = dy * inv
            ov = reach - d
            if ov > maxfrac * rb:
                status[0] = OVERLAP
                status[1] = step
                status[2] = k
                status[3] = 0
            rvx = vel[k, 0] - vel[ring, 0]
            rvy = vel[k, 1] - vel[ring, 1]
            vclose = -(rvx * nx + rvy * ny)
            fe, fn, rd, qd = normal_law(ov, vclose, 0, p, roots, k, R_INNER + 1)
            fx = fn * nx
            fy = fn * ny
            ft = 0.0
            if FRICTION:
                vt = -rvx * ny + rvy * nx - spin[k] * rb - omega * rin
                ft = tangential_law(k, 0, rd, qd, vt, fn, p, xi, dt)
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
            if ENERGY:
                loss += (fn - fe) * vclose * dt
                if LINEAR:
                    elastic += linear_elastic_energy(ov, cin)
                else:
                    elastic += hertz_elastic_energy(ov, cin)
        else:
            fcon[k, 0] = 0.0
            fcon[k, 2] = 0.0
            if SPRING:
                xi[k, 0] = 0.0
                xi[k, 2] = 0.0
        # --- ball / outer raceway -----------------------------------------------------
        r2 = x * x + y * y
        inside = r_out - rb
        if r2 > inside * inside or not CENTRIFUGAL:
            inv = rsqrt_warm(r2, roots, k, R_OUTER)
            r = r2 * inv
            nx = x * inv
            ny = y * inv
            if not CENTRIFUGAL:
                # cancel the centrifugal load: add the centripetal force m v_t^2 / r (inward)
                vtan = -vel[k, 0] * ny + vel[k, 1] * nx
                fcp = mb * vtan * vtan / r
                ball_fx -= fcp * nx
                ball_fy -= fcp * ny
                if ENERGY:
                    work += -fcp * (vel[k, 0] * nx + vel[k, 1] * ny) * dt
        if r2 > inside * inside:
            ov = r + rb - r_out
            if ov > maxfrac * rb:
                status[0] = OVERLAP
                status[1] = step
                status[2] = k
                status[3] = 1
            vclose = vel[k, 0] * nx + vel[k, 1] * ny - r_rate
            fe, fn, rd, qd = normal_law(ov, vclose, 1, p, roots, k, R_OUTER + 1)
            fx = -fn * nx
            fy = -fn * ny
            ft = 0.0
            if FRICTION:
                vt = -vel[k, 0] * ny + vel[k, 1] * nx + spin[k] * rb
                ft = tangential_law(k, 1, rd, qd, vt, fn, p, xi, dt)
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
                loss += (fn - fe) * vclose * dt
                work += -fn * r_rate * dt
                if LINEAR:
                    elastic += linear_elastic_energy(ov, cout)
                else:
                    elastic += hertz_elastic_energy(ov, cout)
        else:
            fcon[k, 1] = 0.0
            fcon[k, 3] = 0.0
            if SPRING:
                xi[k, 1] = 0.0
                xi[k, 3] = 0.0
        acc[k, 0] = ball_fx
        acc[k, 1] = ball_fy
        spin_acc[k] = torque * inv_ib

    if CAGE:
        cbc = p[P_COEF + 2]
        cwall = p[P_COEF + 3]
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
            r = r2 * inv
            nx = cx * inv
            ny = cy * inv
            ov = r - rp  # > 0: on the outer boundary (pushed in); < 0: on the inner one
            if ov != 0.0:
                sgn = 1.0 if ov > 0.0 else -1.0
                aov = abs(ov)
                if aov > maxfrac * rc:
                    status[0] = OVERLAP
                    status[1] = step
                    status[2] = c
                    status[3] = 3
                vclose = sgn * (vel[c, 0] * nx + vel[c, 1] * ny)
                fe, fn, rd, qd = normal_law(aov, vclose, 3, p, roots, j, R_WALL + 1)
                cage_fx -= sgn * fn * nx
                cage_fy -= sgn * fn * ny
                if ENERGY:
                    loss += (fn - fe) * vclose * dt
                    if LINEAR:
                        elastic += linear_elastic_energy(aov, cwall)
                    else:
                        elastic += hertz_elastic_energy(aov, cwall)
            # cage ball j against ball j (slot 4) and ball j + 1 (slot 5): frictionless
            for side in range(2):
                k = j if side == 0 else (j + 1 if j + 1 < z else 0)
                dx = cx - pos[k, 0]
                dy = cy - pos[k, 1]
                d2 = dx * dx + dy * dy
                if d2 < reach * reach:
                    slot = R_SIDE0 + 2 * side
                    inv = rsqrt_warm(d2, roots, j, slot)
                    d = d2 * inv
                    nx = dx * inv
                    ny = dy * inv
                    ov = reach - d
                    if ov > maxfrac * rc:
                        status[0] = OVERLAP
                        status[1] = step
                        status[2] = c
                        status[3] = 2
                    vclose = -((vel[c, 0] - vel[k, 0]) * nx + (vel[c, 1] - vel[k, 1]) * ny)
                    fe, fn, rd, qd = normal_law(ov, vclose, 2, p, roots, j, slot + 1)
                    cage_fx += fn * nx
                    cage_fy += fn * ny
                    acc[k, 0] -= fn * nx
                    acc[k, 1] -= fn * ny
                    fcon[j, 4 + side] = fn
                    if ENERGY:
                        loss += (fn - fe) * vclose * dt
                        if LINEAR:
                            elastic += linear_elastic_energy(ov, cbc)
                        else:
                            elastic += hertz_elastic_energy(ov, cbc)
                else:
                    fcon[j, 4 + side] = 0.0
            acc[c, 0] = cage_fx * inv_mc
            acc[c, 1] = cage_fy * inv_mc
    else:
        cbb = p[P_COEF + 4]
        reach = 2.0 * rb
        for k in range(z):
            m = k + 1 if k + 1 < z else 0
            dx = pos[m, 0] - pos[k, 0]
            dy = pos[m, 1] - pos[k, 1]
            d2 = dx * dx + dy * dy
            if d2 < reach * reach:
                inv = rsqrt_warm(d2, roots, k, R_SIDE0)
                d = d2 * inv
                nx = dx * inv
                ny = dy * inv
                ov = reach - d
                if ov > maxfrac * rb:
                    status[0] = OVERLAP
                    status[1] = step
                    status[2] = k
                    status[3] = 4
                vclose = -((vel[m, 0] - vel[k, 0]) * nx + (vel[m, 1] - vel[k, 1]) * ny)
                fe, fn, rd, qd = normal_law(ov, vclose, 4, p, roots, k, R_SIDE0 + 1)
                acc[m, 0] += fn * nx
                acc[m, 1] += fn * ny
                acc[k, 0] -= fn * nx
                acc[k, 1] -= fn * ny
                fcon[k, 4] = fn
                if ENERGY:
                    loss += (fn - fe) * vclose * dt
                    if LINEAR:
                        elastic += linear_elastic_energy(ov, cbb)
                    else:
                        elastic += hertz_elastic_energy(ov, cbb)
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
    sched[3] = drive_torque
    if ENERGY:
        energy[0] += work + drive_torque * omega * dt
        energy[1] += loss
        energy[2] = elastic


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", _nrt=False)
def kinetic_energy(p, vel, spin):
    z = spin.shape[0]
    e = 0.5 * p[P_MI] * (vel[2 * z, 0] ** 2 + vel[2 * z, 1] ** 2)
    for k in range(z):
        e += 0.5 * p[P_MB] * (vel[k, 0] ** 2 + vel[k, 1] ** 2) + 0.5 * p[P_IB] * spin[k] ** 2
        e += 0.5 * p[P_MC] * (vel[z + k, 0] ** 2 + vel[z + k, 1] ** 2)
    return e


@njit(cache=True, error_model="numpy", _nrt=False)
def first_non_finite(pos, vel):
    """Index of the first body whose position or velocity is not finite, else -1."""
    for i in range(pos.shape[0]):
        if not math.isfinite(pos[i, 0] + pos[i, 1] + vel[i, 0] + vel[i, 1]):
            return i
    return -1


# No fastmath in the time loop: reassociating v dt + a dt^2 / 2 would let an overflowing
# acceleration stay finite and slip past the divergence check (the step costs the same).
@njit(cache=True, error_model="numpy", _nrt=False)
def run(
    p,
    pos,
    vel,
    acc,
    spin,
    spin_acc,
    xi,
    roots,
    fcon,
    sched,
    energy,
    work2,
    step0,
    n_steps,
    record_every,
    rec_index0,
    rec_time,
    rec_pos,
    rec_vel,
    rec_spin,
    rec_fcon,
    rec_sched,
    rec_energy,
    status,
):
    """Advance ``n_steps`` from step ``step0``; record every ``record_every`` steps.

    ``work2`` is scratch of shape (N + Z, 2) (new accelerations and spin accelerations). Returns
    the next free record index. Stops at once when ``status[0]`` becomes non-zero.
    """
    z = spin.shape[0]
    nb = 2 * z + 1
    dt = p[P_DT]
    half_dt2 = 0.5 * dt * dt
    rec = rec_index0
    acc_new = work2[:nb]
    # flat views: the update loops run over 2 N contiguous values (and vectorise)
    n2 = 2 * nb
    pos_f = pos.reshape(n2)
    vel_f = vel.reshape(n2)
    acc_f = acc.reshape(n2)
    acc_new_f = work2.reshape(2 * work2.shape[0])[:n2]
    countdown = record_every - step0 % record_every  # steps to the next recorded one
    for s in range(n_steps):
        step = step0 + s
        t_new = (step + 1) * dt
        if VERLET:
            # positions, then predicted velocities for the dissipative forces (in place)
            for i in range(n2):
                pos_f[i] += vel_f[i] * dt + acc_f[i] * half_dt2
                vel_f[i] += acc_f[i] * dt
            for k in range(z):
                spin[k] += spin_acc[k] * dt
                work2[nb + k, 0] = spin_acc[k]
            t_eval = t_new
        else:
            t_eval = step * dt  # symplectic Euler: forces at (x_n, v_n)
        forces(t_eval, p, pos, vel, spin, acc_new, spin_acc, xi, roots, fcon, sched, energy, status, step)  # noqa: E501  # fmt: skip
        if VERLET:
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
        if status[0] != OK:
            return rec
        countdown -= 1
        if countdown == 0:
            countdown = record_every
            bad = first_non_finite(pos, vel)
            if bad >= 0:
                status[0] = NONFINITE
                status[1] = step
                status[2] = bad
                status[3] = -1
                return rec
            if rec < rec_time.shape[0]:
                rec_time[rec] = t_new
                for i in range(nb):
                    rec_pos[rec, i, 0] = pos[i, 0]
                    rec_pos[rec, i, 1] = pos[i, 1]
                    rec_vel[rec, i, 0] = vel[i, 0]
                    rec_vel[rec, i, 1] = vel[i, 1]
                for k in range(z):
                    rec_spin[rec, k] = spin[k]
                    for q in range(6):
                        rec_fcon[rec, k, q] = fcon[k, q]
                for q in range(4):
                    rec_sched[rec, q] = sched[q]
                if ENERGY:
                    rec_energy[rec, 0] = energy[0]
                    rec_energy[rec, 1] = energy[1]
                    rec_energy[rec, 2] = energy[2]
                    rec_energy[rec, 3] = kinetic_energy(p, vel, spin)
                rec += 1
    return rec


@njit(cache=True, fastmath=FASTMATH, error_model="numpy", _nrt=False)
def start(p, pos, vel, acc, spin, spin_acc, xi, roots, fcon, sched, energy, status):
    """Initial accelerations at t = 0 (needed by velocity Verlet)."""
    forces(0.0, p, pos, vel, spin, acc, spin_acc, xi, roots, fcon, sched, energy, status, 0)
    energy[0] = 0.0
    energy[1] = 0.0


_unused = np  # numpy is imported for numba's typing of the shared contact functions
