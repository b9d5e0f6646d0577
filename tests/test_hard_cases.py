"""Hard cases stay numerically stable.

Every hard case runs the DEM with the energy balance on and must end with:

- **finite values**: every column of both tables is finite, except the two documented
  non-values of the electrical model: ``resistance_ohm`` is +inf (never NaN) exactly at the
  instants when no ball touches both rings, and ``potential_v`` is NaN only for a ball that does
  not touch both rings (or when the resistance is inf).
- **an energy balance**, residual ``r = work_in - dissipated - elastic - kinetic`` at every
  recorded instant. Friction (and the tangential spring's storage, with ``tangential =
  "spring"``) is booked as dissipated, so the balance is the inequality ``kinetic + elastic <=
  work_in - dissipated + tol`` with ``tol = CREATION_RTOL * max(work_in)``, plus the two-sided
  bound ``|r| <= BALANCE_RTOL * max(work_in)``. The accumulators integrate the power with the
  step's (predicted) velocities, a quadrature whose error the measured residuals show to stay
  below 7e-5 of the work in every passing case; a numerical instability pumps energy in that the
  dampers then burn, and shows up as r < 0 of several percent (6e-2 at 0.93x the seed's
  estimated limit, 2.7 at 1.0x). CREATION_RTOL = 3e-4 and BALANCE_RTOL = 1e-3 sit between the two.
- **no ball leaving its ring**: at every recorded instant each ball's overlap with the outer race,
  ``|x_b| + R_b - R_out(t)``, and with the inner race, ``R_inn + R_b - |x_b - x_ring|``, is at
  most ``OVERLAP_LIMIT`` (2 %) of the ball radius, i.e. the ball centre stays within
  ``[R_inn + R_b - limit, R_out - R_b + limit]`` of the respective ring centre. The inner bound is
  taken from the inner-ring centre, which moves by delta_r (from the outer-ring centre a ball
  resting on a shifted inner ring legitimately sits below R_inn + R_b). At 1.5 C_r the static
  Hertz overlap under Stribeck's load 4.37 F_r / Z is itself 2.0 % of R_b, so that case allows 3 %.
  The kernel independently stops a run whose overlap of any body (cage balls included) exceeds
  10 % of its radius at any step (DivergenceError).
- **resistance finite wherever a ball touches both rings**: an instant where some ball has
  ``inner_force_n > 0`` and ``outer_force_n > 0`` has a finite, positive ``resistance_ohm``.

Runs are short (set-up + 8 ms of steady running) except the spin-ups that need longer and the
1 s run; each kernel effect set compiles once per machine (numba cache).
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import cache
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import CR_N, make_scene, solve_network
from hypothesis import given, settings
from hypothesis import strategies as st

import signatelec.engines.dem.run as dem_simulate
from signatelec.cli import main
from signatelec.config.bearing import OUTER, POLYAMIDE, Bearing, Material, contact_properties
from signatelec.config.scene import SceneError
from signatelec.engines.results import DivergenceError
from signatelec.engines.simulate import simulate
from signatelec.physics import contact
from signatelec.physics.conductance import ball_conductance
from signatelec.physics.electrical import OUTER_RING_NODE
from signatelec.physics.laws import scene_law
from signatelec.physics.quasistatic import ball_angles_rad, solve_equilibrium
from signatelec.physics.stability import StabilityLimit, stability_limit

# The seed's 0.1 A/mm^2 current-density warning fires at the first contact instants of every
# run; it concerns the electrical model, not this issue.
pytestmark = pytest.mark.filterwarnings(
    "ignore::signatelec.physics.electrical.CurrentDensityWarning"
)

CREATION_RTOL = 3e-4
BALANCE_RTOL = 1e-3
OVERLAP_LIMIT = 0.02
STEADY_S = 8e-3
ENERGY = {"energy": True}


# --- soundness of one run ----------------------------------------------------------------------


def soundness(result) -> dict:
    """Measure a run: energy residuals, largest overlap, electrical consistency (see module doc)."""
    sc = result.scene
    b = sc.bearing
    z = b.n_balls
    sig, balls = result.signals, result.balls
    n = len(sig)
    assert n > 0 and len(balls) == n * z

    resistance = sig["resistance_ohm"].to_numpy()
    for name in sig.columns:
        if name in ("phase", "resistance_ohm"):
            continue
        assert np.all(np.isfinite(sig[name].to_numpy())), f"signals.{name} not finite"
    for name in balls.columns:
        if name == "potential_v":
            continue
        assert np.all(np.isfinite(balls[name].to_numpy())), f"balls.{name} not finite"

    inner = balls["inner_force_n"].to_numpy().reshape(n, z)
    outer = balls["outer_force_n"].to_numpy().reshape(n, z)
    bridging = (inner > 0.0) & (outer > 0.0)
    conducting = bridging.any(axis=1)
    assert not np.any(np.isnan(resistance))
    assert np.all(np.isfinite(resistance[conducting]) & (resistance[conducting] > 0.0))
    assert np.all(np.isposinf(resistance[~conducting]))
    potential = balls["potential_v"].to_numpy().reshape(n, z)
    assert not np.any(np.isinf(potential))
    assert np.all(np.isfinite(potential[bridging]))

    work = sig["work_in_j"].to_numpy()
    residual = work - sig["dissipated_j"].to_numpy() - sig["elastic_j"].to_numpy()
    residual -= sig["kinetic_j"].to_numpy()
    scale = float(np.max(np.abs(work)))

    x = balls["x_m"].to_numpy().reshape(n, z)
    y = balls["y_m"].to_numpy().reshape(n, z)
    ring_x = sig["inner_x_m"].to_numpy()[:, None]
    ring_y = sig["inner_y_m"].to_numpy()[:, None]
    r_out = sig["outer_race_radius_m"].to_numpy()[:, None]
    outer_overlap = np.hypot(x, y) + b.ball_radius_m - r_out
    inner_overlap = b.inner_race_radius_m + b.ball_radius_m - np.hypot(x - ring_x, y - ring_y)
    overlap = max(outer_overlap.max(), inner_overlap.max()) / b.ball_radius_m
    return {
        "residual_min_j": float(residual.min()),
        "residual_max_j": float(residual.max()),
        "work_j": scale,
        "relative_residual": float(np.abs(residual).max() / scale),
        "max_overlap": float(overlap),
    }


def assert_sound(result, overlap_limit: float = OVERLAP_LIMIT) -> dict:
    m = soundness(result)
    assert m["residual_min_j"] >= -CREATION_RTOL * m["work_j"], m
    assert m["relative_residual"] <= BALANCE_RTOL, m
    assert m["max_overlap"] <= overlap_limit, m
    return m


# --- the hard cases ------------------------------------------------------------------------------


def _duration(spin_up_time_s: float = 5e-3) -> float:
    return 0.5e-3 + 1.5e-3 + spin_up_time_s + STEADY_S


@cache
def large_clearance_m() -> float:
    """Clearance giving epsilon = 0.1 at F_r = 0.1 C_r, 500 rad/s (quasi-static Hertz theory).

    At the seed's 0.2 C_r epsilon = 0.1 needs more than the 5 % of R_b a scene allows.
    """
    from scipy.optimize import brentq

    bearing = Bearing()
    psi = ball_angles_rad(bearing.n_balls)

    def eps(clearance_m):
        state = solve_equilibrium(psi, bearing, 0.1 * CR_N, clearance_m, 500.0, gravity=True)
        return float(state.epsilon) - 0.1

    return brentq(eps, 20e-6, 0.05 * bearing.ball_radius_m, xtol=1e-10)


#: Large clearance: the cage balls, pushing the unloaded balls, leave their line (soft polyamide
#: boundaries) when the spin-up is brisk; 5 ms overlaps a cage boundary by > 10 % of r_c (the run
#: stops), 15 ms keeps it near 5 %.
LARGE_CLEARANCE_SPIN_UP_S = 15e-3
#: 3000 rad/s: 5-30 ms spin-ups stop on a cage-boundary overlap > 10 % (50 ms peaks at 9.3 %);
#: 80 ms keeps the peak at 6.9 %, below the seed scene's own 7.7 %. Halving dt does not help: it is
#: the chain force of the accelerating cage, not the integration.
FAST_SPIN_UP_S = 80e-3
LIGHT_CAGE_DENSITY = 10.0  # kg/m^3, 1/114 of PA66


def light_cage_bearing() -> Bearing:
    light = Material(
        "very light cage balls", POLYAMIDE.youngs_modulus_pa, POLYAMIDE.poisson, LIGHT_CAGE_DENSITY
    )
    return replace(Bearing(), cage_material=light)


def dt_fraction_of_limit(scene, fraction: float):
    limit = stability_limit(scene).dt_limit_s
    return replace(scene, numerics=replace(scene.numerics, dt_s=fraction * limit))


def linear_stiff(fraction: float):
    """Linear law, 10x the default ball/outer stiffness, dt = fraction x the estimated limit."""
    default = scene_law(make_scene(effects={"contact_law": "linear"}))[0][OUTER]
    scene = make_scene(
        duration_s=_duration(),
        effects={"contact_law": "linear"},
        outputs=ENERGY,
        numerics={"linear_stiffness_n_m": 10.0 * default},
    )
    return dt_fraction_of_limit(scene, fraction)


def case_scene(name: str):
    """(scene, overlap limit) of a hard case."""
    if name == "preload_30um":
        return make_scene(clearance_m=-30e-6, duration_s=_duration(), outputs=ENERGY), None
    if name == "large_clearance_eps_0.1":
        return make_scene(
            radial_load_n=0.1 * CR_N,
            clearance_m=large_clearance_m(),
            duration_s=_duration(LARGE_CLEARANCE_SPIN_UP_S),
            outputs=ENERGY,
            procedure={"spin_up_time_s": LARGE_CLEARANCE_SPIN_UP_S},
        ), None
    if name == "zero_radial_load":
        # the seed's 5 ms spin-up: the set-up's stress, not the seconds the ring's weight alone
        # takes to bring the balls to rolling (the automatic spin-up's traction rule)
        return make_scene(
            radial_load_n=0.0,
            duration_s=_duration(),
            outputs=ENERGY,
            procedure={"spin_up_time_s": 5e-3},
        ), None
    if name == "load_Cr":
        return make_scene(radial_load_n=CR_N, duration_s=_duration(), outputs=ENERGY), None
    if name == "load_1.5Cr":
        return make_scene(radial_load_n=1.5 * CR_N, duration_s=_duration(), outputs=ENERGY), 0.03
    if name == "static_omega_0":
        return make_scene(omega_rad_s=0.0, duration_s=_duration(), outputs=ENERGY), None
    if name == "omega_3000":
        return make_scene(
            omega_rad_s=3000.0,
            duration_s=_duration(FAST_SPIN_UP_S),
            outputs=ENERGY,
            procedure={"spin_up_time_s": FAST_SPIN_UP_S},
        ), None
    if name == "load_step":
        return make_scene(
            duration_s=_duration(), outputs=ENERGY, procedure={"load_ramp": "step"}
        ), None
    if name == "dt_90_percent_of_limit":
        return dt_fraction_of_limit(make_scene(duration_s=_duration(), outputs=ENERGY), 0.9), None
    if name == "linear_10x_stiffness":
        # 90 % of the estimated limit, like every case
        return linear_stiff(0.9), None
    if name == "light_cage_balls":
        scene = replace(
            make_scene(duration_s=_duration(), outputs=ENERGY), bearing=light_cage_bearing()
        )
        return dt_fraction_of_limit(scene, 0.9), None
    raise KeyError(name)


FAST_CASES = [
    "preload_30um",
    "large_clearance_eps_0.1",
    "zero_radial_load",
    "load_Cr",
    "load_1.5Cr",
    "static_omega_0",
    "load_step",
    "dt_90_percent_of_limit",
    "linear_10x_stiffness",
]
SLOW_CASES = ["omega_3000", "light_cage_balls"]


@pytest.mark.parametrize(
    "name", FAST_CASES + [pytest.param(n, marks=pytest.mark.slow) for n in SLOW_CASES]
)
def test_hard_case_is_sound(run_scene, name):
    scene, limit = case_scene(name)
    result = run_scene(scene)
    assert_sound(result, limit or OVERLAP_LIMIT)


def test_large_clearance_reaches_epsilon_0_1(run_scene):
    scene, _ = case_scene("large_clearance_eps_0.1")
    steady = run_scene(scene).steady()
    # quasi-static theory gives 0.100 at the nominal ball angles; the DEM's balls move (measured
    # 0.099-0.101 over a pass), 5 % covers it
    assert steady.epsilon.mean() == pytest.approx(0.1, rel=0.05)
    assert steady.loaded_balls.max() <= 4  # the balls outside the narrow load zone ride free


def test_static_bearing_stays_at_rest(run_scene):
    scene, _ = case_scene("static_omega_0")
    steady = run_scene(scene).steady()
    assert np.all(steady.inner_omega_rad_s == 0.0)
    # no drive: the cage creeps at most at rounding level (< 1e-6 of the seed's 198 rad/s)
    assert steady.cage_speed_rad_s.abs().max() < 1e-4


def test_frictionless_bearing_transmits_no_torque(run_scene):
    """The minimal kernel (no cage, no friction, no gravity). Without friction no tangential
    force acts: the inner ring drives nothing (zero drive torque), no ball is ever torqued, so
    none spins, and the balls keep their angles while the energy balance holds as for any hard
    case."""
    scene = make_scene(
        effects={"cage": "none", "friction": "none", "gravity": "none"}, outputs=ENERGY
    )
    result = run_scene(scene)
    balls, signals = result.balls, result.signals
    # before the load the ring sits centred (epsilon undefined): the balance over the steady phase
    assert_sound(
        SimpleNamespace(scene=scene, signals=result.steady(), balls=result.steady("balls"))
    )
    assert (balls.inner_tangential_n == 0.0).all() and (balls.outer_tangential_n == 0.0).all()
    assert (signals.drive_torque_n_m == 0.0).all()
    assert (balls.spin_rad_s == 0.0).all()
    assert signals.inner_omega_rad_s.iloc[-1] == scene.operating.omega_rad_s
    # no tangential force, so no orbit: the cage (mean ball orbit) stays at rest to round-off
    assert signals.cage_speed_rad_s.abs().max() < 1e-6 * scene.operating.omega_rad_s


@pytest.mark.slow
def test_long_run_one_second(run_scene):
    """1 s of bearing time at 0.9x the estimated stability limit (7.1e6 steps, ~6 s of kernel).

    0.9x, not 1.0x: at the estimate itself the energy balance breaks during the spin-up (see
    test_seed_at_the_estimated_limit_keeps_the_energy_balance).
    """
    scene = dt_fraction_of_limit(
        make_scene(duration_s=1.0, outputs=ENERGY, numerics={"sample_rate_hz": 1000.0}), 0.9
    )
    result = run_scene(scene)
    assert len(result.signals) >= 999  # 1 kHz over 1 s
    assert_sound(result)


# --- at the estimated stability limit ----------------------------------------------------------
# These were strict xfails while stability.py used the central-difference limit; the kernel's
# Verlet damps at the predicted velocity, whose limit 2 (sqrt(1 + 4 zeta^2) - 2 zeta) / omega is
# now used (and the cage contacts take the chain force, not mu F_s).


def test_linear_stiff_at_90_percent_of_the_estimated_limit(run_scene):
    assert_sound(run_scene(linear_stiff(0.9)))


def test_seed_at_the_estimated_limit_keeps_the_energy_balance(run_scene):
    scene = dt_fraction_of_limit(make_scene(duration_s=_duration(), outputs=ENERGY), 1.0)
    assert_sound(run_scene(scene))


def test_non_finite_state_stops_the_run(monkeypatch):
    # Was a strict xfail: under the kernel's fastmath flags LLVM folded the divergence check
    # math.isfinite(x + y + vx + vy) to True; the check now runs outside fastmath.
    # An absurd load (1.7e308 N) only the kernel sees: the inner ring's acceleration overflows.
    original = dem_simulate.kernel_parameters

    def overflowing(scene):
        p = original(scene)
        p["radial_load_n"] = 1.7e308
        return p

    monkeypatch.setattr(dem_simulate, "kernel_parameters", overflowing)
    scene = make_scene(duration_s=_duration(), outputs={**ENERGY, "electrical": False})
    with pytest.raises(DivergenceError, match="not finite"):
        simulate(scene)


# --- refusal and divergence ---------------------------------------------------------------------


def test_dt_above_the_limit_is_refused_before_running(monkeypatch):
    scene = make_scene(duration_s=_duration(), outputs=ENERGY)
    limit = stability_limit(scene)
    too_large = replace(scene, numerics=replace(scene.numerics, dt_s=1.5 * limit.dt_limit_s))

    def no_kernel(*args, **kwargs):
        raise AssertionError("the kernel was requested: the refusal came too late")

    monkeypatch.setattr(dem_simulate, "get_kernel", no_kernel)
    with pytest.raises(SceneError) as err:
        simulate(too_large)
    message = str(err.value)
    assert "numerics.dt_s" in message and "\n" not in message
    assert f"{limit.dt_limit_s:.3g}" in message and limit.body in message


def _allow_any_dt(monkeypatch):
    def anything(scene):
        return StabilityLimit(1.0, "test (stability check disabled)", 0.0, 0.0, 0.0)

    monkeypatch.setattr(dem_simulate, "stability_limit", anything)


DIVERGENCE = (
    r"diverged at step \d+ \(t = [0-9.e-]+ s\): (ball \d+|cage ball \d+|inner ring), "
    r"[a-z/ -]+ overlap beyond 10 % of the body radius"
)


def test_forced_divergence_names_step_body_and_quantity(monkeypatch):
    scene = make_scene(duration_s=_duration(), outputs=ENERGY)
    dt = 20.0 * stability_limit(scene).dt_limit_s
    _allow_any_dt(monkeypatch)
    with pytest.raises(DivergenceError, match=DIVERGENCE):
        simulate(replace(scene, numerics=replace(scene.numerics, dt_s=dt)))


def test_forced_divergence_through_the_cli_exits_3_and_writes_nothing(
    monkeypatch, tmp_path, capsys
):
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text("[outputs]\nenergy = true\n")
    work = tmp_path / "work"
    work.mkdir()
    out = work / "run"
    dt = 20.0 * stability_limit(make_scene(outputs=ENERGY)).dt_limit_s
    _allow_any_dt(monkeypatch)
    argv = ["simulate", "--scene", str(scene_file), "--duration", "0.01", "--dt", repr(dt)]
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--out", str(out), "--quiet"])
    assert exc.value.code == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("signatelec: error: simulation diverged at step")
    assert not out.exists()
    assert list(work.iterdir()) == []


# --- contact laws (signatelec.physics.contact): properties ----------------------------------------

BEARING = Bearing()
HERTZ = contact.law_coefficients(BEARING, "hertz")[0]
PROPS = contact_properties(BEARING)
_overlap = st.floats(0.0, 5e-4, allow_nan=False)
_speed = st.floats(-5.0, 5.0, allow_nan=False)
_kind = st.sampled_from(range(5))


@settings(max_examples=200, deadline=None)
@given(_overlap, _overlap, _kind)
def test_hertz_force_is_non_negative_monotone_and_continuous(d1, d2, kind):
    c = HERTZ[kind]
    lo, hi = min(d1, d2), max(d1, d2)
    f_lo, f_hi = contact.hertz_normal_force(lo, c), contact.hertz_normal_force(hi, c)
    assert 0.0 <= f_lo <= f_hi
    # continuity (mean value theorem): the tangent stiffness grows with overlap, so
    # |F(hi) - F(lo)| <= K(hi) (hi - lo); rounding allowance 1e-12 relative
    assert f_hi - f_lo <= contact.hertz_normal_stiffness(hi, c) * (hi - lo) * (1 + 1e-12) + 1e-300
    # apart there is no force, and the inverse recovers the overlap
    assert contact.hertz_normal_force(-hi, c) == 0.0
    assert contact.hertz_overlap(f_hi, c) == pytest.approx(hi, rel=1e-12, abs=1e-18)


@settings(max_examples=200, deadline=None)
@given(_overlap, st.floats(1e-9, 1e-6), _kind, st.sampled_from(["hertz", "linear"]))
def test_elastic_energy_is_the_work_of_the_force(d, h, kind, law):
    # dE/d(delta) = F, checked without quadrature error: F grows with the overlap, so the work
    # over [d, d + h] lies between F(d) h and F(d + h) h. Allowance: rounding of E(d + h) - E(d).
    if law == "hertz":
        c = HERTZ[kind]
        force, energy = contact.hertz_normal_force, contact.hertz_elastic_energy
    else:
        c = contact.law_coefficients(BEARING, "linear")[0][kind]
        force, energy = contact.linear_normal_force, contact.linear_elastic_energy
    work = energy(d + h, c) - energy(d, c)
    rounding = 4 * np.finfo(float).eps * energy(d + h, c)
    assert force(d, c) * h - rounding <= work <= force(d + h, c) * h + rounding


@settings(max_examples=200, deadline=None)
@given(_overlap, _overlap, _speed, _kind, st.sampled_from(["hertz", "linear"]))
def test_damped_normal_force_is_non_negative_and_monotone_when_closing(d1, d2, v, kind, law):
    m = PROPS[kind].reduced_mass_kg
    lo, hi = min(d1, d2), max(d1, d2)
    if law == "hertz":
        c = HERTZ[kind]

        def force(d, speed):
            fe = contact.hertz_normal_force(d, c)
            return contact.damped_normal_force(fe, contact.hertz_critical_damping(d, c, m), speed)
    else:
        k = contact.law_coefficients(BEARING, "linear")[0][kind]

        def force(d, speed):
            fe = contact.linear_normal_force(d, k)
            return contact.damped_normal_force(fe, contact.critical_damping(k, m), speed)

    assert force(lo, v) >= 0.0 and force(hi, v) >= 0.0  # a contact never attracts
    closing = abs(v)
    assert force(lo, closing) <= force(hi, closing) * (1 + 1e-12) + 1e-290
    if law == "hertz":
        # continuous at contact onset: F <= c delta^1.5 + 2 sqrt(1.5 c m) delta^(1/4) |v|, a bound
        # that vanishes with the overlap (the linear law's damping jumps at onset, by design)
        bound = c * lo**1.5 + 2 * math.sqrt(1.5 * c * m) * lo**0.25 * closing
        # relative round-off, plus an absolute floor for subnormal forces (~1e-305 N), where
        # relative precision is lost
        assert force(lo, closing) <= bound * (1 + 1e-12) + 1e-290


@settings(max_examples=300, deadline=None)
@given(
    st.floats(0.0, 1e9),
    st.floats(-1e-3, 1e-3),
    st.floats(0.0, 1e4),
    _speed,
    st.floats(-1e4, 1e5),
    st.floats(0.0, 2.0),
)
def test_tangential_force_stays_in_the_coulomb_cone(k_t, displacement, c_t, slip, f_n, mu):
    candidate = contact.tangential_force(k_t, displacement, c_t, slip)
    f_t = contact.coulomb_limit(candidate, f_n, mu)
    cone = mu * max(f_n, 0.0)
    assert abs(f_t) <= cone * (1 + 1e-15)
    assert f_t * candidate >= 0.0  # never reverses the candidate
    if abs(candidate) <= cone:
        assert f_t == candidate


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 1e9), st.floats(0.0, 1e4), _speed, st.floats(1e-9, 1e-6))
def test_seed_tangential_law_only_dissipates(k_t, c_t, slip, dt):
    # seed law delta_t = v_t dt: F_t = -(K_t dt + C_t) v_t opposes the slip, so the friction
    # power F_t v_t the kernel books as dissipated is never negative
    f_t = contact.coulomb_limit(contact.tangential_force(k_t, slip * dt, c_t, slip), 1e3, 0.15)
    assert f_t * slip <= 0.0


# --- Kirchhoff network: properties beyond tests/test_electrical.py -------------------------------
# test_electrical.py checks ring currents, R > 0 and Rayleigh on bearing-shaped networks and
# per-node conservation on one fixed random network; here: arbitrary networks, per-ball and
# per-node conservation, Tellegen's power balance and Rayleigh for a ball added anywhere.

GAMMA = BEARING.electrical_conductivity_s_m
NETWORK_RTOL = 1e-6
V_BALL = BEARING.ball_volume_m3


@st.composite
def _networks(draw):
    """Random contact lists: each ball touches 1-4 nodes at distinct points of its surface.

    Contact directions lie on a 10-degree grid, distinct on one ball (two contacts of a ball are
    never at one point): 1 - cos(theta) >= 0.015 keeps eq. 16 well conditioned.
    """
    n_balls = draw(st.integers(1, 8))
    n_nodes = draw(st.integers(2, 6))
    ball, node, angle = [], [], []
    for k in range(n_balls):
        touched = draw(st.lists(st.integers(0, n_nodes - 1), min_size=1, max_size=4, unique=True))
        where = draw(
            st.lists(st.integers(0, 35), min_size=len(touched), max_size=len(touched), unique=True)
        )
        ball += [k] * len(touched)
        node += touched
        angle += [math.radians(10 * w) for w in where]
    area = draw(
        st.lists(
            st.one_of(st.just(0.0), st.floats(1e-9, 3e-6)), min_size=len(ball), max_size=len(ball)
        )
    )
    direction = np.column_stack([np.cos(angle), np.sin(angle)])
    return np.array(ball), np.array(node), np.array(area), direction


@settings(max_examples=150, deadline=None)
@given(_networks(), st.integers(0, 5), st.integers(0, 5), st.floats(1e-8, 3e-6))
def test_network_conserves_current_and_power_and_obeys_rayleigh(net, a, b, new_area):
    ball, node, area, direction = net
    current = 0.1
    sol = solve_network(ball, node, area, direction, current)
    assert sol.resistance_ohm > 0.0 and not math.isnan(sol.resistance_ohm)
    n_nodes = max(int(node.max()) + 1, 2)
    # Kirchhoff: zero net current into every ball, +I / -I / 0 at outer ring / inner ring /
    # junctions. Tolerance: LU is backward stable, its relative error ~ eps x the conductance
    # ratio, which here reaches (3e-6 / 1e-9)^2 x 2 / 0.015 ~ 1e9 (areas and angles drawn above),
    # i.e. ~2e-7; NETWORK_RTOL = 1e-6 (Rayleigh's R' <= R missed by 2e-9 at 1e-10 tolerance)
    tol = NETWORK_RTOL * current
    np.testing.assert_allclose(np.bincount(ball, sol.contact_current_a), 0.0, rtol=0, atol=tol)
    into = np.bincount(node, sol.contact_current_a, minlength=n_nodes)
    expected = np.zeros(n_nodes)
    if math.isfinite(sol.resistance_ohm):
        expected[OUTER_RING_NODE], expected[1] = current, -current
        # Tellegen: the resistors dissipate what the source delivers, sum C dV^2 = I^2 R
        power = 0.0
        for k in np.unique(ball):
            rows = np.flatnonzero(ball == k)
            for i, p in enumerate(rows):
                for q in rows[i + 1 :]:
                    dv = sol.node_potential_v[node[p]] - sol.node_potential_v[node[q]]
                    if np.isfinite(dv):
                        cos = float(direction[p] @ direction[q])
                        c = ball_conductance(
                            area[p], area[q], cos, conductivity_s_m=GAMMA, ball_volume_m3=V_BALL
                        )
                        power += c * dv * dv
        assert power == pytest.approx(current**2 * sol.resistance_ohm, rel=NETWORK_RTOL)
    np.testing.assert_allclose(into, expected, rtol=0, atol=tol)

    # Rayleigh: one more conducting ball between any two nodes never raises the resistance;
    # between the two rings it always gives a finite one
    a, b = a % n_nodes, b % n_nodes
    if a == b:
        a, b = 0, 1
    k = int(ball.max()) + 1
    more = solve_network(
        np.append(ball, [k, k]),
        np.append(node, [a, b]),
        np.append(area, [new_area, new_area]),
        np.vstack([direction, [[1.0, 0.0], [-1.0, 0.0]]]),
        current,
    )
    assert more.resistance_ohm <= sol.resistance_ohm * (1 + NETWORK_RTOL)
    if {a, b} == {0, 1}:
        assert math.isfinite(more.resistance_ohm)
