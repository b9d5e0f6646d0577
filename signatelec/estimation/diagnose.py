"""The bearing's condition of one screened trace, beside its load state.

:func:`assess_condition` asks a :class:`~signatelec.estimation.condition.ConditionModel` about a
trace that passed the sanity layer, and gives no confident answer to a trace that cannot carry
one:

- a trace shorter than :data:`~signatelec.estimation.envelope.MIN_CAGE_REVOLUTIONS` cage
  revolutions is not assessed (a ball's spall is in the load zone once per cage revolution,
  and its lines 2 BSF -+ FTF are not resolved over less), nor one shorter (in cage
  revolutions, less 5 %) than the shortest trace the condition model learnt from (the lines'
  heights over their floors grow with the length);
- condition features unlike every training trace (in-domain score below
  :data:`~signatelec.estimation.domain.REFUSE_SCORE`) are not assessed; below
  :data:`~signatelec.estimation.domain.WARN_SCORE` the answer carries a warning;
- a top probability below :data:`CONFIDENT_CONDITION` is reported as uncertain, its rivals
  named;
- a speed outside the condition model's training range is an extrapolation, said in a
  warning, and a healthy call there is not confident (:data:`OUTSIDE_SPEEDS`).

The result's keys: ``condition`` (None when not assessed), ``condition_probability_<name>``,
``condition_confident``, ``spall_length_m`` with ``_low`` and ``_high`` (None unless a spall is
the answer), ``condition_in_domain_score``; for a defect or an unbalance the characteristic
line that names it (:data:`CONDITION_LINES`): ``condition_line`` (its name),
``condition_line_hz`` (from the bearing's geometry and the speed,
:func:`~signatelec.physics.kinematics.characteristic_frequencies_hz`),
``condition_line_found_hz`` (the highest peak within the line's search window) and
``condition_line_snr`` (its height over the spectrum's floor there); and notes.
"""

from __future__ import annotations

import math

import numpy as np

from signatelec.config.bearing import Bearing
from signatelec.config.constraints import HEALTHY
from signatelec.estimation.condition import CONDITIONS, PROBABILITY, SEVERITY_TARGET, SPALLS
from signatelec.estimation.condition_features import condition_features
from signatelec.estimation.domain import REFUSE_SCORE, WARN_SCORE, outside_speeds
from signatelec.estimation.envelope import MIN_CAGE_REVOLUTIONS, analyse_envelope

#: A condition call at or above this probability is confident.
CONFIDENT_CONDITION = 0.8
#: The characteristic line of each condition and the spectrum that carries it (module
#: docstring of :mod:`signatelec.estimation.envelope`): a spall's pulses in the envelope, an
#: unbalance's breathing load zone in the trace itself.
CONDITION_LINES = {
    "outer": ("bpfo", "envelope"),
    "inner": ("bpfi", "envelope"),
    "ball": ("ball_defect", "envelope"),
    "unbalance": ("shaft", "raw"),
}
#: Why a healthy call outside the condition model's training speeds is not confident: the
#: default model's confident calls on fast-DEM runs of datasets/diagnosis.toml's design outside
#: them (100-250 rad/s over 0.5 s, 900-1400 rad/s over 0.2 s; 16 runs per condition, 0.2 %
#: noise) were right for every fault (90 of 90; every spall of 0.4 mm or more typed right) and
#: wrong for every healthy call (7 of 7: spalls of 0.12-0.38 mm missed), where inside them
#: (300-700 rad/s) every confident call was right (55 of 55).
OUTSIDE_SPEEDS = "a healthy call there is not confident (a short spall may be missed)"
#: Result keys of the characteristic line.
LINE_KEYS = ("condition_line", "condition_line_hz", "condition_line_found_hz", "condition_line_snr")


def _none(model) -> dict:
    """The result keys of a trace not assessed."""
    out = {"condition": None, "condition_confident": False, "condition_in_domain_score": None}
    for c in getattr(model.estimator, "classes_", CONDITIONS):
        out[f"{PROBABILITY}{c}"] = None
    for k in ("", "_low", "_high"):
        out[f"{SEVERITY_TARGET}{k}"] = None
    return out | dict.fromkeys(LINE_KEYS)


def matched_line(condition: str, analysis) -> dict:
    """The characteristic line of ``condition`` in the trace's ``analysis``
    (:data:`LINE_KEYS`; all None for a healthy call)."""
    if condition not in CONDITION_LINES:
        return dict.fromkeys(LINE_KEYS)
    name, which = CONDITION_LINES[condition]
    spectrum = analysis.envelope if which == "envelope" else analysis.raw
    f_hz = float(analysis.lines_hz[name])
    floor = spectrum.floor(f_hz)
    found = spectrum.peak_hz(f_hz)
    return {
        "condition_line": name,
        "condition_line_hz": f_hz,
        "condition_line_found_hz": found if math.isfinite(found) else None,
        "condition_line_snr": spectrum.line(f_hz) / floor if floor > 0.0 else None,
    }


def speed_warning(model, omega_rad_s, call: str | None) -> str | None:
    """The warning of a condition ``call`` at a speed, or the speeds (low, high) of several
    assessments, outside the condition ``model``'s training range
    (:func:`~signatelec.estimation.domain.outside_speeds`; None within it, or without a
    range): an extrapolation, and a healthy call is not confident there
    (:data:`OUTSIDE_SPEEDS`)."""
    if omega_rad_s is None:
        return None
    low, high = (omega_rad_s, omega_rad_s) if np.isscalar(omega_rad_s) else omega_rad_s
    if (speeds := outside_speeds(model.info.get("ranges"), low, high)) is None:
        return None
    lo, hi = speeds
    speed = f"{low:g}" if low == high else f"{low:g}-{high:g}"
    return (
        f"omega {speed} rad/s is outside the condition model's training range {lo:g}-{hi:g} "
        "rad/s: extrapolating" + (f"; {OUTSIDE_SPEEDS}" if call == HEALTHY else "")
    )


def least_cage_revolutions(model) -> tuple[float, float]:
    """(the fewest cage revolutions a trace must span for the condition ``model`` to assess it,
    the fewest of its training traces'): the lines' heights over their floors grow with the
    trace's length, so fewer than the shortest training trace is an extrapolation the model was
    not asked to make."""
    trained = model.info.get("ranges", {}).get("cage_revolutions", (0.0, 0.0))[0]
    return max(MIN_CAGE_REVOLUTIONS, 0.95 * trained), trained


def assess_condition(
    resistance_ohm,
    sample_rate_hz: float,
    omega_rad_s: float,
    trace_features: dict,
    model,
    bearing: Bearing | None = None,
    trace_analysis=None,
) -> tuple[dict, list[str]]:
    """(condition keys, notes) of one screened trace (module docstring); ``trace_features``
    are its load-state features (:func:`~signatelec.estimation.features.trace_features`),
    ``trace_analysis`` its :func:`~signatelec.estimation.analysis.analyse_trace`, if made."""
    analysis = analyse_envelope(
        resistance_ohm, sample_rate_hz, omega_rad_s, bearing=bearing, analysis=trace_analysis
    )
    revolutions = analysis.cage_revolutions
    least, trained = least_cage_revolutions(model)
    if revolutions < least:
        need = least / analysis.lines_hz["ftf"]
        return _none(model), [
            f"condition not assessed: the trace spans {revolutions:.1f} cage revolutions, "
            f"{least:.2g} are needed (at least {need * 1e3:.0f} ms at this speed; the "
            f"condition model learnt from traces of {trained:.2g} or more)"
        ]
    feats = {**trace_features, **condition_features(None, analysis=analysis)}
    score = model.domain.score(feats)
    if score < REFUSE_SCORE:
        return _none(model) | {"condition_in_domain_score": score}, [
            f"condition not assessed: the trace is unlike every training trace of the condition "
            f"model (in-domain score {score:.2g}; farthest: "
            f"{', '.join(model.domain.farthest(feats))})"
        ]
    out = model.predict_one(feats)
    out |= matched_line(out["condition"], analysis)
    notes = []
    probs = {c: out[f"{PROBABILITY}{c}"] for c in model.estimator.classes_}
    best = out["condition"]
    off_speed = speed_warning(model, omega_rad_s, best)
    out["condition_confident"] = bool(probs[best] >= CONFIDENT_CONDITION)
    out["condition_in_domain_score"] = score
    if off_speed is not None:
        notes.append(f"warning: condition: {off_speed}")
    if not out["condition_confident"]:
        likely = [c for c, p in sorted(probs.items(), key=lambda kv: -kv[1]) if p >= 0.1]
        notes.append(
            f"condition uncertain: {' or '.join(likely)} (no probability reaches "
            f"{CONFIDENT_CONDITION:.0%}); a longer or quieter trace is needed to tell"
        )
    if off_speed is not None and best == HEALTHY:
        out["condition_confident"] = False
    if score < WARN_SCORE:
        notes.append(
            f"warning: condition in-domain score {score:.2g} (below {WARN_SCORE:g}; farthest: "
            f"{', '.join(model.domain.farthest(feats))}): the condition is an extrapolation"
        )
    if best not in SPALLS:
        for k in ("", "_low", "_high"):
            out[f"{SEVERITY_TARGET}{k}"] = None
    else:
        for k in ("", "_low", "_high"):
            v = out.get(f"{SEVERITY_TARGET}{k}")
            out[f"{SEVERITY_TARGET}{k}"] = v if v is not None and math.isfinite(v) else None
    return out, notes


def condition_line(result: dict) -> str | None:
    """The one line naming the condition and its probability (None without a condition
    model)."""
    if "condition" not in result:
        return None
    c = result["condition"]
    if c is None:
        return "  condition = not assessed (see the notes)"
    p = result.get(f"{PROBABILITY}{c}")
    sure = "" if result.get("condition_confident") else ", uncertain"
    line = f"  condition = {c}  (probability {p:.2f}{sure})"
    name = result.get("condition_line")
    if name is not None:
        label = {"ball_defect": "2 BSF"}.get(name, name.upper())
        found = result.get("condition_line_found_hz")
        snr = result.get("condition_line_snr")
        line += f"; {label} {result['condition_line_hz']:.1f} Hz"
        if found is not None:
            line += f", line found at {found:.1f} Hz"
        if snr is not None:
            line += f" ({snr:.1f} x its floor)"
    length = result.get(SEVERITY_TARGET)
    if length is not None:
        lo, hi = result[f"{SEVERITY_TARGET}_low"], result[f"{SEVERITY_TARGET}_high"]
        line += f"; spall length {length * 1e3:.2f} mm [{lo * 1e3:.2f}, {hi * 1e3:.2f}]"
    return line
