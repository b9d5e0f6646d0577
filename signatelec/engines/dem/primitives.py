"""Numba pieces of the DEM kernel that no kernel option changes: warm-started roots, the set-up
schedule (and the load table, the inner ring's angle, the unbalance), the local surface of
defects and lobes (signatelec.physics.defects), scalar contact limits, checks.

They are inlined into (or linked with) the specialised kernel of :mod:`.kernel`, whose cache key
covers this file (:mod:`.build`). Arrays as in :mod:`.records`.
"""

from __future__ import annotations

import math

from numba import njit

from signatelec.physics.defects import lobe_shift_m, surface_drop_m, tabulated_load_n

# No nnan/ninf: the divergence check relies on math.isfinite. The time loop and the functions it
# calls run without numba's reference counting (_nrt=False in the kernel): they allocate
# nothing, and the atomic increments and decrements of every array passed to forces() each step
# cost 20 % of it.
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}
#: Inlined helpers: compiled as part of their caller, whose cache holds them.
inline = njit(inline="always", fastmath=FASTMATH, error_model="numpy")

# Warm-started roots. Every contact keeps the inverse square root of its centre distance and the
# inverse fourth root of its overlap in State.roots. A step changes a centre distance by a
# relative 1e-9 to 1e-5, so a Householder correction of order 4 from the old value, with
# r = 1 - x y^2 (1 - x y^4), is exact to below 1 ulp where |r| < 2^-13, and replaces a square root
# and a division (the divider bounds this kernel). Overlaps change faster, so their guess is
# extrapolated linearly from the two steps before; under 1 % of updates (first touches, the zero
# cache) fall back to the roots computed directly (seed scene). tests/test_kernel_contacts.py
# holds warm and cold equal.
WARM = 2.0**-13


@inline
def rsqrt_step(x, y):
    """The Householder step from the guess ``y`` to 1 / sqrt(x), and whether it is exact
    (|r| < WARM; else the root must be computed cold, 1 / sqrt(x))."""
    r = 1.0 - x * y * y
    # (1 - r)^(-1/2) = 1 + r/2 + 3r^2/8 + 5r^3/16 + O(r^4)
    return y * (1.0 + r * (0.5 + r * (0.375 + r * 0.3125))), abs(r) < WARM


@inline
def rquart_step(x, y_old, y_older):
    """The step from the roots of the two steps before (extrapolated linearly) to x^(-1/4), and
    whether it is exact (else 1 / sqrt(sqrt(x)))."""
    y = 2.0 * y_old - y_older
    y2 = y * y
    r = 1.0 - x * y2 * y2
    # (1 - r)^(-1/4) = 1 + r/4 + 5r^2/32 + 15r^3/128 + O(r^4)
    return y * (1.0 + r * (0.25 + r * (0.15625 + r * 0.1171875))), abs(r) < WARM and y > 0.0


@inline
def rsqrt_next(x, y):
    """1 / sqrt(x) from the guess ``y``: the Householder step where exact, else a cold root."""
    y_new, exact = rsqrt_step(x, y)
    if exact:
        return y_new
    return 1.0 / math.sqrt(x)


@inline
def rquart_next(x, y_old, y_older):
    """x^(-1/4) from the roots of the two steps before (extrapolated, then corrected)."""
    y_new, exact = rquart_step(x, y_old, y_older)
    if exact:
        return y_new
    return 1.0 / math.sqrt(math.sqrt(x))


@inline
def rsqrt_warm(x, roots, k, slot):
    """1 / sqrt(x), warm-started from roots[k, slot] and stored back there."""
    y = rsqrt_next(x, roots[k, slot])
    roots[k, slot] = y
    return y


@inline
def rquart_warm(x, roots, k, slot):
    """x^(-1/4), warm-started from roots[k, slot] and stored back there."""
    y_old = roots[k, slot]
    y = rquart_next(x, y_old, roots[k, slot + 10])
    roots[k, slot + 10] = y_old
    roots[k, slot] = y
    return y


@inline
def schedule(t, p):
    """Outer race radius and its rate, applied F_r, inner-ring speed at time t (seed 2.2.1-2.2.2).

    Phase ends t1 (clearance), t2 (load), t3 (spin-up); a zero-length phase is a step.
    Ramps follow (1 - cos(pi s)) / 2, the sinusoidal profile of the seed.
    """
    t1, t2, t3 = p.clearance_end_s, p.load_end_s, p.spin_up_end_s
    r_out = p.outer_race_radius_m + p.clearance_m
    r_rate = 0.0
    if t < t1:
        s = t / t1
        r_out = p.outer_race_radius_m + p.clearance_m * 0.5 * (1.0 - math.cos(math.pi * s))
        r_rate = p.clearance_m * 0.5 * math.pi / t1 * math.sin(math.pi * s)
    fr = p.radial_load_n
    if t < t1:
        fr = 0.0
    elif t < t2:
        fr = p.radial_load_n * 0.5 * (1.0 - math.cos(math.pi * (t - t1) / (t2 - t1)))
    omega = p.omega_rad_s
    if t < t2:
        omega = 0.0
    elif t < t3:
        omega = p.omega_rad_s * 0.5 * (1.0 - math.cos(math.pi * (t - t2) / (t3 - t2)))
    return r_out, r_rate, fr, omega


@inline
def scheduled_load(t, p, fr):
    """F_r at time t with the load table (physics.defects.tabulated_load_n, times after the
    set-up); ``fr`` the schedule's during the set-up."""
    if t < p.spin_up_end_s:
        return fr
    times, loads = p.load_table_time_s, p.load_table_load_n
    return tabulated_load_n(t - p.spin_up_end_s, times, loads, p.load_table_count, fr)


@inline
def ring_angle_rad(t, p):
    """Inner-ring angle phi(t), the integral of the schedule's speed (the quasi-static tier's
    inner_ring_angle_rad), rad."""
    t2, t3, omega = p.load_end_s, p.spin_up_end_s, p.omega_rad_s
    if t <= t2:
        return 0.0
    if t < t3:
        u, ramp = t - t2, t3 - t2
        return 0.5 * omega * (u - ramp / math.pi * math.sin(math.pi * u / ramp))
    return omega * (0.5 * (t3 - t2) + t - t3)


@inline
def unbalance_force(phi, omega, p):
    """The unbalance m e omega^2 turning with the inner ring, at phi + its phase from -y, N."""
    force = p.unbalance_n_s2 * omega * omega
    angle = phi + p.unbalance_phase_rad
    return force * math.sin(angle), -force * math.cos(angle)


@inline
def lobe_shift(t, theta, p):
    """Out-of-round outer race at angle theta, m; the lobes grow over the clearance phase as
    the clearance does (eq. 14), so the balls do not start inside the race."""
    ramp = 1.0
    if t < p.clearance_end_s:
        ramp = 0.5 * (1.0 - math.cos(math.pi * t / p.clearance_end_s))
    return ramp * lobe_shift_m(theta, p.lobes, p.lobe_amplitude_m)


@inline
def contact_drop(side, theta, phi, k, p, ball_angle):
    """Drop of the local surface under ball k's contact on ``side`` (physics.defects), the
    ball turned by ``ball_angle``."""
    table, count, radius = p.defect_table, p.defect_count, p.contact_radius_m[side]
    return surface_drop_m(side, theta, phi, k, ball_angle, table, count, radius)


# Scalar forms of contact.damped_normal_force and contact.coulomb_limit: numpy's maximum, minimum
# and sign carry NaN handling the kernel does not need (tests/test_kernel_contacts.py holds them
# equal to the contact module).
@inline
def damped_normal_force(elastic_force_n, damping_n_s_m, closing_speed_m_s):
    return max(elastic_force_n + damping_n_s_m * closing_speed_m_s, 0.0)


@inline
def coulomb_limit(tangential_force_n, normal_force_n, friction_coefficient):
    limit = friction_coefficient * max(normal_force_n, 0.0)
    return min(max(tangential_force_n, -limit), limit)


@njit(fastmath=FASTMATH, error_model="numpy", _nrt=False)
def kinetic_energy(p, s):
    """Kinetic energy of every body of state ``s``, J (the cage balls' or the rigid cage's: the
    other's mass is 0)."""
    z = s.spin.shape[0]
    vel = s.vel
    e = 0.5 * p.inner_ring_mass_kg * (vel[2 * z, 0] ** 2 + vel[2 * z, 1] ** 2)
    e += 0.5 * p.rigid_cage_mass_kg * (vel[z, 0] ** 2 + vel[z, 1] ** 2)
    e += 0.5 * p.rigid_cage_inertia_kg_m2 * vel[z + 1, 0] ** 2
    for k in range(z):
        e += 0.5 * p.ball_mass_kg * (vel[k, 0] ** 2 + vel[k, 1] ** 2)
        e += 0.5 * p.ball_inertia_kg_m2 * s.spin[k] ** 2
        e += 0.5 * p.cage_ball_mass_kg * (vel[z + k, 0] ** 2 + vel[z + k, 1] ** 2)
    return e


# No fastmath: under its flags LLVM folds math.isfinite(x) to True.
@njit(error_model="numpy", _nrt=False)
def first_non_finite(pos, vel):
    """Index of the first body whose position or velocity is not finite, else -1."""
    for i in range(pos.shape[0]):
        if not math.isfinite(pos[i, 0] + pos[i, 1] + vel[i, 0] + vel[i, 1]):
            return i
    return -1
