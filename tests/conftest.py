"""Shared fixtures. Simulations are cached per session: several tests read one run."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import pytest

from signatelec.config.scene import Effects, Numerics, Operating, Outputs, Procedure, Scene

CR_N = 29100.0  # NSK dynamic load rating of the 6208 (seed 2.2.2)


def make_scene(
    radial_load_n: float = 5820.0,
    clearance_m: float = 0.0,
    omega_rad_s: float = 500.0,
    duration_s: float = 0.012,
    effects: dict | None = None,
    numerics: dict | None = None,
    procedure: dict | None = None,
    outputs: dict | None = None,
) -> Scene:
    return Scene(
        operating=Operating(
            radial_load_n=radial_load_n, clearance_m=clearance_m, omega_rad_s=omega_rad_s
        ),
        procedure=replace(Procedure(), **(procedure or {})),
        effects=replace(Effects(), **(effects or {})),
        outputs=replace(Outputs(), **(outputs or {})),
        numerics=replace(Numerics(duration_s=duration_s), **(numerics or {})),
    )


@cache
def _run(scene: Scene):
    from signatelec.engines.simulate import simulate

    return simulate(scene)


@pytest.fixture(scope="session")
def run_scene():
    """Simulate a scene once per test session (scenes are frozen, hence hashable)."""
    return _run


def solve_network(ball, node, area, direction=None, current_a=0.1):
    """signatelec.physics.electrical.network_resistance for the seed bearing's balls (gamma,
    V_b)."""
    from signatelec.config.bearing import Bearing
    from signatelec.physics.electrical import network_resistance

    b = Bearing()
    return network_resistance(
        ball,
        node,
        area,
        direction,
        conductivity_s_m=b.electrical_conductivity_s_m,
        ball_volume_m3=b.ball_volume_m3,
        injected_current_a=current_a,
    )
