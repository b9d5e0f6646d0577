"""The lines a bearing's defects, its shaft and its cage put in the resistance spectrum, by
name, and which of them a healthy bearing shows too: read by the ripple search
(:mod:`signatelec.measurement.ripple`: a line away from the ball-pass frequency that lies on
one is a defect's or the cage's, not a wrong speed), the sanity layer and the condition's
confirmation of a defect's line (:mod:`signatelec.estimation.health`)."""

from __future__ import annotations

from signatelec.physics.kinematics import characteristic_frequencies_hz

#: Half-width of the match of a line to a defect's line, relative (the DEM's cage slips by
#: -0.3 to +0.1 %, a ball's spin more), widened by two frequency bins 2 / T of the trace.
DEFECT_LINE_REL = 0.01
#: The lines of :func:`defect_lines_hz` that a healthy bearing shows too: the shaft's harmonics
#: (a runout, an unbalance) and the cage's (with a clearance a few balls carry the load, and
#: the ball set's rotation modulates it: the 6208 at epsilon 0.33-0.38 shows FTF, 2 FTF and
#: 3 FTF above its ball-pass line). A line there beside the ripple is no defect's own.
HEALTHY_LINES = frozenset({f"{k} f_s" for k in range(1, 9)} | {f"{k} FTF" for k in range(1, 5)})


def defect_lines_hz(omega_rad_s: float, bearing=None) -> dict[str, tuple[str, float]]:
    """The lines a defect or an unbalance puts in the resistance spectrum, by name: (the
    condition, Hz): the shaft harmonics (unbalance), BPFI's harmonics and its shaft sidebands
    (inner race), 2 BSF's harmonics, its cage sidebands and the cage harmonics (ball);
    Randall and Antoni (2011, eqs 1-4). ``bearing``: its geometry (default: the seed's)."""
    f = characteristic_frequencies_hz(omega_rad_s, bearing)
    lines: dict[str, tuple[str, float]] = {}
    for k in range(1, 9):
        lines[f"{k} f_s"] = ("unbalance", k * f["shaft"])
    for k in range(1, 5):
        lines[f"{k} BPFI"] = ("inner", k * f["bpfi"])
        lines[f"{k} x 2 BSF"] = ("ball", k * f["ball_defect"])
        lines[f"{k} FTF"] = ("ball", k * f["ftf"])
    for j in (-2, -1, 1, 2):
        lines[f"BPFI {j:+d} f_s"] = ("inner", f["bpfi"] + j * f["shaft"])
    for j in (-3, -2, -1, 1, 2, 3):
        lines[f"2 BSF {j:+d} FTF"] = ("ball", f["ball_defect"] + j * f["ftf"])
    return lines


def defect_line_of(
    frequency_hz: float, omega_rad_s: float, duration_s: float, bearing=None
) -> tuple[str, str] | None:
    """(condition, line name) of the defect line nearest ``frequency_hz`` within
    :data:`DEFECT_LINE_REL` (+ 2 / T), or None."""
    best = None
    for name, (condition, f) in defect_lines_hz(omega_rad_s, bearing).items():
        off = abs(frequency_hz - f)
        if off <= DEFECT_LINE_REL * f + 2.0 / duration_s and (best is None or off < best[0]):
            best = (off, condition, name)
    return None if best is None else (best[1], best[2])


def defect_own(frequency_hz: float, omega_rad_s: float, duration_s: float, bearing) -> bool:
    """Whether a line lies on a defect's own line (:func:`defect_line_of`, not one of
    :data:`HEALTHY_LINES`): BPFI's family or 2 BSF's, which only a spall puts in the trace."""
    line = defect_line_of(frequency_hz, omega_rad_s, duration_s, bearing)
    return line is not None and line[1] not in HEALTHY_LINES
