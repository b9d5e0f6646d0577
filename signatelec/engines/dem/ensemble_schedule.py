"""The schedule of the ensemble kernel (:mod:`.ensemble`): each lane's outer race radius, load
and speed at the time of a force evaluation (.primitives.schedule), the inner ring's applied
force, and the sums of that evaluation set to 0.

:func:`schedule_lanes` makes its pieces for one specialised ensemble kernel from its module
constants, as :func:`.ensemble_cages.cage_contacts` makes the cages' contacts (numba compiles a
closure's variables in as constants and inlines the pieces into the kernel's ``forces``). The
schedule runs lane by lane (its cosines are calls).
"""

from __future__ import annotations

from signatelec.engines.dem.primitives import (
    inline,
    ring_angle_rad,
    schedule,
    scheduled_load,
    unbalance_force,
)

#: The ensemble kernel's constants the schedule reads.
CONSTANTS = (
    "LANES", "BALLS", "T_SHIFT", "DEFECTS_INNER", "UNBALANCE", "LOAD_TABLE", "ENERGY",
    "GRAVITY_STANDARD", "CAGE_RIGID", "P_DT", "VEL", "RING", "SCHED", "RATE", "TIME", "PHI",
    "FLAG", "RING_FX", "RING_FY", "DRIVE", "LOSS", "ELASTIC", "WORK",
)  # fmt: skip


def schedule_lanes(constants: dict):
    """The schedule of every lane, lane by lane, of the ensemble kernel whose module constants
    are ``constants`` (its globals: :data:`CONSTANTS`)."""
    (
        LANES, BALLS, T_SHIFT, DEFECTS_INNER, UNBALANCE, LOAD_TABLE, ENERGY, GRAVITY_STANDARD,
        CAGE_RIGID, P_DT, VEL, RING, SCHED, RATE, TIME, PHI, FLAG, RING_FX, RING_FY, DRIVE, LOSS,
        ELASTIC, WORK,
    ) = (constants[name] for name in CONSTANTS)  # fmt: skip

    @inline
    def schedule_lanes_(step, PR, W):
        """Each lane's schedule (.primitives.schedule: its cosines, from its PR) at its time
        of :func:`.ensemble.forces`, the inner ring's applied force, and the sums of this force
        evaluation set to 0 (one lane at a time: the cosines are calls)."""
        for lane in range(LANES):
            p = PR[lane]
            dt = W[P_DT * LANES + lane]
            t = (step + T_SHIFT) * dt
            r_out, r_rate, fr, omega = schedule(t, p)
            W[SCHED * LANES + lane] = r_out
            W[(SCHED + 1) * LANES + lane] = fr
            phi = ring_angle_rad(t, p) if DEFECTS_INNER or UNBALANCE else 0.0  # inner-ring angle
            if LOAD_TABLE:
                fr = scheduled_load(t, p, fr)
                W[(SCHED + 1) * LANES + lane] = fr
            W[(SCHED + 2) * LANES + lane] = omega
            W[RATE * LANES + lane] = r_rate
            W[TIME * LANES + lane] = t
            W[PHI * LANES + lane] = phi
            W[FLAG * LANES + lane] = 0.0
            g = p.gravity_m_s2 if GRAVITY_STANDARD else 0.0
            ring_fx = 0.0
            ring_fy = -fr - p.inner_ring_mass_kg * g
            work = 0.0
            if UNBALANCE:
                ufx, ufy = unbalance_force(phi, omega, p)
                ring_fx += ufx
                ring_fy += ufy
                if ENERGY:
                    vr = (VEL + 2 * RING) * LANES + lane
                    work += (ufx * W[vr] + ufy * W[vr + LANES]) * dt
            W[RING_FX * LANES + lane] = ring_fx
            W[RING_FY * LANES + lane] = ring_fy
            W[DRIVE * LANES + lane] = 0.0
            W[LOSS * LANES + lane] = 0.0
            W[ELASTIC * LANES + lane] = 0.0
            if ENERGY:
                vel_y = W[(VEL + 2 * RING + 1) * LANES + lane]
                work += -fr * vel_y * dt
                if GRAVITY_STANDARD:
                    wsum = p.inner_ring_mass_kg * vel_y
                    for k in range(BALLS):
                        wsum += (
                            p.ball_mass_kg * W[(VEL + 2 * k + 1) * LANES + lane]
                            + p.cage_ball_mass_kg * W[(VEL + 2 * (BALLS + k) + 1) * LANES + lane]
                        )
                    if CAGE_RIGID:
                        wsum += p.rigid_cage_mass_kg * W[(VEL + 2 * BALLS + 1) * LANES + lane]
                    work += -g * wsum * dt
            W[WORK * LANES + lane] = work

    return schedule_lanes_
