"""The lubricated bearing from a run's recorded kinematics and loads (``effects.lubrication``).

Post-processing of either engine's tables (the DEM's and the quasi-static tier's carry the same
columns): per ball and instant the entrainment speed of each contact from the ball's orbit and
spin and the ring speed, the Hamrock-Dowson films and Lambda (:mod:`signatelec.physics.ehl`),
the contacts' film capacitance and asperity conduction and the bearing's impedance
(:mod:`signatelec.physics.lubricated_contact`). With ``effects.lubrication = "none"`` nothing here
runs and the tables are the dry model's.

Columns added: ``signals`` ``capacitance_f`` (the parallel capacitance Im(Y) / omega an LCR meter
reads at ``operating.measurement_frequency_hz``), ``impedance_ohm`` (|Z|),
``impedance_phase_rad``, and ``resistance_ohm`` becomes the lubricated bearing's DC resistance
(the seed's dry value at Lambda -> 0); ``balls`` ``inner_film_m``, ``outer_film_m`` (central film,
or the separation of an unloaded contact), ``inner_film_parameter``, ``outer_film_parameter``
(Lambda = h_min / sigma), ``inner_regime``, ``outer_regime`` (boundary, mixed, full). Ball
currents and potentials stay those of the dry network. Ball/ball contacts (cage off) do not
conduct in this model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from signatelec.config.bearing import raceway_radii
from signatelec.config.scene import Scene
from signatelec.engines.results import SimulationResult
from signatelec.physics.conductance import bearing_contact_area
from signatelec.physics.ehl import (
    LUBRICATION_REGIMES,
    entrainment_speed_m_s,
    film_thickness_m,
    lubrication_regime,
)
from signatelec.physics.lubricated_contact import (
    ball_impedance_ohm,
    bearing_impedance_ohm,
    contact_film,
    dry_ball_conductance_s,
    metallic_fraction,
)

#: Load at which an unloaded contact's film is evaluated (its floor: the separation of an
#: unloaded ball is never below the film a 1 N contact would carry), N.
UNLOADED_FILM_LOAD_N = 1.0


@dataclass(frozen=True)
class ContactState:
    """Every ball's contacts at every instant, arrays (n_instants, n_balls) per race."""

    film_m: dict  # central film (loaded) or separation (unloaded)
    film_parameter: dict  # Lambda = h_min / sigma
    capacitance_f: dict
    leakage_s: dict
    metal_fraction: dict
    dry_conductance_s: np.ndarray

    def ball_impedance(self, frequency_hz) -> np.ndarray:
        return ball_impedance_ohm(
            frequency_hz,
            self.capacitance_f["inner"],
            self.capacitance_f["outer"],
            self.leakage_s["inner"],
            self.leakage_s["outer"],
            self.dry_conductance_s,
            self.metal_fraction["inner"],
            self.metal_fraction["outer"],
        )


def contact_state(scene: Scene, balls: pd.DataFrame, signals: pd.DataFrame) -> ContactState:
    """Films, Lambda, capacitances and metallic fractions of a run's contacts."""
    b = scene.bearing
    oil = scene.lubricant.resolved()
    z = b.n_balls
    n = len(signals)

    def per_ball(column):
        return balls[column].to_numpy(dtype=float).reshape(n, z)

    speed = dict(
        zip(
            ("inner", "outer"),
            entrainment_speed_m_s(
                per_ball("orbit_speed_rad_s"),
                per_ball("spin_rad_s"),
                signals["inner_omega_rad_s"].to_numpy()[:, None],
                b.ball_radius_m,
                b.inner_race_radius_m,
                signals["outer_race_radius_m"].to_numpy()[:, None],
            ),
            strict=True,
        )
    )
    bx, by = per_ball("x_m"), per_ball("y_m")
    ix = signals["inner_x_m"].to_numpy()[:, None]
    iy = signals["inner_y_m"].to_numpy()[:, None]
    separation = {
        "inner": np.hypot(bx - ix, by - iy) - b.ball_radius_m - b.inner_race_radius_m,
        "outer": signals["outer_race_radius_m"].to_numpy()[:, None]
        - np.hypot(bx, by)
        - b.ball_radius_m,
    }
    modulus = b.ball_material.plane_strain_modulus_pa
    radii = raceway_radii(b)
    film, lam, cap, leak, metal, area = {}, {}, {}, {}, {}, {}
    for race in ("inner", "outer"):
        rx, ry, _, alpha = radii[race]
        force = per_ball(f"{race}_force_n")
        loaded = force > 0.0
        args = (speed[race], oil.viscosity_pa_s, oil.pressure_viscosity_1_pa, rx, alpha, modulus)
        h_c, h_min = film_thickness_m(np.where(loaded, force, 1.0), *args)
        floor_c, floor_min = film_thickness_m(UNLOADED_FILM_LOAD_N, *args)
        gap = np.maximum(separation[race], floor_c)
        h_c = np.where(loaded, h_c, gap)
        h_min = np.where(loaded, h_min, np.maximum(separation[race], floor_min))
        area[race] = bearing_contact_area(force, b, race)
        lam[race] = h_min / oil.roughness_m
        metal[race] = np.where(loaded, metallic_fraction(lam[race]), 0.0)
        film[race] = h_c
        # rough surfaces in contact keep their mean planes ~sigma apart: the capacitive gap
        # never closes below the composite roughness (at rest h_c is 0)
        cap[race], leak[race] = contact_film(
            area[race], np.maximum(h_c, oil.roughness_m), metal[race], rx, ry, oil
        )
    dry = dry_ball_conductance_s(area["inner"], area["outer"], -1.0, b)
    return ContactState(film, lam, cap, leak, metal, dry)


def add_lubrication(result: SimulationResult) -> None:
    """Add the lubricated bearing's columns to ``result``'s tables (see the module docstring)."""
    lubricate_tables(result.scene, result.balls, result.signals)


def lubricate_tables(scene: Scene, balls: pd.DataFrame, signals: pd.DataFrame) -> None:
    """Add the lubricated bearing's columns to ``balls`` and ``signals`` (in place): the whole
    run's tables, or one streamed block of them (:class:`signatelec.engines.stream.TableStream`).

    ``signals`` also gains ``film_parameter_min``, the smallest Lambda of the loaded contacts at
    each instant (NaN when none is loaded): the bearing's regime at a glance.
    """
    state = contact_state(scene, balls, signals)
    frequency = scene.operating.measurement_frequency_hz
    impedance = bearing_impedance_ohm(state.ball_impedance(frequency))
    dc = bearing_impedance_ohm(state.ball_impedance(0.0)).real
    with np.errstate(divide="ignore", invalid="ignore"):
        admittance = np.where(np.isfinite(impedance), 1.0 / impedance, 0.0)
    signals["resistance_ohm"] = dc
    signals["capacitance_f"] = admittance.imag / (2.0 * np.pi * frequency)
    signals["impedance_ohm"] = np.abs(impedance)
    signals["impedance_phase_rad"] = np.where(np.isfinite(impedance), np.angle(impedance), 0.0)
    loaded_lambda = []
    for race in ("inner", "outer"):
        balls[f"{race}_film_m"] = state.film_m[race].ravel()
    for race in ("inner", "outer"):
        balls[f"{race}_film_parameter"] = state.film_parameter[race].ravel()
        loaded = balls[f"{race}_force_n"].to_numpy().reshape(state.film_parameter[race].shape) > 0
        loaded_lambda.append(np.where(loaded, state.film_parameter[race], np.inf))
    for race in ("inner", "outer"):
        balls[f"{race}_regime"] = pd.Categorical.from_codes(
            lubrication_regime(state.film_parameter[race]).ravel(), LUBRICATION_REGIMES
        )
    smallest = np.min(np.concatenate(loaded_lambda, axis=1), axis=1)
    signals["film_parameter_min"] = np.where(np.isfinite(smallest), smallest, np.nan)


def impedance_sweep(result: SimulationResult, frequencies_hz, instant: int = -1) -> pd.DataFrame:
    """The bearing's impedance over ``frequencies_hz`` at one recorded instant (a Bode plot).

    Columns ``frequency_hz``, ``impedance_ohm`` (|Z|), ``impedance_phase_rad``, ``capacitance_f``
    (Im(Y) / omega) and ``resistance_ohm`` (1 / Re(Y)). Works whatever ``effects.lubrication``
    says (the scene's oil and surfaces are used).
    """
    f = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    if f.size == 0 or not np.all(np.isfinite(f) & (f > 0.0)):
        raise ValueError("frequencies_hz must be finite numbers > 0")
    n = len(result.signals)
    row = instant % n if n else 0
    signals = result.signals.iloc[[row]].reset_index(drop=True)
    z = result.scene.bearing.n_balls
    balls = result.balls.iloc[row * z : (row + 1) * z].reset_index(drop=True)
    state = contact_state(result.scene, balls, signals)
    impedance = bearing_impedance_ohm(state.ball_impedance(f[:, None]))
    admittance = 1.0 / impedance
    return pd.DataFrame(
        {
            "frequency_hz": f,
            "impedance_ohm": np.abs(impedance),
            "impedance_phase_rad": np.angle(impedance),
            "capacitance_f": admittance.imag / (2.0 * np.pi * f),
            "resistance_ohm": 1.0 / admittance.real,
        }
    )
