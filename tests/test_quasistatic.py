"""Validation of the quasi-static load distribution against theory and published numbers.

Every expected value comes from Harris (Rolling Bearing Analysis, 4th ed., 2001, section 7.3 and
table 7.1), from Stribeck's constant, from closed forms of the integrals, or from the geometry of
seed eqs 14-15; none is a number this code produced. Each tolerance is a few times the error
measured (quoted beside it), with the published tolerance, where there is one, in a comment.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import signatelec
from signatelec.config.bearing import INNER, OUTER, STANDARD_GRAVITY_M_S2, Bearing
from signatelec.physics.contact import hertz_overlap, law_coefficients
from signatelec.physics.load_distribution import (
    epsilon_from_shift,
    harris_radial_integral,
    load_zone_limit_rad,
    max_ball_load_n,
)
from signatelec.physics.quasistatic import (
    ball_angles_rad,
    ball_loads,
    radial_unit_vectors,
    solve_equilibrium,
    solve_equilibrium_over_time,
)
from signatelec.physics.ring_equilibrium import COMPILED_CONTACT_LAWS, contact_laws_fingerprint

SEED = Bearing()
C_R_N = SEED.dynamic_load_rating_n  # 29100 N (seed 2.2.2)
OMEGA_RAD_S = 500.0  # seed section 4
BALL_AT_ZERO = ball_angles_rad(13)  # one ball on the load line
BALLS_STRADDLING = ball_angles_rad(13, np.pi / 13)  # the load line between two balls
# 400 balls need a pitch circle of ~1 m to fit (bearing validation): same balls and grooves.
MANY = SEED.with_(n_balls=400, inner_race_radius_m=1.0, outer_race_radius_m=1.0 + 2 * 6.3e-3)

# Equilibrium residual, relative to the load carried: the solver asks 1e-12 (SOLVER_RTOL), or the
# round-off floor of the approaches s . u - Delta_r when the deflections are tiny beside the
# clearance. Measured: 2.8e-11 at worst over 3000 random ball sets (test below), 4.9e-11 of 2 F_r
# at 0.01 N with 200 um of clearance.
BALANCE_RTOL = 1e-10


def centrifugal_force_n(bearing, omega_rad_s):
    """m_b omega_c^2 r_p with the kinematic cage speed omega R_inn / (R_inn + R_out)."""
    omega_c = (
        omega_rad_s
        * bearing.inner_race_radius_m
        / (bearing.inner_race_radius_m + bearing.outer_race_radius_m)
    )
    return bearing.ball_mass_kg * omega_c**2 * (bearing.inner_race_radius_m + bearing.ball_radius_m)


def residual_n(state, psi, load_xy):
    u = radial_unit_vectors(psi)
    return np.einsum("...z,...zk->...k", state.inner_force_n, u) - load_xy


# --- Harris' radial integral ----------------------------------------------------------------------


# Harris (2001) table 7.1, point contact (n = 1.5), printed with 4 decimals.
HARRIS_TABLE_7_1 = [
    (0.1, 0.1156),
    (0.2, 0.1590),
    (0.3, 0.1892),
    (0.4, 0.2117),
    (0.5, 0.2288),
    (0.6, 0.2416),
    (0.7, 0.2505),
    (0.8, 0.2559),
    (1.0, 0.2546),
    (1.25, 0.2289),
    (2.5, 0.1339),
    (5.0, 0.0711),
]


@pytest.mark.validation
@pytest.mark.parametrize(("epsilon", "published"), HARRIS_TABLE_7_1)
def test_radial_integral_matches_harris_table(epsilon, published):
    # The table rounds to 4 decimals: half a unit of the last digit, 5e-5 (plus float slack).
    assert abs(float(harris_radial_integral(epsilon)) - published) <= 5.0001e-5


@pytest.mark.validation
def test_radial_integral_closed_forms():
    # Exact values; quad is asked 1e-14 absolute and lands within an ulp or so (measured relative
    # errors 2.2e-16, 0 and 8.3e-16 below).
    # n = 3/2, eps = 1: (1/2pi) int cos^3(psi/2) cos(psi) = 4 / (5 pi).
    assert harris_radial_integral(1.0) == pytest.approx(4.0 / (5.0 * math.pi), rel=1e-15)
    # n = 1 (linear law), eps = 1/2: (1/2pi) int_{-pi/2}^{pi/2} cos^2 = 1/4.
    assert harris_radial_integral(0.5, exponent=1.0) == pytest.approx(0.25, rel=1e-15)
    # n = 1, every ball loaded (eps >= 1): J_r = 1 / (4 eps).
    eps = np.array([[1.0, 2.0], [4.0, 10.0]])
    np.testing.assert_allclose(harris_radial_integral(eps, exponent=1.0), 0.25 / eps, rtol=4e-15)
    # No load zone, no load.
    np.testing.assert_array_equal(harris_radial_integral([0.0, -1.0]), [0.0, 0.0])


@pytest.mark.validation
def test_stribeck_constant():
    # Stribeck: Q_max = 4.37 F_r / Z at zero clearance (Harris 7.3). The constant has 3 significant
    # figures (published tolerance: half a unit of the last, 0.005); 1 / J_r(0.5) = 4.3701,
    # measured 9.6e-5 from it.
    assert 13 * max_ball_load_n(1000.0, 13, 0.5) / 1000.0 == pytest.approx(4.37, abs=4e-4)


# --- load parameter and load zone (seed eq. 15) ---------------------------------------------------


@pytest.mark.validation
def test_epsilon_and_load_zone_follow_eq_15():
    # Exact arithmetic of eq. 15 and psi_l = arccos(Delta_r / delta_r): ulp-level tolerances
    # (measured: 0 and 2.1e-16 relative).
    assert epsilon_from_shift(20e-6, 10e-6) == pytest.approx(0.25, rel=1e-15)
    assert epsilon_from_shift(10e-6, -10e-6) == pytest.approx(1.0, rel=1e-15)
    np.testing.assert_array_equal(epsilon_from_shift([0.0, 1e-9, 1.0], 0.0), 0.5)
    assert epsilon_from_shift(0.0, -1e-6) == np.inf  # preload, no shift: uniform load
    assert epsilon_from_shift(0.0, 1e-6) == -np.inf  # clearance, no shift: no ball loaded
    assert load_zone_limit_rad(20e-6, 10e-6) == pytest.approx(math.pi / 3, rel=1e-15)
    assert load_zone_limit_rad(20e-6, -10e-6) == pytest.approx(2 * math.pi / 3, rel=1e-15)
    assert load_zone_limit_rad(10e-6, 0.0) == pytest.approx(math.pi / 2, rel=1e-15)
    assert load_zone_limit_rad(5e-6, -10e-6) == math.pi
    assert load_zone_limit_rad(5e-6, 10e-6) == 0.0


# --- many-ball limit: the discrete equilibrium tends to Harris' integral --------------------------


@pytest.mark.validation
@pytest.mark.parametrize(
    ("radial_load_n", "clearance_m"),
    [
        (4e5, 60e-6),  # clearance, eps ~ 0.33
        (4e5, 30e-6),  # clearance, eps ~ 0.39
        (4e5, 0.0),  # eps = 0.5
        (4e5, -20e-6),  # preload, eps ~ 0.62
        (4e5, -60e-6),  # preload, every ball loaded, eps ~ 1.2
        (4e4, -20e-6),  # preload, every ball loaded, eps ~ 1.9
    ],
)
def test_many_balls_reach_harris_integral(radial_load_n, clearance_m):
    psi = ball_angles_rad(MANY.n_balls)
    state = solve_equilibrium(psi, MANY, radial_load_n, clearance_m, 0.0, centrifugal=False)
    # The ball sum is a trapezoid rule of J_r's integrand, whose edges at +-psi_l behave like
    # (psi_l - psi)^1.5: error O(h^2.5) with h = 2 pi / 400, at most about 3e-5 (required of the
    # many-ball limit: 0.5 %). Measured: 3.6e-7 at worst over the six cases.
    ratio = radial_load_n / (MANY.n_balls * state.max_inner_force_n)
    assert ratio == pytest.approx(float(harris_radial_integral(state.epsilon)), rel=1.5e-6)
    # psi_l = arccos(Delta_r / delta_r): without centrifugal force, a ball is loaded exactly when
    # its approach delta_r cos(psi) - Delta_r is positive, i.e. inside the geometric load zone.
    psi_l = math.acos(np.clip(clearance_m / state.delta_r_m, -1.0, 1.0))
    assert state.load_zone_limit_rad == pytest.approx(psi_l, rel=1e-15)  # measured: 0
    inside = np.cos(psi) > clearance_m / state.delta_r_m
    np.testing.assert_array_equal(state.inner_force_n > 0.0, inside)
    # Round trip of eq. 15: Delta_r = delta_r (1 - 2 eps), to round-off (measured 6.8e-21 m).
    assert state.delta_r_m * (1.0 - 2.0 * state.epsilon) == pytest.approx(clearance_m, abs=3e-20)


@pytest.mark.validation
@pytest.mark.parametrize("clearance_m", [30e-6, 0.0, -10e-6, -80e-6])
@pytest.mark.parametrize("bearing", [SEED, MANY], ids=["13 balls", "400 balls"])
def test_ball_loads_follow_harris_distribution(bearing, clearance_m):
    # Harris 7.3: Q(psi) = Q_max [1 - (1 - cos psi) / (2 eps)]^n, exact for any number of balls
    # when the set is symmetric (s along -y) and the two contacts are in series without body
    # force. Measured: 2e-15 relative on the loaded balls, 1e-14 N on a ball at the zone edge.
    psi = ball_angles_rad(bearing.n_balls)
    state = solve_equilibrium(psi, bearing, 5820.0, clearance_m, 0.0, centrifugal=False)
    bracket = np.maximum(1.0 - (1.0 - np.cos(psi)) / (2.0 * state.epsilon), 0.0)
    np.testing.assert_allclose(
        state.inner_force_n, state.max_inner_force_n * bracket**1.5, rtol=8e-15, atol=5e-14
    )


# --- equilibrium ----------------------------------------------------------------------------------


@pytest.mark.validation
@settings(max_examples=60, deadline=None)
@given(
    # Arbitrary, asymmetric ball sets of 3 to 16 balls: gaps drawn from weights in [0.25, 1], so
    # no two balls coincide (real balls cannot: the seed's are 0.48 rad apart), then rotated.
    gap_weights=st.lists(st.floats(0.25, 1.0), min_size=3, max_size=16),
    rotation_rad=st.floats(-math.pi, math.pi),
    radial_load_n=st.floats(1.0, 3e4),
    clearance_m=st.floats(-20e-6, 100e-6),
    omega_rad_s=st.floats(0.0, 2000.0),
    law=st.sampled_from(["hertz", "harris", "linear"]),
    gravity=st.booleans(),
)
def test_equilibrium_of_arbitrary_ball_sets(
    gap_weights, rotation_rad, radial_load_n, clearance_m, omega_rad_s, law, gravity
):
    gaps = 2 * np.pi * np.array(gap_weights) / np.sum(gap_weights)
    # Contact forces only push: balls all within a half turn away from the load cannot carry it.
    assume(gaps.max() < 0.9 * np.pi)
    psi = rotation_rad + np.cumsum(gaps)
    state = solve_equilibrium(
        psi, SEED, radial_load_n, clearance_m, omega_rad_s, law=law, gravity=gravity
    )
    weight = SEED.inner_ring_mass_kg * STANDARD_GRAVITY_M_S2 if gravity else 0.0
    load_xy = np.array([0.0, -(radial_load_n + weight)])
    carried = np.hypot(*load_xy) + state.inner_force_n.sum()
    assert np.hypot(*residual_n(state, psi, load_xy)) <= BALANCE_RTOL * carried
    # Radial equilibrium of each ball touching both races: Q_o - Q_i = F_c + m_b g cos psi.
    body = centrifugal_force_n(SEED, omega_rad_s) + (
        SEED.ball_mass_kg * STANDARD_GRAVITY_M_S2 * np.cos(psi) if gravity else np.zeros_like(psi)
    )
    both = (state.inner_force_n > 0.0) & (state.outer_force_n > 0.0)
    np.testing.assert_allclose(
        (state.outer_force_n - state.inner_force_n)[both],
        body[both],
        rtol=0.0,
        # a ball's split is converged to ~1e-14; measured 1.2e-15 of the largest Q_o at worst
        # over 3000 random ball sets
        atol=5e-15 * state.outer_force_n.max(),
    )


@pytest.mark.validation
@pytest.mark.parametrize("clearance_m", [-10e-6, 0.0, 20e-6])
def test_compatibility_of_deflections(clearance_m):
    # Geometry: a ball touching both races has d_i + d_o = s . u - Delta_r (seed eq. 14 radii),
    # with d = (Q / c)^(2/3) of the DEM's Hertz law (seed eq. 8). The series split is converged
    # to ~1e-14; measured 7.7e-16 of the approach.
    state = solve_equilibrium(BALL_AT_ZERO, SEED, 5820.0, clearance_m, OMEGA_RAD_S)
    coefficients, _ = law_coefficients(SEED, "hertz")
    approach = radial_unit_vectors(BALL_AT_ZERO) @ state.shift_xy_m - clearance_m
    loaded = state.inner_force_n > 0.0
    deflections = hertz_overlap(state.inner_force_n, coefficients[INNER]) + hertz_overlap(
        state.outer_force_n, coefficients[OUTER]
    )
    np.testing.assert_allclose(deflections[loaded], approach[loaded], rtol=3.5e-15)
    # A ball off the inner race has an approach below its centrifugal deflection on the outer.
    rest = hertz_overlap(centrifugal_force_n(SEED, OMEGA_RAD_S), coefficients[OUTER])
    assert np.all(approach[~loaded] <= rest)


@pytest.mark.validation
@pytest.mark.parametrize("psi", [BALL_AT_ZERO, BALLS_STRADDLING], ids=["ball at 0", "straddle"])
@pytest.mark.parametrize("clearance_m", [-10e-6, 0.0, 20e-6, 200e-6])
def test_symmetric_ball_set_has_no_sideways_shift(psi, clearance_m):
    # Mirror symmetry about the load line: s_x = 0 up to the round-off of sin(2 pi k / 13)
    # (measured 4.4e-16 of s_y); the residual measured 4.5e-14 of F_r at worst.
    state = solve_equilibrium(psi, SEED, 5820.0, clearance_m, OMEGA_RAD_S)
    assert abs(state.shift_xy_m[0]) <= 2e-15 * abs(state.shift_xy_m[1])
    assert state.shift_xy_m[1] < 0.0
    assert np.hypot(*residual_n(state, psi, [0.0, -5820.0])) <= 2e-13 * 5820.0


@pytest.mark.validation
def test_mirrored_ball_set_mirrors_the_shift():
    # psi -> -psi mirrors the bearing about the load line: s_x changes sign, s_y does not.
    # Measured: equal to the last bit; ulp-level tolerance.
    psi = np.array([0.3, 1.0, 1.9, 2.8, 3.9, 4.6, 5.5])
    right = solve_equilibrium(psi, SEED, 5820.0, 10e-6, OMEGA_RAD_S)
    left = solve_equilibrium(-psi, SEED, 5820.0, 10e-6, OMEGA_RAD_S)
    assert abs(right.shift_xy_m[0]) > 1e-7  # really asymmetric
    np.testing.assert_allclose(left.shift_xy_m, right.shift_xy_m * [-1.0, 1.0], rtol=1e-15)
    np.testing.assert_allclose(left.inner_force_n, right.inner_force_n, rtol=1e-15)


@pytest.mark.validation
@pytest.mark.parametrize("psi", [BALL_AT_ZERO, BALLS_STRADDLING], ids=["ball at 0", "straddle"])
@pytest.mark.parametrize("radial_load_n", [100.0, 5820.0, 20000.0])
def test_zero_clearance_loads_half_the_bearing(psi, radial_load_n):
    # Seed 2.2.2: Delta_r = 0 gives eps = 0.5 and the balls of the lower half carry the load
    # (psi_l = 90 deg), whatever F_r. Without centrifugal force "loaded" is exactly cos psi > 0.
    state = solve_equilibrium(psi, SEED, radial_load_n, 0.0, OMEGA_RAD_S, centrifugal=False)
    assert state.epsilon == 0.5
    assert state.load_zone_limit_rad == pytest.approx(math.pi / 2, rel=1e-15)
    np.testing.assert_array_equal(state.inner_force_n > 0.0, np.cos(psi) > 1e-12)
    preload = solve_equilibrium(psi, SEED, radial_load_n, -5e-6, OMEGA_RAD_S, centrifugal=False)
    clearance = solve_equilibrium(psi, SEED, radial_load_n, 5e-6, OMEGA_RAD_S, centrifugal=False)
    assert clearance.epsilon < 0.5 < preload.epsilon
    assert clearance.loaded_count <= state.loaded_count <= preload.loaded_count


@pytest.mark.validation
@pytest.mark.parametrize(
    ("law", "power"), [("hertz", 2.0 / 3.0), ("harris", 2.0 / 3.0), ("linear", 1.0)]
)
def test_shift_scales_as_power_of_load(law, power):
    # At zero clearance without body force every ball's approach is delta_r cos psi, so
    # F_r ~ delta_r^n exactly (homogeneity): delta_r ~ F_r^(1/n). Measured: 5e-16 relative.
    loads = np.array([100.0, 1000.0, 10000.0])
    delta = [
        solve_equilibrium(BALL_AT_ZERO, SEED, f, 0.0, 0.0, law=law, centrifugal=False).delta_r_m
        for f in loads
    ]
    np.testing.assert_allclose(np.diff(np.log(delta)) / np.diff(np.log(loads)), power, rtol=2e-15)


# --- centrifugal force, gravity, no load ----------------------------------------------------------


@pytest.mark.validation
@pytest.mark.parametrize("omega_rad_s", [500.0, 3000.0])
@pytest.mark.parametrize("clearance_m", [-10e-6, 0.0, 20e-6])
def test_centrifugal_force_adds_to_the_outer_race(omega_rad_s, clearance_m):
    # Harris chapter 10: Q_o - Q_i = m_b omega_c^2 r_p for a ball on both races; a ball off the
    # inner race rests on the outer with Q_o = F_c. Measured: 4.5e-16 of the largest Q_o, and
    # 1.1e-14 relative on a resting ball (its overlap inverted and back).
    f_c = centrifugal_force_n(SEED, omega_rad_s)
    state = solve_equilibrium(BALL_AT_ZERO, SEED, 5820.0, clearance_m, omega_rad_s)
    loaded = state.inner_force_n > 0.0
    assert 0 < state.loaded_count < 13
    np.testing.assert_allclose(
        (state.outer_force_n - state.inner_force_n)[loaded],
        f_c,
        rtol=0.0,
        atol=2e-15 * state.outer_force_n.max(),
    )
    np.testing.assert_array_equal(state.inner_force_n[~loaded], 0.0)
    np.testing.assert_allclose(state.outer_force_n[~loaded], f_c, rtol=5e-14)


@pytest.mark.validation
def test_ball_loads_for_a_given_shift():
    # s = (0, -delta): approach delta cos psi - Delta_r (Harris 7.3). A ball reaches the inner
    # race only if the approach exceeds the outer deflection under F_c alone.
    coefficients, _ = law_coefficients(SEED, "hertz")
    f_c = centrifugal_force_n(SEED, OMEGA_RAD_S)
    rest = float(hertz_overlap(f_c, coefficients[OUTER]))
    shift = np.array([0.0, -3.0 * rest])
    inner, outer = ball_loads(BALL_AT_ZERO, shift, SEED, 0.0, OMEGA_RAD_S)
    reaches = 3.0 * rest * np.cos(BALL_AT_ZERO) > rest
    np.testing.assert_array_equal(inner > 0.0, reaches)
    np.testing.assert_allclose(outer[~reaches], f_c, rtol=7e-15)  # measured 1.6e-15
    # Without body force the two contacts in series give Q = K delta^1.5 with
    # K = (c_i^(-2/3) + c_o^(-2/3))^(-3/2) (Harris 7.2); measured 1.8e-15 relative.
    k_series = (coefficients[INNER] ** (-2 / 3) + coefficients[OUTER] ** (-2 / 3)) ** -1.5
    inner, outer = ball_loads(BALL_AT_ZERO, shift, SEED, 0.0, 0.0, centrifugal=False)
    expected = k_series * np.maximum(3.0 * rest * np.cos(BALL_AT_ZERO), 0.0) ** 1.5
    np.testing.assert_allclose(inner, expected, rtol=8e-15)
    np.testing.assert_allclose(outer, expected, rtol=8e-15)


@pytest.mark.validation
def test_preload_without_load_squeezes_every_ball_equally():
    # F_r = 0, Delta_r < 0: s = 0 and every ball carries K (-Delta_r)^1.5 (Harris 7.2 series).
    coefficients, _ = law_coefficients(SEED, "hertz")
    k_series = (coefficients[INNER] ** (-2 / 3) + coefficients[OUTER] ** (-2 / 3)) ** -1.5
    state = solve_equilibrium(BALL_AT_ZERO, SEED, 0.0, -10e-6, 0.0, centrifugal=False)
    assert state.delta_r_m <= 1e-15 * 10e-6  # round-off of the 13 unit vectors (measured: 0)
    np.testing.assert_allclose(state.inner_force_n, k_series * 10e-6**1.5, rtol=5e-15)  # 1.1e-15
    assert state.loaded_count == 13
    assert state.load_zone_limit_rad == math.pi


@pytest.mark.parametrize("clearance_m", [0.0, 20e-6])
def test_clearance_without_load_returns_the_centred_ring(clearance_m):
    # Documented choice: with F = 0 and no preload the ring is free inside the clearance.
    state = solve_equilibrium(BALL_AT_ZERO, SEED, 0.0, clearance_m, OMEGA_RAD_S)
    np.testing.assert_array_equal(state.shift_xy_m, 0.0)
    np.testing.assert_array_equal(state.inner_force_n, 0.0)
    np.testing.assert_allclose(
        state.outer_force_n, centrifugal_force_n(SEED, OMEGA_RAD_S), rtol=5e-15
    )  # measured 1.3e-15
    assert state.loaded_count == 0


@pytest.mark.validation
@pytest.mark.parametrize("psi", [BALL_AT_ZERO, BALLS_STRADDLING], ids=["ball at 0", "straddle"])
@pytest.mark.parametrize("radial_load_n", [0.01, 1.0, 100.0])
def test_large_clearance_loads_few_balls(psi, radial_load_n):
    # 200 um of clearance against deflections below 10 um (100 N on one ball): the load zone
    # shrinks to the one or two balls nearest the load line (eps -> 0); equilibrium still holds,
    # at the round-off floor of s . u - Delta_r (measured 4.9e-11 of 2 F_r at 0.01 N).
    state = solve_equilibrium(psi, SEED, radial_load_n, 200e-6, OMEGA_RAD_S)
    assert 1 <= state.loaded_count <= 3
    assert 0.0 < state.epsilon < 0.05
    assert np.hypot(*residual_n(state, psi, [0.0, -radial_load_n])) <= BALANCE_RTOL * (
        2.0 * radial_load_n
    )


@pytest.mark.validation
def test_gravity_alone_hangs_the_ring_on_the_balls():
    # No load, no speed: the inner ring weight is carried, each ball on both races has
    # Q_o - Q_i = m_b g cos psi, and upper balls rest on the inner ring with Q_i = m_b g |cos psi|.
    # Measured: residual 5.3e-17 of the load carried, 1.7e-15 on Q_i, 1.3e-16 of the weight on
    # Q_o - Q_i.
    state = solve_equilibrium(BALL_AT_ZERO, SEED, 0.0, 0.0, 0.0, gravity=True)
    weight_n = SEED.inner_ring_mass_kg * STANDARD_GRAVITY_M_S2
    ball_weight_n = SEED.ball_mass_kg * STANDARD_GRAVITY_M_S2
    assert np.hypot(*residual_n(state, BALL_AT_ZERO, [0.0, -weight_n])) <= 2.5e-16 * (
        weight_n + state.inner_force_n.sum()
    )
    upper = np.cos(BALL_AT_ZERO) < 0.0
    np.testing.assert_allclose(
        state.inner_force_n[upper], -ball_weight_n * np.cos(BALL_AT_ZERO[upper]), rtol=7e-15
    )
    np.testing.assert_array_equal(state.outer_force_n[upper], 0.0)
    both = state.outer_force_n > 0.0
    np.testing.assert_allclose(
        (state.outer_force_n - state.inner_force_n)[both],
        ball_weight_n * np.cos(BALL_AT_ZERO[both]),
        rtol=0.0,
        atol=5e-16 * weight_n,
    )


# --- the seed operating point ---------------------------------------------------------------------


@pytest.mark.validation
def test_seed_operating_point_against_stribeck():
    # Seed section 4.1: F_r = 0.2 C_r, Delta_r = 0, 13 balls, omega = 500 rad/s.
    radial_load_n = 0.2 * C_R_N
    stribeck_n = 4.37 * radial_load_n / 13
    state = solve_equilibrium(BALL_AT_ZERO, SEED, radial_load_n, 0.0, OMEGA_RAD_S)
    # Finite Z with a ball on the load line: Z Q_max / F_r = 13 / sum cos^2.5 = 4.373 (+0.08 %);
    # the centrifugal force (9.8 N per ball) moves it by ~0.1 % more. Measured: +0.19 %.
    assert state.max_inner_force_n == pytest.approx(stribeck_n, rel=0.005)
    assert state.epsilon == 0.5 and state.loaded_count == 7
    # Without centrifugal force the finite-Z Stribeck sum is exact:
    # F_r = Q_max sum_{cos psi > 0} cos(psi)^2.5.
    no_fc = solve_equilibrium(BALL_AT_ZERO, SEED, radial_load_n, 0.0, 0.0, centrifugal=False)
    cos_psi = np.cos(BALL_AT_ZERO)
    exact = radial_load_n / np.sum(np.maximum(cos_psi, 0.0) ** 2.5)
    assert no_fc.max_inner_force_n == pytest.approx(exact, rel=2e-15)  # measured: 0


# --- time series ----------------------------------------------------------------------------------


@pytest.mark.validation
def test_time_series_of_a_turning_cage():
    # 1000 instants over 3 ball passes of the seed bearing with 20 um of clearance.
    n_instants = 1000
    cage_angle = np.linspace(0.0, 3 * 2 * np.pi / 13, n_instants)
    psi = ball_angles_rad(13, cage_angle)
    state = solve_equilibrium_over_time(psi, SEED, 5820.0, 20e-6, OMEGA_RAD_S)
    assert state.inner_force_n.shape == (n_instants, 13)
    assert state.shift_xy_m.shape == (n_instants, 2)
    # Measured: residual 1.6e-12 of F_r at worst (the solver asks 1e-12 of F_r + sum Q_i).
    residual = np.hypot(*residual_n(state, psi, [0.0, -5820.0]).T)
    assert np.all(residual <= 5e-12 * 5820.0)
    # Ball-pass periodicity: a cage turned by 2 pi / 13 is the same bearing with the balls
    # relabelled (ball k where ball k + 1 was). Measured: 1.6e-16 on delta_r, 2.3e-15 relative
    # and 3.9e-12 N on the forces.
    one_pass = 333
    assert cage_angle[one_pass] == pytest.approx(2 * np.pi / 13, rel=1e-15)
    assert state.delta_r_m[one_pass] == pytest.approx(state.delta_r_m[0], rel=7e-16)
    np.testing.assert_allclose(
        state.inner_force_n[one_pass], np.roll(state.inner_force_n[0], -1), rtol=1e-14, atol=1e-12
    )
    # One instant on its own gives the same equilibrium (a different start, same solution;
    # measured 2.4e-14).
    alone = solve_equilibrium(psi[377], SEED, 5820.0, 20e-6, OMEGA_RAD_S)
    np.testing.assert_allclose(alone.shift_xy_m, state.shift_xy_m[377], rtol=1e-13)


# --- input checks ---------------------------------------------------------------------------------


def test_inputs_are_checked():
    with pytest.raises(ValueError, match="shape"):
        solve_equilibrium(BALL_AT_ZERO[None, :], SEED, 100.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="radial_load_n"):
        solve_equilibrium(BALL_AT_ZERO, SEED, -1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="cannot carry"):
        solve_equilibrium(np.array([2.0, 2.5, 3.0, 3.5]), SEED, 100.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="contact_law"):
        solve_equilibrium(BALL_AT_ZERO, SEED, 100.0, 0.0, 0.0, law="rubber")


# --- the compiled solver follows the contact laws -------------------------------------------------


def test_compiled_solver_records_the_current_contact_laws():
    # numba caches the solver by its own file: the fingerprint line there must change with the
    # laws of contact.py, or a stale cache could serve the old law (see COMPILED_CONTACT_LAWS).
    assert contact_laws_fingerprint() == COMPILED_CONTACT_LAWS, (
        "the contact laws changed: set signatelec.physics.ring_equilibrium.COMPILED_CONTACT_LAWS "
        f"to {contact_laws_fingerprint()!r}"
    )


@pytest.mark.slow
def test_a_changed_hertz_law_reaches_the_compiled_solver(tmp_path):
    # A copy of the package, run twice with one numba cache; between the runs the copy's Hertz
    # force doubles. Both contacts stiffer by 2: same split of the approach, Q exactly doubled.
    package = Path(signatelec.__file__).parent
    shutil.copytree(package, tmp_path / "signatelec", ignore=shutil.ignore_patterns("__pycache__"))
    script = (
        "from signatelec.config.bearing import Bearing\n"
        "from signatelec.physics.quasistatic import ball_angles_rad, ball_loads\n"
        "inner, _ = ball_loads(ball_angles_rad(13), [0.0, -1e-5], Bearing(), 0.0, 0.0, "
        "centrifugal=False)\n"
        "print(repr(float(inner.max())))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "NUMBA_CACHE_DIR": str(tmp_path / "nb")}

    def max_load_n() -> float:
        run = subprocess.run(
            [sys.executable, "-c", script],
            env=env,
            cwd=tmp_path,  # "-c" puts the working directory first on sys.path
            capture_output=True,
            text=True,
            check=True,
        )
        return float(run.stdout)

    before = max_load_n()
    contact = tmp_path / "signatelec" / "physics" / "contact.py"
    text = contact.read_text()
    hertz = "    return coefficient * d * np.sqrt(d)\n"
    assert text.count(hertz) == 1
    contact.write_text(text.replace(hertz, "    return 2.0 * coefficient * d * np.sqrt(d)\n"))
    assert max_load_n() == pytest.approx(2.0 * before, rel=2e-15)  # measured 4.5e-16
