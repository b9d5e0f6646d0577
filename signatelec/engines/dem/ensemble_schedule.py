"""The schedule of the ensemble kernel (:mod:`.ensemble`): each lane's outer race radius, load
and speed at the time of a force evaluation (.primitives.schedule), the inner ring's applied
force, and the sums of that evaluation set to 0.

:func:`schedule_lanes` makes its pieces for one specialised ensemble kernel from its module
constants, as :func:`.ensemble_cages.cage_contacts` makes the cages' contacts (numba compiles a
closure's variables in as constants and inlines the pieces into the kernel's ``forces``). During
the set-up the schedule runs lane by lane (its cosines are calls); once every lane is past its
set-up, its constant end values run in one loop over the lanes.
"""

from __future__ import annotations

from signatelec.engines.dem.lanes import (
    P_CLEARANCE,
    P_LOAD,
    P_OMEGA,
    P_R_OUT,
    P_T1,
    P_T2,
    P_T3,
)
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
    "GRAVITY_STANDARD", "CAGE_RIGID", "P_DT", "P_G", "P_MI", "VEL", "RING", "SCHED", "RATE",
    "TIME", "PHI", "FLAG", "RING_FX", "RING_FY", "DRIVE", "LOSS", "ELASTIC", "WORK",
)  # fmt: skip


def schedule_lanes(constants: dict):
    """(steady_loop, past_setup, steady_lanes, schedule_lanes) of the ensemble kernel whose
    module constants are ``constants`` (its globals: :data:`CONSTANTS`): whether the kernel's
    effects let the schedule's end values run in one loop, how many lanes are past their
    set-up, that loop, and the schedule lane by lane."""
    (
        LANES, BALLS, T_SHIFT, DEFECTS_INNER, UNBALANCE, LOAD_TABLE, ENERGY, GRAVITY_STANDARD,
        CAGE_RIGID, P_DT, P_G, P_MI, VEL, RING, SCHED, RATE, TIME, PHI, FLAG, RING_FX, RING_FY,
        DRIVE, LOSS, ELASTIC, WORK,
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

    # Effects of the schedule that steady_lanes does not carry.
    steady_loop = not (LOAD_TABLE or UNBALANCE or DEFECTS_INNER or ENERGY)

    @inline
    def past_setup(step, W):
        """How many lanes are past their set-up (clearance, load, spin-up) at the time of
        :func:`.ensemble.forces`."""
        done = 0
        for lane in range(LANES):
            t = (step + T_SHIFT) * W[P_DT * LANES + lane]
            end = max(W[P_T1 * LANES + lane], W[P_T2 * LANES + lane], W[P_T3 * LANES + lane])
            done += t >= end
        return done

    @inline
    def steady_lanes(step, W):
        """schedule_lanes_ when every lane is past its set-up: the schedule's constant end
        values (.primitives.schedule), from the rows of W, without calls or branches."""
        for lane in range(LANES):
            t = (step + T_SHIFT) * W[P_DT * LANES + lane]
            fr = W[P_LOAD * LANES + lane]
            W[SCHED * LANES + lane] = W[P_R_OUT * LANES + lane] + W[P_CLEARANCE * LANES + lane]
            W[(SCHED + 1) * LANES + lane] = fr
            W[(SCHED + 2) * LANES + lane] = W[P_OMEGA * LANES + lane]
            W[RATE * LANES + lane] = 0.0
            W[TIME * LANES + lane] = t
            W[PHI * LANES + lane] = 0.0
            W[FLAG * LANES + lane] = 0.0
            g = W[P_G * LANES + lane] if GRAVITY_STANDARD else 0.0
            W[RING_FX * LANES + lane] = 0.0
            W[RING_FY * LANES + lane] = -fr - W[P_MI * LANES + lane] * g
            W[DRIVE * LANES + lane] = 0.0
            W[LOSS * LANES + lane] = 0.0
            W[ELASTIC * LANES + lane] = 0.0
            W[WORK * LANES + lane] = 0.0

    return steady_loop, past_setup, steady_lanes, schedule_lanes_
