"""Observed order of the integrators in dt (PyBaMM-style: rates = log2(err[:-1] / err[1:])).

The scene keeps every contact closed after the preload phase (10 um preload, no cage, no
gravity), so no contact opens or closes while the error is measured. Damping is off here:
critical Hertz damping C = 2 sqrt(1.5 c sqrt(delta) m) grows as delta^{1/4}, which is not
Lipschitz at the contact onset (every contact starts at delta = 0 in the clearance phase), and
that caps the observed order of any scheme (errors stay ~1e-6 relative, measured). The seed's
tangential law delta_t = v_t dt makes the model itself depend on dt, so only the accumulated
spring is used for the order test.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_scene

from signatelec.engines.simulate import simulate

DTS = (1.2e-7, 6e-8, 3e-8, 1.5e-8)
REFERENCE_DT = 3.75e-9


def observed_orders(integrator: str) -> np.ndarray:
    traces = {}
    for dt in (*DTS, REFERENCE_DT):
        scene = make_scene(
            omega_rad_s=100.0,
            clearance_m=-10e-6,
            duration_s=1.2e-3,
            effects={
                "tangential": "spring",
                "cage": "none",
                "gravity": "none",
                "damping": "none",
            },
            outputs={"electrical": False},
            numerics={"dt_s": dt, "sample_rate_hz": 1e4 / 1.2, "integrator": integrator},
            procedure={"clearance_time_s": 0.1e-3, "load_time_s": 0.3e-3, "spin_up_time_s": 0.5e-3},
        )
        r = simulate(scene)
        traces[dt] = np.concatenate(
            [r.balls.inner_force_n, r.balls.outer_force_n, r.balls.inner_tangential_n]
        )
    ref = traces[REFERENCE_DT]
    err = np.array([np.abs(traces[dt] - ref).max() for dt in DTS])
    return np.log2(err[:-1] / err[1:])


@pytest.mark.slow
def test_velocity_verlet_is_second_order():
    rates = observed_orders("verlet")
    assert np.all((rates > 1.8) & (rates < 2.3)), rates  # measured 2.007, 2.015, 2.075


@pytest.mark.slow
def test_symplectic_euler_is_first_order():
    rates = observed_orders("euler")
    assert np.all((rates > 0.9) & (rates < 1.4)), rates  # measured 1.33, 1.21, 1.28
