"""The rigid cage (``effects.cage = "rigid"``) against rolling kinematics, the quasi-static theory,
the seed's cage-ball model and the energy balance.

The rigid cage is one ball-guided ring body (centre and angle) with a spherical pocket per ball
(signatelec.config.bearing: PA66-GF25, 0.254 mm diametral pocket clearance, conformal Hertz
contact, frictionless). Bearings: the seed's 2D 6208 (13 balls) and the catalogue's SKF 6208
(9 balls of 12.7 mm), each at 500 and 1000 rad/s, F_r = 0.2 C_r of the seed, zero clearance.
"""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from test_hard_cases import BALANCE_RTOL, OVERLAP_LIMIT, assert_sound, soundness

from signatelec.config.bearing import BALL_POCKET, Bearing
from signatelec.config.catalogue import catalogue_bearing
from signatelec.config.scene import Scene
from signatelec.engines.fidelity import apply_fidelity
from signatelec.engines.quasistatic.tier import simulate_quasistatic
from signatelec.physics.laws import scene_law
from signatelec.physics.stability import stability_limit

pytestmark = pytest.mark.filterwarnings(
    "ignore::signatelec.physics.electrical.CurrentDensityWarning"
)

BEARINGS = {"seed 6208": Bearing(), "catalogue 6208": catalogue_bearing("6208")}
CASES = [(name, omega) for name in BEARINGS for omega in (500.0, 1000.0)]


def rigid_scene(bearing_name: str, omega_rad_s: float, **changes) -> Scene:
    scene = Scene(bearing=BEARINGS[bearing_name])
    return scene.with_overrides(cage="rigid", omega_rad_s=omega_rad_s, **changes)


@pytest.mark.parametrize("bearing_name, omega", CASES)
def test_cage_turns_at_the_rolling_speed(run_scene, bearing_name, omega):
    """Cage speed within 1 % of omega R_inn / (R_inn + R_out) (rolling without slip), for the
    cage body's own rotation and the balls' mean orbit. Measured: -0.11 to -0.16 % (the balls
    slip a little on the inner race, which drives them)."""
    scene = rigid_scene(bearing_name, omega)
    steady = run_scene(scene).steady()
    kinematic = scene.bearing.cage_speed_rad_s(omega)
    assert steady.cage_body_speed_rad_s.mean() == pytest.approx(kinematic, rel=1e-2)
    assert steady.cage_speed_rad_s.mean() == pytest.approx(kinematic, rel=1e-2)


@pytest.mark.parametrize("bearing_name, omega", CASES)
def test_ball_loads_and_resistance_match_the_quasistatic_theory(run_scene, bearing_name, omega):
    """Largest ball load within 2 % and mean resistance within 1 % of the quasi-static tier
    (Hertz equilibrium of the inner ring with centrifugal ball loads, seed eqs 14-18).
    Measured: largest load +0.18 to +0.21 %, resistance -0.017 to -0.043 %."""
    scene = rigid_scene(bearing_name, omega)
    steady = run_scene(scene).steady()
    theory = simulate_quasistatic(scene).signals
    assert steady.max_ball_load_n.mean() == pytest.approx(theory.max_ball_load_n.mean(), rel=2e-2)
    assert steady.resistance_ohm.mean() == pytest.approx(theory.resistance_ohm.mean(), rel=1e-2)


def test_agrees_with_the_seeds_cage_model_at_the_seeds_scene(run_scene):
    """At the seed's scene the rigid cage and the seed's 13 cage balls give the same mean
    resistance within 0.5 %. Measured: +0.024 % (largest ball load +0.08 %): both cages only
    space the balls; the loads come from the rings. What differs is how they space them (a
    0.127 mm radial play in a pocket of a floating ring against a chain of cage balls held on the
    pitch circle) and the balls' slip (orbit -0.13 % against -0.05 %): that moves the ball-pass
    ripple (+14 % in amplitude, a ripple of 0.15 % of R), hardly the mean."""
    rigid = run_scene(Scene().with_overrides(cage="rigid")).steady()
    seed = run_scene(Scene()).steady()
    assert rigid.resistance_ohm.mean() == pytest.approx(seed.resistance_ohm.mean(), rel=5e-3)


@pytest.mark.parametrize("bearing_name, omega", CASES)
def test_energy_balance_and_overlaps(run_scene, bearing_name, omega):
    """Energy balance (work in = dissipated + elastic + kinetic, the cage's translation and
    rotation included), finite tables and no ball leaving its ring, as tests/test_hard_cases.py
    holds every hard case; and a ball-guided cage: its centre stays within the pocket play
    (R_p - R_b) of the bearing axis, plus the inner ring's shift that moves the balls."""
    scene = rigid_scene(bearing_name, omega, energy=True)
    result = run_scene(scene)
    assert_sound(result)
    sig = result.signals
    b = scene.bearing
    shift = (sig.cage_x_m**2 + sig.cage_y_m**2) ** 0.5
    assert shift.max() <= b.pocket_radius_m - b.ball_radius_m + sig.delta_r_m.max()


@pytest.mark.parametrize("integrator", ["verlet", "euler"])
def test_runs_at_its_stability_limit(run_scene, integrator):
    """The rigid cage, a 7 g body, no longer sets the step as the seed's 5 mg cage balls do:
    its estimated limit is at least 5 times theirs (measured 6.6x with Verlet, 6.8x with Euler:
    0.73 us and 1.43 us), within 5 % of the cageless bearing's steel-ball limit (Verlet) and
    within 15 % of the 80x mass-scaled cage balls' (Euler, the ``fast`` preset's).

    A run at 0.9x that estimate keeps the energy balance. With symplectic Euler the balance's
    quadrature (power at v_n) is first order: its residual is proportional to dt (measured
    2.3e-4, 3.3e-4, 4.4e-4 of the work in at 0.5, 0.7, 0.9x; the ``fast`` preset's own is 3.4e-4),
    above the 3e-4 the hard cases allow Verlet. It is held to the two-sided 1e-3 and to halving
    with dt, which energy pumped in by an instability would not do."""
    base = Scene().with_overrides(integrator=integrator)
    rigid = stability_limit(base.with_overrides(cage="rigid"))
    assert rigid.dt_limit_s >= 5.0 * stability_limit(base).dt_limit_s
    if integrator == "verlet":
        none = stability_limit(base.with_overrides(cage="none")).dt_limit_s
        assert rigid.dt_limit_s == pytest.approx(none, rel=5e-2)
    else:
        fast = stability_limit(apply_fidelity(Scene(), "fast")).dt_limit_s
        assert rigid.dt_limit_s == pytest.approx(fast, rel=0.15)

    def run(fraction):
        scene = base.with_overrides(
            cage="rigid", energy=True, dt_s=fraction * rigid.dt_limit_s, duration_s=0.016
        )
        return run_scene(scene)

    if integrator == "verlet":
        assert_sound(run(0.9))
    else:
        at_limit = soundness(run(0.9))
        half = soundness(run(0.45))
        assert at_limit["relative_residual"] <= BALANCE_RTOL
        assert at_limit["max_overlap"] <= OVERLAP_LIMIT
        ratio = half["relative_residual"] / at_limit["relative_residual"]
        assert ratio == pytest.approx(0.5, abs=0.1)


def test_pocket_contact_is_conformal_hertz():
    """The ball/pocket law is Hertz's sphere in a spherical seat: F = 4/3 E* sqrt(R) delta^{3/2}
    with 1/R = 1/R_b - 1/R_p and 1/E* = (1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2 (Johnson, Contact
    Mechanics, section 4.2); and the cage's mass and inertia are those of a ring of section
    2 R_b x R_b on the pitch circle less its pockets (7.0 g, I / (m r_p^2) = 1.03)."""
    b = Bearing()
    steel, cage = b.ball_material, b.rigid_cage_material
    e_star = 1.0 / (
        (1 - steel.poisson**2) / steel.youngs_modulus_pa
        + (1 - cage.poisson**2) / cage.youngs_modulus_pa
    )
    rp = b.ball_radius_m + 0.127e-3
    radius = 1.0 / (1.0 / b.ball_radius_m - 1.0 / rp)
    coef, exponent = scene_law(Scene().with_overrides(cage="rigid"))
    assert exponent == 1.5
    assert coef[BALL_POCKET] == pytest.approx(4.0 / 3.0 * e_star * math.sqrt(radius), rel=1e-12)
    # a ring without pockets bounds the mass from above; the pockets take about 2/3 of it
    ring = (
        cage.density_kg_m3 * 2 * math.pi * b.pitch_radius_m * b.ball_radius_m * 2 * b.ball_radius_m
    )
    assert 0.3 * ring < b.rigid_cage_mass_kg < 0.5 * ring
    assert b.rigid_cage_inertia_kg_m2 / (b.rigid_cage_mass_kg * b.pitch_radius_m**2) == (
        pytest.approx(1.0, abs=0.05)
    )


def test_a_steel_cage_is_heavier_and_gives_the_same_loads(run_scene):
    """A steel cage (same geometry) weighs density ratio times more and leaves the ball loads and
    resistance unchanged within 0.5 % of the polyamide cage's."""
    from signatelec.config.bearing import STEEL

    steel = replace(Bearing(), rigid_cage_material=STEEL)
    assert steel.rigid_cage_mass_kg / Bearing().rigid_cage_mass_kg == pytest.approx(
        STEEL.density_kg_m3 / Bearing().rigid_cage_material.density_kg_m3, rel=1e-12
    )
    a = run_scene(Scene().with_overrides(cage="rigid")).steady()
    s = run_scene(Scene(bearing=steel).with_overrides(cage="rigid")).steady()
    assert s.resistance_ohm.mean() == pytest.approx(a.resistance_ohm.mean(), rel=5e-3)
    assert s.max_ball_load_n.mean() == pytest.approx(a.max_ball_load_n.mean(), rel=5e-3)


def test_a_brisk_spin_up_to_3000_rad_s(run_scene):
    """The seed's cage balls leave their line under the chain force of a brisk spin-up: 3000
    rad/s needs an 80 ms spin-up (tests/test_hard_cases.py, FAST_SPIN_UP_S). The rigid cage takes
    the seed's 5 ms with the energy balance kept and the cage at the rolling speed within 1 %
    (measured -0.06 %; peak pocket force 590 N during the spin-up, a 20 um conformal overlap,
    90 N in steady running)."""
    scene = Scene().with_overrides(cage="rigid", omega_rad_s=3000.0, energy=True, duration_s=0.016)
    result = run_scene(scene)
    assert_sound(result)
    kinematic = scene.bearing.cage_speed_rad_s(3000.0)
    speed = result.steady().cage_body_speed_rad_s.mean()
    assert speed == pytest.approx(kinematic, rel=1e-2)


def test_the_tier_counts_the_rigid_cage_kinetic_energy():
    """The quasi-static tier's kinetic energy adds the rigid cage turning at the kinematic cage
    speed, I omega_c^2 / 2 (it does not translate), to the balls'. Weightless, so that the balls
    sit alike with and without it (under gravity its pockets push them by ~0.1 N)."""
    scene = Scene().with_overrides(energy=True, duration_s=0.0075 + 1e-3, gravity="none")
    rigid = simulate_quasistatic(scene.with_overrides(cage="rigid")).signals.kinetic_j
    none = simulate_quasistatic(scene.with_overrides(cage="none")).signals.kinetic_j
    b = scene.bearing
    cage = 0.5 * b.rigid_cage_inertia_kg_m2 * b.cage_speed_rad_s(500.0) ** 2
    assert (rigid - none).to_numpy() == pytest.approx(cage, rel=1e-9)
