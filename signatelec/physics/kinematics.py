"""Rolling kinematics of a radial ball bearing: the characteristic frequencies, Hz.

Outer ring fixed, inner ring turning at ``omega_rad_s``, pure rolling, contact angle zero (the
2D model): the cage turns at omega R_inn / (R_inn + R_out) (:meth:`Bearing.cage_speed_rad_s`).

References
----------
T. A. Harris, M. N. Kotzalas, *Essential Concepts of Bearing Technology*, 5th ed., CRC, 2006,
section 8.3 (cage and ball speeds of a ball bearing with the outer ring fixed).
"""

from __future__ import annotations

import math
from functools import cache

from signatelec.config.bearing import Bearing


@cache
def _default_bearing() -> Bearing:
    return Bearing()


def expected_ball_pass_hz(omega_rad_s: float, bearing: Bearing | None = None) -> float:
    """Kinematic ball-pass frequency Z omega_c / 2 pi of ``bearing`` (default: the seed's 6208).

    This is the frequency at which balls pass a point of the fixed outer ring (BPFO), and so the
    period of the healthy bearing's resistance ripple.
    """
    return (bearing or _default_bearing()).ball_pass_frequency_hz(omega_rad_s)


def shaft_frequency_hz(omega_rad_s: float) -> float:
    """Shaft (inner-ring) rotation frequency omega / 2 pi, Hz."""
    return omega_rad_s / (2.0 * math.pi)
