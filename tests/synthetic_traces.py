"""Synthetic resistance traces of a bearing with a spall or an unbalance, whose answers are known.

A healthy ripple at BPFO (0.1 % and 0.03 % of the level at its first two harmonics, as the
DEM's) plus, for a spall, rectangular pulses at its characteristic line (Randall and Antoni 2011,
eqs 1-4) lasting the time the contact takes to cross the spall, length / surface speed of the
contact over the spalled surface (the ball loses that contact for as long); an inner-race spall's
pulses are modulated by the load zone at f_s, a ball's at FTF; an unbalance modulates the level
at f_s. White noise on top.
"""

from __future__ import annotations

import numpy as np

from signatelec.config.bearing import Bearing
from signatelec.physics.kinematics import characteristic_frequencies_hz

FS = 20000.0
OMEGA = 500.0
LEVEL = 2.5e-3


def contact_speed_m_s(kind: str, omega_rad_s: float, bearing: Bearing | None = None) -> float:
    """Speed of the contact point over the spalled surface, pure rolling: the outer race
    omega_c R_out, the inner race (omega - omega_c) R_inn, the ball 2 pi BSF R_b."""
    b = bearing or Bearing()
    wc = b.cage_speed_rad_s(omega_rad_s)
    if kind == "outer":
        return wc * b.outer_race_radius_m
    if kind == "inner":
        return (omega_rad_s - wc) * b.inner_race_radius_m
    bsf = characteristic_frequencies_hz(omega_rad_s, b)["bsf"]
    return 2.0 * np.pi * bsf * b.ball_radius_m


def spalled_trace(
    kind: str,
    *,
    duration_s: float = 0.2,
    noise: float = 0.002,
    pulse_rel: float = 0.05,
    width_s: float | None = 2e-4,
    length_m: float | None = None,
    level: float = LEVEL,
    bearing=None,
    seed: int = 0,
    omega: float = OMEGA,
    phase: float | None = 0.1,
) -> np.ndarray:
    """A healthy ripple at BPFO (0.1 % and 0.03 % at its first two harmonics, as the DEM's)
    plus, for a spall, rectangular pulses of ``pulse_rel`` of the level (a ball of the five or
    six carrying the current leaving the circuit) at its line (inner: heights modulated by the load
    zone at f_s; ball: at FTF), or for an unbalance a 0.3 % modulation at f_s; white noise of
    ``noise`` of the level. ``phase``: where the first pulse falls in its period (None: drawn,
    like the modulations' phases)."""
    rng = np.random.default_rng(seed)
    drawn = phase is None
    phase = rng.random() if drawn else phase
    zone_phase = 2 * np.pi * rng.random() if drawn else 0.0
    t = np.arange(int(round(duration_s * FS))) / FS
    lines = characteristic_frequencies_hz(omega, bearing)
    bpfo = lines["bpfo"]
    if length_m is not None:
        width_s = length_m / contact_speed_m_s(kind, omega, bearing)
    r = level * (
        1.0 + 1e-3 * np.cos(2 * np.pi * bpfo * t + 0.3) + 3e-4 * np.cos(4 * np.pi * bpfo * t)
    )
    if kind in ("outer", "inner", "ball"):
        f = {"outer": bpfo, "inner": lines["bpfi"], "ball": lines["ball_defect"]}[kind]
        pulses = ((t * f + phase) % 1.0 < width_s * f).astype(float)
        zone = {"outer": 1.0, "inner": lines["shaft"], "ball": lines["ftf"]}[kind]
        if kind != "outer":
            pulses *= np.clip(np.cos(2 * np.pi * zone * t + zone_phase), 0.0, None)
        r = r + level * pulse_rel * pulses
    elif kind == "unbalance":
        r = r * (1.0 + 3e-3 * np.cos(2 * np.pi * lines["shaft"] * t + zone_phase))
    return r * (1.0 + noise * rng.standard_normal(t.size))
