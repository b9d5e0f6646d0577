"""Rolling kinematics of a radial ball bearing: the characteristic frequencies, Hz.

Outer ring fixed, inner ring turning at ``omega_rad_s`` (shaft frequency f_s = omega / 2 pi),
pure rolling, contact angle alpha (0 for the 2D model). With the ball diameter D = 2 R_b and the
pitch diameter d_m = R_inn + R_out of the model:

- cage (fundamental train) frequency  FTF  = f_s / 2 (1 - D cos(alpha) / d_m);
- ball pass frequency, outer race     BPFO = Z FTF;
- ball pass frequency, inner race     BPFI = Z f_s / 2 (1 + D cos(alpha) / d_m);
- ball spin frequency (in the cage)   BSF  = d_m / (2 D) f_s (1 - (D cos(alpha) / d_m)^2).

At alpha = 0, FTF is the cage speed omega R_inn / (R_inn + R_out) of
:meth:`Bearing.cage_speed_rad_s`, and BPFO its ball-pass frequency
:meth:`Bearing.ball_pass_frequency_hz`. A defect on a ball strikes the inner and the outer race
once each per spin revolution, so its impacts repeat at 2 BSF (the "rolling element" frequency
that bearing-fault data sets publish).

References
----------
T. A. Harris, M. N. Kotzalas, *Essential Concepts of Bearing Technology*, 5th ed., CRC, 2006,
section 8.3 (cage and ball speeds of a ball bearing with the outer ring fixed).
R. B. Randall, J. Antoni, "Rolling element bearing diagnostics: a tutorial", Mechanical Systems
and Signal Processing 25 (2011) 485-520, eqs 1-4.
"""

from __future__ import annotations

import math

from signatelec.config.bearing import Bearing, BearingError, seed_bearing


def shaft_frequency_hz(omega_rad_s: float) -> float:
    """Shaft (inner-ring) rotation frequency omega / 2 pi, Hz."""
    return omega_rad_s / (2.0 * math.pi)


def _diameter_ratio(bearing: Bearing, contact_angle_rad: float) -> float:
    """D cos(alpha) / d_m with D = 2 R_b and d_m = R_inn + R_out."""
    if not (isinstance(contact_angle_rad, int | float) and 0.0 <= contact_angle_rad < math.pi / 2):
        raise BearingError(
            f"contact_angle_rad = {contact_angle_rad!r}: must be a number in [0, pi/2)"
        )
    pitch_diameter_m = bearing.inner_race_radius_m + bearing.outer_race_radius_m
    return 2.0 * bearing.ball_radius_m * math.cos(contact_angle_rad) / pitch_diameter_m


def cage_frequency_hz(
    omega_rad_s: float, bearing: Bearing | None = None, contact_angle_rad: float = 0.0
) -> float:
    """Cage (fundamental train) frequency FTF = f_s / 2 (1 - D cos(alpha) / d_m), Hz."""
    ratio = _diameter_ratio(bearing or seed_bearing(), contact_angle_rad)
    return 0.5 * shaft_frequency_hz(omega_rad_s) * (1.0 - ratio)


def ball_pass_frequency_outer_hz(
    omega_rad_s: float, bearing: Bearing | None = None, contact_angle_rad: float = 0.0
) -> float:
    """Ball pass frequency over a point of the fixed outer race, BPFO = Z FTF, Hz."""
    b = bearing or seed_bearing()
    return b.n_balls * cage_frequency_hz(omega_rad_s, b, contact_angle_rad)


def ball_pass_frequency_inner_hz(
    omega_rad_s: float, bearing: Bearing | None = None, contact_angle_rad: float = 0.0
) -> float:
    """Ball pass frequency over a point of the inner race, BPFI = Z f_s / 2 (1 + D cos / d_m)."""
    b = bearing or seed_bearing()
    ratio = _diameter_ratio(b, contact_angle_rad)
    return 0.5 * b.n_balls * shaft_frequency_hz(omega_rad_s) * (1.0 + ratio)


def ball_spin_frequency_hz(
    omega_rad_s: float, bearing: Bearing | None = None, contact_angle_rad: float = 0.0
) -> float:
    """Ball spin frequency relative to the cage, BSF = d_m / 2D f_s (1 - (D cos / d_m)^2), Hz."""
    b = bearing or seed_bearing()
    ratio = _diameter_ratio(b, contact_angle_rad)
    pitch_over_ball = (b.inner_race_radius_m + b.outer_race_radius_m) / (2.0 * b.ball_radius_m)
    return 0.5 * pitch_over_ball * shaft_frequency_hz(omega_rad_s) * (1.0 - ratio**2)


def characteristic_orders(bearing: Bearing | None = None, contact_angle_rad: float = 0.0) -> dict:
    """FTF, BPFO, BPFI and BSF as multiples of the shaft frequency (orders), dimensionless."""
    one_hz_rad_s = 2.0 * math.pi
    return {
        "ftf": cage_frequency_hz(one_hz_rad_s, bearing, contact_angle_rad),
        "bpfo": ball_pass_frequency_outer_hz(one_hz_rad_s, bearing, contact_angle_rad),
        "bpfi": ball_pass_frequency_inner_hz(one_hz_rad_s, bearing, contact_angle_rad),
        "bsf": ball_spin_frequency_hz(one_hz_rad_s, bearing, contact_angle_rad),
    }


def characteristic_frequencies_hz(
    omega_rad_s: float, bearing: Bearing | None = None, contact_angle_rad: float = 0.0
) -> dict[str, float]:
    """The lines a defect or a rotating load puts in the signal at shaft speed ``omega_rad_s``
    (the measured speed), Hz: ``shaft`` (f_s: unbalance), ``ftf`` (cage), ``bpfo`` (outer-race
    defect), ``bpfi`` (inner-race defect), ``bsf`` (ball spin) and ``ball_defect`` = 2 BSF (a
    spall on a ball strikes both races once per spin revolution)."""
    b = bearing or seed_bearing()
    bsf = ball_spin_frequency_hz(omega_rad_s, b, contact_angle_rad)
    return {
        "shaft": shaft_frequency_hz(omega_rad_s),
        "ftf": cage_frequency_hz(omega_rad_s, b, contact_angle_rad),
        "bpfo": ball_pass_frequency_outer_hz(omega_rad_s, b, contact_angle_rad),
        "bpfi": ball_pass_frequency_inner_hz(omega_rad_s, b, contact_angle_rad),
        "bsf": bsf,
        "ball_defect": 2.0 * bsf,
    }


def expected_ball_pass_hz(omega_rad_s: float, bearing: Bearing | None = None) -> float:
    """Kinematic ball-pass frequency of ``bearing`` (default: the seed's 6208), Hz.

    The frequency at which balls pass a point of the fixed outer ring, and so the period of the
    healthy bearing's resistance ripple: :func:`ball_pass_frequency_outer_hz` at contact angle
    zero, computed as Z times the model's cage speed (:meth:`Bearing.ball_pass_frequency_hz`),
    the form the simulations, features and data sets have always used.
    """
    return (bearing or seed_bearing()).ball_pass_frequency_hz(omega_rad_s)
