"""The cages' contacts of the ensemble kernel (:mod:`.ensemble`): the cage balls' (on their
boundaries and their two balls), ball on ball without a cage, and the rigid cage's pockets.

:func:`cage_contacts` makes them for one specialised ensemble kernel from its module constants
(flags, BALLS, LANES, the rows of W) and its ``normal_lane``: numba compiles a closure's
variables in as constants and inlines these functions into the kernel's ``forces``, so each is
the code it would be written in :mod:`.ensemble` itself (an off flag is not in the machine code,
the lane loops' trip counts and row offsets are constants). The physics is that of
:func:`.kernel.forces`, in the same order.
"""

from __future__ import annotations

import math

from signatelec.engines.dem.lanes import P_CAGE_I, P_CAGE_M, P_GAP, P_STEP_COS, P_STEP_SIN
from signatelec.engines.dem.primitives import inline, rsqrt_next
from signatelec.engines.dem.records import R_SIDE0, R_SIDE1, R_WALL

#: The ensemble kernel's constants the cages' contacts read.
CONSTANTS = (
    "LANES", "BALLS", "ENERGY", "GRAVITY_STANDARD", "POS", "VEL", "ACC_NEW", "ROOTS", "FCON",
    "LOSS", "ELASTIC", "INV_MB", "INV_MC", "POCKET", "FLAG", "SAVED", "AGAIN", "P_RB", "P_RC",
    "P_RP", "P_G", "P_MC", "P_LIMIT",
)  # fmt: skip


def cage_contacts(constants: dict, normal_lane, root_lane, keep, cold_loop):
    """(cage_ball_lanes, pair_lanes, rigid_cage_lanes) of the ensemble kernel whose module
    constants are ``constants`` (its globals: :data:`CONSTANTS`), normal law ``normal_lane``,
    warm root ``root_lane``, row keeper ``keep`` and decorator of a loop with the cold roots
    ``cold_loop``: a cage ball's boundary contact runs as a ball's (:mod:`.ensemble`), first
    without the cold roots, again with them where a lane needed one."""
    (
        LANES, BALLS, ENERGY, GRAVITY_STANDARD, POS, VEL, ACC_NEW, ROOTS, FCON, LOSS, ELASTIC,
        INV_MB, INV_MC, POCKET, FLAG, SAVED, AGAIN, P_RB, P_RC, P_RP, P_G, P_MC, P_LIMIT,
    ) = (constants[name] for name in CONSTANTS)  # fmt: skip

    @inline
    def add_energy(W, lane, loss, elastic):
        """A contact's damping loss and elastic energy into this force evaluation's sums."""
        if ENERGY:
            W[LOSS * LANES + lane] += loss
            W[ELASTIC * LANES + lane] += elastic

    @inline
    def cage_ball_lanes(j, nxt, last_j, last_nxt, W):
        """Cage ball j on its boundaries, balls j and ``nxt`` (j + 1); a lane loop per contact.
        ``last_j``, ``last_nxt``: that contact is the ball's last (its F / m follows)."""
        if wall_lanes(j, W, False):  # as a ball's contacts (.ensemble._ball_lanes)
            for lane in range(LANES):
                if W[(SAVED + AGAIN) * LANES + lane] != 0.0:
                    wall_state(j, W, lane, True)
            wall_lanes_cold(j, W)
        # cage ball j against ball j (slot R_SIDE0) and ball j + 1 (R_SIDE1), then F / m
        c = BALLS + j
        root = ROOTS + 20 * j
        pair_lanes(c, j, 2, P_RC, c, root + R_SIDE0, FCON + 6 * j + 4, W, 1 if last_j else 0)
        pair_lanes(c, nxt, 2, P_RC, c, root + R_SIDE1, FCON + 6 * j + 5, W, 3 if last_nxt else 2)

    @inline
    def wall_state(j, W, lane, restore):
        """Keep (or put back) the rows cage ball j's boundary contact changes in lane ``lane``."""
        root = ROOTS + 20 * j + R_WALL
        keep(W, lane, root, 0, restore)
        keep(W, lane, root + 1, 1, restore)
        keep(W, lane, root + 11, 2, restore)
        keep(W, lane, FLAG, 3, restore)
        if ENERGY:
            keep(W, lane, LOSS, 4, restore)
            keep(W, lane, ELASTIC, 5, restore)

    @inline
    def wall_lanes(j, W, cold):
        """Cage ball j on its boundaries at r_p -+ r_c, every lane, with the cold roots if
        ``cold``: its weight and that force into its row of ACC_NEW; the number of lanes that
        needed a cold root (0 if ``cold``)."""
        c = BALLS + j
        cx_at = (POS + 2 * c) * LANES
        vc = (VEL + 2 * c) * LANES
        at_wall = (ROOTS + 20 * j + R_WALL) * LANES
        cold_lanes = 0
        for lane in range(LANES):
            if cold and W[(SAVED + AGAIN) * LANES + lane] == 0.0:
                continue  # a lane the first pass left exact
            if not cold:  # the rows as they were, for a second pass with the cold roots
                wall_state(j, W, lane, False)
            rc = W[P_RC * LANES + lane]
            rp = W[P_RP * LANES + lane]
            g = W[P_G * LANES + lane] if GRAVITY_STANDARD else 0.0
            cx = W[cx_at + lane]
            cy = W[cx_at + LANES + lane]
            cage_fx = 0.0
            cage_fy = -W[P_MC * LANES + lane] * g
            # cage ball / its two boundaries at r_p -+ r_c (table 2 "cage/cage")
            r2 = cx * cx + cy * cy
            inv, exact = root_lane(r2, W[at_wall + lane], cold)
            W[at_wall + lane] = inv
            nx = cx * inv
            ny = cy * inv
            ov = r2 * inv - rp
            on = ov != 0.0
            sgn = 1.0 if ov > 0.0 else -1.0
            vclose = sgn * (W[vc + lane] * nx + W[vc + LANES + lane] * ny)
            fn, rd, qd, dloss, de, need = normal_lane(
                abs(ov), vclose, 3, W[P_LIMIT * LANES + lane] * rc, c, on, W, lane,
                ROOTS + 20 * j + R_WALL + 1, cold,
            )  # fmt: skip
            add_energy(W, lane, dloss, de)
            W[(ACC_NEW + 2 * c) * LANES + lane] = cage_fx - sgn * fn * nx if on else cage_fx
            W[(ACC_NEW + 2 * c + 1) * LANES + lane] = cage_fy - sgn * fn * ny if on else cage_fy
            need = need or not exact
            W[(SAVED + AGAIN) * LANES + lane] = 1.0 if need else 0.0
            cold_lanes += need
        return cold_lanes

    @cold_loop
    def wall_lanes_cold(j, W):
        """:func:`wall_lanes` with the cold roots."""
        wall_lanes(j, W, True)

    @inline
    def pair_lanes(a, b, kind, radius_row, body, root_row, fcon_row, W, last):
        """Body a (cage ball or ball, radius at ``radius_row``) on ball b, frictionless, every
        lane: the force on a added to its row of ACC_NEW, its opposite to b's (a cage ball on a
        ball, or ball k + 1 on ball k without a cage); then F / m of cage ball a if ``last`` & 2,
        of ball b if ``last`` & 1."""
        for lane in range(LANES):
            radius = W[radius_row * LANES + lane]
            reach = W[P_RB * LANES + lane] + radius
            dx = W[(POS + 2 * a) * LANES + lane] - W[(POS + 2 * b) * LANES + lane]
            dy = W[(POS + 2 * a + 1) * LANES + lane] - W[(POS + 2 * b + 1) * LANES + lane]
            d2 = dx * dx + dy * dy
            inside = d2 < reach * reach
            at = root_row * LANES + lane
            inv_old = W[at]
            inv = rsqrt_next(d2, inv_old)
            W[at] = inv if inside else inv_old
            nx = dx * inv
            ny = dy * inv
            rvx = W[(VEL + 2 * a) * LANES + lane] - W[(VEL + 2 * b) * LANES + lane]
            rvy = W[(VEL + 2 * a + 1) * LANES + lane] - W[(VEL + 2 * b + 1) * LANES + lane]
            vclose = -(rvx * nx + rvy * ny)
            fn, rd, qd, dloss, de, _ = normal_lane(
                reach - d2 * inv, vclose, kind, W[P_LIMIT * LANES + lane] * radius, body, inside,
                W, lane, root_row + 1, True,
            )  # fmt: skip
            add_energy(W, lane, dloss, de)
            fx = fn * nx if inside else 0.0
            fy = fn * ny if inside else 0.0
            inv_a = W[INV_MC * LANES + lane] if last & 2 else 1.0
            inv_b = W[INV_MB * LANES + lane] if last & 1 else 1.0
            at_a = (ACC_NEW + 2 * a) * LANES + lane
            at_b = (ACC_NEW + 2 * b) * LANES + lane
            W[at_a], W[at_a + LANES] = (W[at_a] + fx) * inv_a, (W[at_a + LANES] + fy) * inv_a
            W[at_b], W[at_b + LANES] = (W[at_b] - fx) * inv_b, (W[at_b + LANES] - fy) * inv_b
            W[fcon_row * LANES + lane] = fn

    @inline
    def rigid_cage_lanes(W):
        """The rigid cage (centre in body row BALLS, angle of pocket 0 in row BALLS + 1) on its
        balls, every lane: ball k in its pocket (a sphere of radius R_b + gap centred at
        c + r_p u_k) pushed back when its centre is more than the gap from the pocket centre,
        contact type 5, frictionless; the cage's acceleration and angular acceleration. As
        :func:`.kernel.forces` (CAGE_RIGID): u_k rotated from u_0 pocket by pocket (rows
        POCKET), the forces gathered in rows POCKET + 2..4; a lane loop per ball."""
        cage = (POS + 2 * BALLS) * LANES
        vcage = (VEL + 2 * BALLS) * LANES
        for lane in range(LANES):  # u_0, from the cage angle, and the cage's weight
            theta = W[cage + 2 * LANES + lane]
            W[POCKET * LANES + lane] = math.sin(theta)
            W[(POCKET + 1) * LANES + lane] = -math.cos(theta)
            g = W[P_G * LANES + lane] if GRAVITY_STANDARD else 0.0
            W[(POCKET + 2) * LANES + lane] = 0.0
            W[(POCKET + 3) * LANES + lane] = -W[P_CAGE_M * LANES + lane] * g
            W[(POCKET + 4) * LANES + lane] = 0.0
        for k in range(BALLS):
            for lane in range(LANES):
                rp = W[P_RP * LANES + lane]
                gap = W[P_GAP * LANES + lane]
                ux = W[POCKET * LANES + lane]
                uy = W[(POCKET + 1) * LANES + lane]
                wc = W[vcage + 2 * LANES + lane]
                ox = rp * ux
                oy = rp * uy
                dx = W[(POS + 2 * k) * LANES + lane] - (W[cage + lane] + ox)
                dy = W[(POS + 2 * k + 1) * LANES + lane] - (W[cage + LANES + lane] + oy)
                d2 = dx * dx + dy * dy
                inside = d2 > gap * gap
                at = (ROOTS + 20 * k + R_SIDE0) * LANES + lane
                inv_old = W[at]
                inv = rsqrt_next(d2, inv_old)
                W[at] = inv if inside else inv_old
                nx = dx * inv
                ny = dy * inv
                # closing: ball centre away from the pocket centre (a cage point: v_c + w x r)
                vx = W[(VEL + 2 * k) * LANES + lane] - W[vcage + lane] + wc * oy
                vy = W[(VEL + 2 * k + 1) * LANES + lane] - W[vcage + LANES + lane] - wc * ox
                fn, rd, qd, dloss, de, _ = normal_lane(
                    d2 * inv - gap, vx * nx + vy * ny, 5,
                    W[P_LIMIT * LANES + lane] * W[P_RB * LANES + lane], k, inside, W, lane,
                    ROOTS + 20 * k + R_SIDE0 + 1, True,
                )  # fmt: skip
                add_energy(W, lane, dloss, de)
                fx = fn * nx if inside else 0.0
                fy = fn * ny if inside else 0.0
                W[(ACC_NEW + 2 * k) * LANES + lane] -= fx
                W[(ACC_NEW + 2 * k + 1) * LANES + lane] -= fy
                W[(POCKET + 2) * LANES + lane] += fx
                W[(POCKET + 3) * LANES + lane] += fy
                W[(POCKET + 4) * LANES + lane] += fn * (ox * ny - oy * nx) if inside else 0.0
                W[(FCON + 6 * k + 4) * LANES + lane] = fn if inside else 0.0
                step_c = W[P_STEP_COS * LANES + lane]
                step_s = W[P_STEP_SIN * LANES + lane]
                W[POCKET * LANES + lane] = ux * step_c - uy * step_s
                W[(POCKET + 1) * LANES + lane] = uy * step_c + ux * step_s
        for lane in range(LANES):
            acc = (ACC_NEW + 2 * BALLS) * LANES + lane
            mass = W[P_CAGE_M * LANES + lane]
            W[acc] = W[(POCKET + 2) * LANES + lane] / mass
            W[acc + LANES] = W[(POCKET + 3) * LANES + lane] / mass
            W[acc + 2 * LANES] = W[(POCKET + 4) * LANES + lane] / W[P_CAGE_I * LANES + lane]
            W[acc + 3 * LANES] = 0.0

    return cage_ball_lanes, pair_lanes, rigid_cage_lanes
