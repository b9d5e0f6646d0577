"""Localised defects and abnormal loads: the surface, the unloaded ball, the signature's lines.

Physics checked against theory: Sawalhi and Randall's bridged depth (MSSP 22, 2008), the
quasi-static equilibrium of the ring with the ball over a spall removed (Harris 2001, 7.3), and
the characteristic frequencies BPFO, BPFI, 2 BSF (Randall and Antoni 2011, eqs 1-4) from the
measured cage speed.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from signatelec.config.scene import Scene, SceneError
from signatelec.engines.dem.run import simulate_dem
from signatelec.engines.dem.spec import SCENE_FLAGS, KernelSpec
from signatelec.engines.quasistatic.tier import simulate_quasistatic, solve_ring_equilibrium
from signatelec.physics import kinematics
from signatelec.physics.defect_geometry import contact_radii_m
from signatelec.physics.defects import bridged_drop_m, spall_drop_m

SPALL = {"length_m": 1.5e-3, "depth_m": 50e-6}


def _scene(defects=(), **sections) -> Scene:
    return Scene.from_dict({"defects": [SPALL | d for d in defects], **sections})


@functools.cache
def _run(location: str, omega_rad_s: float = 500.0, duration_s: float = 0.06):
    scene = _scene(
        [{"location": location}],
        operating={"omega_rad_s": omega_rad_s},
        numerics={"duration_s": duration_s},
    )
    return simulate_dem(scene)


def test_the_spall_profiles_follow_the_bridged_depth_rule():
    radius, depth = 6.3e-3, 50e-6
    for length in (0.5e-3, 1.5e-3, 4e-3):
        half = 0.5 * length
        bridged = min(depth, radius - math.sqrt(radius**2 - half**2))  # Sawalhi & Randall 2008
        assert bridged_drop_m(half, depth, radius) == pytest.approx(bridged, rel=1e-12)
        assert spall_drop_m(0.3 * half, half, depth, radius, False) == pytest.approx(bridged)
        assert spall_drop_m(1.01 * half, half, depth, radius, False) == 0.0
        # smooth: rides the edges down, the rectangular drop at the centre, 0 at the edges
        assert spall_drop_m(0.0, half, depth, radius, True) == pytest.approx(bridged)
        assert spall_drop_m(0.999 * half, half, depth, radius, True) < 0.01 * bridged
    # a 0.5 mm pit is bridged: the ball does not reach its bottom
    assert bridged_drop_m(0.25e-3, depth, radius) < 0.2 * depth


def test_a_healthy_scene_compiles_no_defect_code():
    assert dict(KernelSpec.default().scene) == dict.fromkeys(SCENE_FLAGS, False)
    assert KernelSpec.default().key == "balls-coulomb-critical-hertz-seed-standard-inertial-verlet"
    # zero amplitudes are no abnormal load: the healthy kernel
    zero = Scene.from_dict(
        {"loads": {"unbalance_phase_rad": 1.0}, "housing": {"out_of_round_lobes": 3}}
    )
    assert KernelSpec.from_scene(zero) == KernelSpec.default()
    assert not zero.abnormal
    flags = KernelSpec.from_scene(_scene([{"location": "ball"}], loads={"unbalance_force_n": 50.0}))
    assert {n for n, on in flags.scene if on} == {"DEFECTS_BALL", "UNBALANCE"}


def test_bad_defects_and_loads_are_refused_in_one_line():
    cases = [
        ({"defects": [SPALL | {"location": "cage"}]}, "defects[0].location = 'cage'"),
        ({"defects": [SPALL | {"location": "ball", "ball": 13}]}, "defects[0].ball = 13"),
        ({"defects": [{"location": "outer", "length_m": 0.3, "depth_m": 1e-5}]}, "circumference"),
        ({"defects": [{"location": "inner", "length_m": 1e-3, "depth_m": 0.0}]}, "> 0"),
        ({"defects": [{"location": "inner", "length_m": 1e-3, "depth_m": 1e-3}]}, "ball radius"),
        (
            {"loads": {"load_table_time_s": [0.02, 0.01], "load_table_radial_load_n": [1, 2]}},
            "times must increase",
        ),
        ({"loads": {"unbalance_force_n": 1e6}}, "plus the largest F_r"),
        ({"housing": {"out_of_round_lobes": 1.5}}, "must be an integer"),
        # a list reached the lobes' rule before its type was checked (a TypeError)
        ({"housing": {"out_of_round_lobes": []}}, "out_of_round_lobes = []: must be an integer"),
    ]
    for table, match in cases:
        with pytest.raises(SceneError, match=match.replace("[", r"\[").replace("(", r"\(")) as e:
            Scene.from_dict(table)
        assert "\n" not in str(e.value)
    scene = _scene([{"location": "ball", "ball": 3, "profile": "smooth"}])
    assert Scene.from_dict(scene.to_dict()) == scene


def test_a_deep_outer_spall_unloads_the_ball_over_it_and_the_others_carry_the_load():
    """Standing ring (omega = 0): ball 0 rests on a spall in the load direction, deeper than its
    Hertz approach; the other balls carry F_r as the theory says with ball 0 removed."""
    scene = _scene(
        [{"location": "outer", "length_m": 4e-3, "depth_m": 150e-6}],
        operating={"omega_rad_s": 0.0},
        numerics={"duration_s": 0.01},
    )
    result = simulate_dem(scene)
    steady = result.balls[result.balls.time_s > 0.008]
    loads = steady.groupby("ball").inner_force_n.mean().to_numpy()
    healthy = solve_ring_equilibrium(scene, np.zeros((1, 13)) + 2 * np.pi * np.arange(13) / 13)
    approach = healthy.inner_overlap_m[0, 0] + healthy.outer_overlap_m[0, 0]
    rb_out = contact_radii_m(scene.bearing)[1]
    assert bridged_drop_m(2e-3, 150e-6, rb_out) > 2.0 * approach
    psi = 2 * np.pi * np.arange(1, 13) / 13
    theory = solve_ring_equilibrium(scene, psi[None, :]).inner_force_n[0]
    assert loads[0] < 1e-3 * loads.max()
    carrying = theory > 0.05 * theory.max()
    # measured within 0.3 %; the requirement asks 2 %
    np.testing.assert_allclose(loads[1:][carrying], theory[carrying], rtol=0.02)


def _line_hz(result, f0: float) -> float:
    """Frequency of the largest line of the steady resistance within 10 % of f0 (zero-padded
    Hann spectrum), Hz."""
    s = result.signals[result.signals.phase == "steady"]
    r = s.resistance_ohm.to_numpy()
    dt = float(np.diff(s.time_s.to_numpy()).mean())
    pad = 32 * r.size
    spectrum = np.abs(np.fft.rfft((r - r.mean()) * np.hanning(r.size), pad))
    f = np.fft.rfftfreq(pad, dt)
    band = (f > 0.9 * f0) & (f < 1.1 * f0)
    return float(f[band][np.argmax(spectrum[band])])


def _events(result) -> np.ndarray:
    """Start times of the excursions of the steady resistance beyond 5 % of its median, s."""
    s = result.signals[result.signals.phase == "steady"]
    r, t = s.resistance_ohm.to_numpy(), s.time_s.to_numpy()
    away = np.abs(r - np.median(r)) > 0.05 * np.median(r)
    starts = t[1:][away[1:] & ~away[:-1]]
    # an entry and an exit edge of one passage lie closer than a tenth of the ball pass
    return starts[np.r_[True, np.diff(starts) > 1e-3]]


def _measured(result):
    s = result.signals[result.signals.phase == "steady"]
    cage_hz = s.cage_speed_rad_s.mean() / (2 * np.pi)
    shaft_hz = s.inner_omega_rad_s.mean() / (2 * np.pi)
    return cage_hz, shaft_hz, result.scene.bearing.n_balls


@pytest.mark.slow
def test_an_outer_spall_gives_one_event_per_ball_pass_at_bpfo():
    result = _run("outer")
    cage_hz, _, z = _measured(result)
    bpfo = z * cage_hz  # Z FTF with the measured cage speed
    assert bpfo == pytest.approx(kinematics.ball_pass_frequency_outer_hz(500.0), rel=0.005)
    events = _events(result)
    periods = np.diff(events)
    np.testing.assert_allclose(periods, 1.0 / bpfo, rtol=0.05)  # one event per passage
    assert _line_hz(result, bpfo) == pytest.approx(bpfo, rel=0.005)


@pytest.mark.slow
def test_an_inner_spall_gives_its_line_at_bpfi_with_shaft_sidebands():
    result = _run("inner")
    cage_hz, shaft_hz, z = _measured(result)
    bpfi = z * (shaft_hz - cage_hz)
    assert _line_hz(result, bpfi) == pytest.approx(bpfi, rel=0.005)
    for side in (bpfi - shaft_hz, bpfi + shaft_hz):  # the load zone modulates at f_s
        assert _line_hz(result, side) == pytest.approx(side, rel=0.005)


@pytest.mark.slow
def test_a_ball_spall_strikes_both_races_once_a_spin_turn_at_twice_bsf():
    result = _run("ball", duration_s=0.2)  # a few load-zone passages of the ball
    cage_hz, _, _ = _measured(result)
    steady = result.balls[(result.balls.ball == 0) & (result.balls.time_s > 0.01)]
    spin_hz = abs(steady.spin_rad_s.mean() / (2 * np.pi) - cage_hz)  # spin relative to the cage
    bsf = kinematics.ball_spin_frequency_hz(500.0)
    assert spin_hz == pytest.approx(bsf, rel=0.01)
    assert _line_hz(result, 2 * spin_hz) == pytest.approx(2 * spin_hz, rel=0.005)
    rotation = steady.ball_rotation_rad.to_numpy()
    assert rotation[-1] - rotation[0] == pytest.approx(
        np.trapezoid(steady.spin_rad_s, steady.time_s), rel=1e-3
    )


def test_the_quasistatic_tier_sees_the_same_defects_and_loads():
    healthy = simulate_quasistatic(Scene())
    outer = simulate_quasistatic(_scene([{"location": "outer"}]))
    r0 = healthy.signals.resistance_ohm
    r1 = outer.signals.resistance_ohm
    assert r1.min() < 0.97 * r0.min()  # the ball over the spall leaves the load zone's network
    table = Scene.from_dict(
        {"loads": {"load_table_time_s": [0.01, 0.012], "load_table_radial_load_n": [5820, 8000]}}
    )
    sig = simulate_quasistatic(table).signals
    late = sig[sig.time_s > table.setup_time_s + 0.012]
    assert np.allclose(late.applied_load_n, 8000.0)
    # a larger load, a smaller resistance (seed fig. 9)
    assert late.resistance_ohm.mean() < 0.97 * r0.mean()


@pytest.mark.slow
def test_abnormal_loads_in_the_dem_follow_the_quasistatic_theory():
    """An unbalance turning at shaft speed, a step of the load table and a three-lobed outer race
    in one run: the DEM against the ring's quasi-static equilibrium under the same loads."""
    scene = Scene.from_dict(
        {
            "loads": {
                "unbalance_force_n": 1000.0,
                "load_table_time_s": [0.02, 0.021],
                "load_table_radial_load_n": [5820.0, 8000.0],
            },
            "housing": {"out_of_round_lobes": 3, "out_of_round_amplitude_m": 5e-6},
            "numerics": {"duration_s": 0.05},
        }
    )
    dem = simulate_dem(scene)
    tier = simulate_quasistatic(scene).signals
    d = dem.signals[dem.signals.phase == "steady"].reset_index(drop=True)
    np.testing.assert_allclose(d.time_s, tier.time_s)
    # the kernel's schedule and the tier apply one load-table rule
    np.testing.assert_allclose(d.applied_load_n, tier.applied_load_n, atol=1e-6)
    after = d.time_s - scene.setup_time_s
    for window in ((after > 0.002) & (after < 0.02), after > 0.023):
        # measured: 0.1 % (resistance), 0.2 % (largest ball load)
        assert d.resistance_ohm[window].mean() == pytest.approx(
            tier.resistance_ohm[window].mean(), rel=0.005
        )
        assert d.max_ball_load_n[window].mean() == pytest.approx(
            tier.max_ball_load_n[window].mean(), rel=0.01
        )
        # the ring follows the unbalance turning with it: its x shift, whose RMS difference
        # from the theory's measured 5-6 % of its own RMS (the DEM's ball-pass ripple)
        x_dem, x_tier = d.inner_x_m[window], tier.inner_x_m[window]
        assert np.sqrt(np.mean((x_dem - x_tier) ** 2)) < 0.15 * x_tier.std()
