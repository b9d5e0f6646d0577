"""Surfaces with localised defects, out-of-round rings and abnormal loads: one definition.

Scalar functions (``math`` only) compiled with numba's ``inline="always"``: the DEM kernel
(:mod:`signatelec.engines.dem.kernel`) inlines them into its contact loop and the quasi-static
tier calls them over its instants (:func:`clearance_offsets_m`), so both see the same surface.
Called from Python they compile on first use.

A spall is a pit of length L along its surface and depth d. A body rolling over it meets its
edges: its centre drops by the amount the pit lets it, which is not the depth when the body is
larger than the pit. For a pair of surfaces of in-plane radii R_1 and R_2 in contact (the equivalent
radius 1/R = 1/R_1 + 1/R_2, a concave race counted negative), the gap at a distance x from the
contact is R - sqrt(R^2 - x^2) (~ x^2 / 2R), so bridging a pit of half-length L / 2 the bodies
close by at most

    h_max = min(d, R - sqrt(R^2 - (L/2)^2))

Sawalhi and Randall's rule (with the ball radius, R = R_b, for a flat race), here with the pair's
equivalent radius. The profiles of the drop h(s) with the position s of the contact in the pit:

- ``rectangular`` (Sawalhi and Randall 2008): h = h_max over the whole pit, the contact steps
  down at the leading edge and up at the trailing edge;
- ``smooth`` (the ball rolling over the edges, as Liu and Shao 2015 model the edge topography):
  h = min(d, R - sqrt(R^2 - m^2)) with m the distance to the nearer edge: the contact rides down
  the leading edge, reaches the bottom only if the pit is long enough, and rides up the trailing
  edge; at the pit's centre it equals the rectangular one.

Where the drop exceeds the Hertz approach of a contact, the contact opens: the ball over the
spall is unloaded, may lose both contacts, and re-enters at the trailing edge.

An out-of-round outer race has the radius R_out + A cos(n theta), theta from the load direction
-y (a housing that squeezes the ring into n lobes).

References
----------
N. Sawalhi, R. B. Randall, "Simulating gear and bearing interactions in the presence of faults,
Part I. The combined gear bearing dynamic model and the simulation of localised bearing faults",
Mechanical Systems and Signal Processing 22 (2008) 1924-1951, section 4.
J. Liu, Y. Shao, "A new dynamic model for vibration analysis of a ball bearing due to a localized
surface defect considering edge topographies", Nonlinear Dynamics 79 (2015) 1329-1351.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from signatelec.physics.defect_geometry import (
    BALL,
    BALL_SURFACE,
    CENTRE,
    DEPTH,
    HALF_LENGTH,
    INNER_RACE,
    INNER_SIDE,
    LOCATION,
    OUTER_RACE,
    OUTER_SIDE,
    SMOOTH,
    SURFACE_RADIUS,
    contact_radii_m,
    defect_table,
)

TWO_PI = 2.0 * math.pi

_inline = njit(inline="always", error_model="numpy")


@_inline
def wrap_angle(angle_rad):
    """``angle_rad`` brought into [-pi, pi)."""
    return angle_rad - TWO_PI * math.floor((angle_rad + math.pi) / TWO_PI)


@_inline
def bridged_drop_m(half_span_m, depth_m, radius_m):
    """How far a body of equivalent radius ``radius_m`` closes on a pit of depth ``depth_m``
    whose edge lies ``half_span_m`` away on each side: min(d, R - sqrt(R^2 - x^2)), m."""
    if half_span_m >= radius_m:
        return depth_m
    return min(depth_m, radius_m - math.sqrt(radius_m * radius_m - half_span_m * half_span_m))


@_inline
def spall_drop_m(offset_m, half_length_m, depth_m, radius_m, smooth):
    """Drop of the contact at ``offset_m`` (along the surface) from the centre of a spall of
    half-length ``half_length_m``: 0 outside it, else the rectangular or smooth profile, m."""
    inside = half_length_m - abs(offset_m)
    if inside <= 0.0:
        return 0.0
    return bridged_drop_m(inside if smooth else half_length_m, depth_m, radius_m)


@_inline
def surface_drop_m(side, theta, ring_angle, ball, ball_angle, table, count, radius_m):
    """Largest drop, m, of the defects that the ``side`` contact of ball ``ball`` meets.

    ``theta``: direction of the contact from the centre it belongs to (the outer race's for the
    outer contact, the inner ring's for the inner one), rad from -y; ``ring_angle`` the inner
    ring's rotation, ``ball_angle`` the ball's; ``radius_m`` the pair's equivalent radius.
    ``table`` (TABLE_ROWS, n) from :func:`~signatelec.physics.defect_geometry.defect_table`, its
    first ``count`` columns used.
    """
    drop = 0.0
    for j in range(count):
        location = table[LOCATION, j]
        if location == OUTER_RACE and side == OUTER_SIDE:
            arc = theta - table[CENTRE, j]
        elif location == INNER_RACE and side == INNER_SIDE:
            arc = theta - ring_angle - table[CENTRE, j]
        elif location == BALL_SURFACE and table[BALL, j] == ball:
            # the ball's point on the outer race faces theta, the one on the inner race theta + pi
            face = math.pi if side == INNER_SIDE else 0.0
            arc = theta + face - ball_angle - table[CENTRE, j]
        else:
            continue
        offset = wrap_angle(arc) * table[SURFACE_RADIUS, j]
        half, depth, smooth = table[HALF_LENGTH, j], table[DEPTH, j], table[SMOOTH, j] > 0.0
        drop = max(drop, spall_drop_m(offset, half, depth, radius_m, smooth))
    return drop


@_inline
def lobe_shift_m(theta, lobes, amplitude_m):
    """Out-of-round outer race: R_out(theta) - R_out = A cos(n theta), theta from -y, m."""
    return amplitude_m * math.cos(lobes * theta)


@_inline
def tabulated_load_n(time_after_setup_s, times_s, loads_n, count, static_n):
    """F_r of a load table at ``time_after_setup_s``: ``static_n`` before its first point,
    linear between points, the last value after the last (``count`` points), N."""
    if count == 0 or time_after_setup_s < times_s[0]:
        return static_n
    for i in range(1, count):
        if time_after_setup_s < times_s[i]:
            w = (time_after_setup_s - times_s[i - 1]) / (times_s[i] - times_s[i - 1])
            return loads_n[i - 1] + w * (loads_n[i] - loads_n[i - 1])
    return loads_n[count - 1]


@njit(cache=True, error_model="numpy")
def tabulated_loads_n(times_after_setup_s, times_s, loads_n, static_n):
    """:func:`tabulated_load_n` at each of an array of times, N."""
    out = np.empty(times_after_setup_s.shape[0])
    count = times_s.shape[0]
    for i in range(out.shape[0]):
        out[i] = tabulated_load_n(times_after_setup_s[i], times_s, loads_n, count, static_n)
    return out


@njit(cache=True, error_model="numpy")
def _offsets(psi, ring_angle, ball_angle, table, count, radii, lobes, amplitude, out):
    t_count, z = psi.shape
    for t in range(t_count):
        for k in range(z):
            inner = surface_drop_m(
                INNER_SIDE, psi[t, k], ring_angle[t], k, ball_angle[t, k], table, count, radii[0]
            )
            outer = surface_drop_m(
                OUTER_SIDE, psi[t, k], ring_angle[t], k, ball_angle[t, k], table, count, radii[1]
            )
            out[t, k] = inner + outer + lobe_shift_m(psi[t, k], lobes, amplitude)


def clearance_offsets_m(scene, ball_angle_rad, ring_angle_rad, ball_rotation_rad) -> np.ndarray:
    """Extra clearance (T, Z) each ball sees at each instant, m: the drops of the defects under
    its two contacts and the out-of-round outer race's radius at its angle.

    ``ball_angle_rad`` (T, Z) the balls' angles from -y (the direction of both contacts, the
    ring's shift being microns), ``ring_angle_rad`` (T,) the inner ring's rotation,
    ``ball_rotation_rad`` (T, Z) the balls' rotation angles.
    """
    psi = np.ascontiguousarray(ball_angle_rad, dtype=float)
    out = np.zeros(psi.shape)
    h = scene.housing
    lobes = float(h.out_of_round_lobes) if h.out_of_round else 0.0
    _offsets(
        psi,
        np.ascontiguousarray(ring_angle_rad, dtype=float),
        np.ascontiguousarray(ball_rotation_rad, dtype=float),
        defect_table(scene, max(len(scene.defects), 1)),
        len(scene.defects),
        np.array(contact_radii_m(scene.bearing)),
        lobes,
        h.out_of_round_amplitude_m if h.out_of_round else 0.0,
        out,
    )
    return out
