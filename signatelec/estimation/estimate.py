"""The load state of one measured trace: F_r, epsilon and clearance with intervals, the regime;
and the bearing's condition beside it (:mod:`signatelec.estimation.diagnose`) when the model
carries a condition model.

:func:`estimate` screens the trace (:func:`signatelec.measurement.sanity.screen_trace`: set-up
transient cut off, level in the model's trained range, ball-pass ripple found at the frequency
the speed predicts), computes its features (:mod:`signatelec.estimation.features`), scores them
against the model's training traces (:class:`~signatelec.estimation.domain.Domain`), asks a
:class:`~signatelec.estimation.models.LoadStateModel` (a model file, or the default model of
:mod:`signatelec.estimation.persistence`) and says where the answer is weak: a regime call below
:data:`CONFIDENT_PROBABILITY` is flagged uncertain with its rivals named (there the signature lies
within the noise of another regime's: docs/load_state, "Where the targets are out of reach"),
an omega outside the training range is extrapolation, an in-domain score below
:data:`~signatelec.estimation.domain.WARN_SCORE` a warning.

Refused, with one line: what the sanity layer refuses (:class:`~signatelec.measurement.traces.
TraceError`); an in-domain score below
:data:`~signatelec.estimation.domain.REFUSE_SCORE`, and a trace without a ball-pass line whose
features are unlike the training traces' too (score below
:data:`~signatelec.estimation.domain.NO_LINE_REFUSE_SCORE`)
(:class:`~signatelec.estimation.domain.DomainError`), unless the condition model calls a defect
or an unbalance confidently: its signature may take the trace out of the load-state domain, so
the condition is answered and the load state left out, with a note. A trace the condition
model calls faulty (a spall or an unbalance) is scored and answered by the model's ``faulty``
load-state model, which learnt defective runs too: the load state holds with a defect present
(docs/diagnosis, "Load state with a defect present"). A trace without a line but like the
training traces is answered with a warning and no confident regime: where the load zone's edge
sits on a zero of the ripple's first harmonic (epsilon about 0.35-0.43 or 0.525-0.55) a running
bearing shows no line within 0.2 % noise over 50 ms, and the model has learnt those states; the
speed cannot be checked on such a trace (held-out runs without a line, 50 ms at 0.2 % noise:
F_r MAPE 0.7 %, epsilon MAE 0.043, regime 70 % right; with --omega 20 % off 0.9 %, 0.064 and
58 %).
:mod:`signatelec.estimation.report` renders the result.
"""

from __future__ import annotations

import math
from dataclasses import replace

from signatelec.config.bearing import Bearing
from signatelec.config.constraints import HEALTHY
from signatelec.estimation.analysis import analyse_trace
from signatelec.estimation.diagnose import assess_condition
from signatelec.estimation.domain import (
    NO_LINE_REFUSE_SCORE,
    REFUSE_SCORE,
    WARN_SCORE,
    DomainError,
    outside_speeds,
)
from signatelec.estimation.features import trace_features
from signatelec.estimation.models import DEFAULT_COVERAGE, LoadStateModel
from signatelec.measurement.sanity import ANY_FAULT, explains, screen_trace
from signatelec.measurement.traces import TraceError
from signatelec.physics.regimes import REGIMES

#: A regime call at or above this probability is reported as confident. Measured on held-out
#: runs at 0.2 % noise, 50 ms (docs/load_state): 95-97 % of such calls are right, against 79 %
#: of all calls; below it the note names the regimes the signature cannot tell apart.
CONFIDENT_PROBABILITY = 0.8


def estimate(
    trace, omega_rad_s: float, model: LoadStateModel, bearing: Bearing | None = None
) -> dict:
    """Estimate the load state of a prepared :class:`signatelec.measurement.traces.Trace`.

    Returns a flat dict: ``radial_load_n``, ``epsilon``, ``clearance_m`` with ``*_low`` and
    ``*_high`` (interval of nominal ``interval_coverage``), ``regime``,
    ``regime_probability_<regime>`` and ``regime_confident`` (top probability at least
    :data:`CONFIDENT_PROBABILITY`, a ball-pass line found, and a speed within the model's
    training range), ``in_domain_score``, and notes
    on the trace, the ripple and the model's range; with a condition model, ``condition``,
    ``condition_probability_<name>``, ``condition_confident``, ``spall_length_m`` with
    ``_low`` and ``_high`` and ``condition_in_domain_score``
    (:func:`~signatelec.estimation.diagnose.assess_condition`). Raises TraceError or
    DomainError (one line) when the trace cannot carry an answer (module docstring).

    ``bearing``: the bearing's geometry (default: the one the model learnt, ``model.bearing``,
    the seed's for the default model), which places the ball-pass and the characteristic
    lines. The trace's features are read at the ball-pass line of the bearing the model
    learnt (:meth:`~signatelec.estimation.models.LoadStateModel.knows`): for another bearing
    the condition is answered and the load state left out, with a note.
    """
    learnt = model.bearing  # (None: the seed's)
    bearing = learnt if bearing is None else bearing
    domain = model.domain
    screened = screen_trace(
        trace,
        omega_rad_s,
        domain.level_range_ohm,
        defect_lines=model.condition is not None,
        bearing=bearing,
    )
    trace, ripple = screened.trace, screened.ripple
    notes = list(screened.notes)
    r, fs = trace.resistance_ohm, trace.sample_rate_hz
    mine = None if learnt is None else analyse_trace(r, fs, omega_rad_s, bearing=learnt)
    feats = trace_features(r, fs, omega_rad_s, analysis=mine)
    condition: dict = {}
    if model.condition is not None:
        condition, condition_notes = assess_condition(
            trace.resistance_ohm,
            trace.sample_rate_hz,
            omega_rad_s,
            feats,
            model.condition,
            bearing=bearing,
        )
        notes += condition_notes
    if not model.knows(bearing):
        known = "the seed's bearing" if learnt is None else f"the {learnt.name}"
        if not condition:
            raise DomainError(
                f"{trace.source}: the model knows {known} only, and no condition "
                f"model is there to assess this {bearing.name}"
            )
        notes.append(
            f"load state not estimated: the load-state model learnt {known} only, "
            f"not the {bearing.name}"
        )
        # the trace's ball-pass figures of its own geometry (the features read the model's)
        feats = feats | {
            "ball_pass_expected_hz": ripple.expected_hz,
            "ball_pass_found_hz": ripple.frequency_hz,
            "duration_ball_passes": trace.duration_s * ripple.expected_hz,
        }
        return _result(condition, notes, trace, feats, ripple, model)
    if screened.defect_line is not None:
        # the strongest line is a defect's, not the ball-pass ripple: only a confident call of
        # that very condition explains it (of any fault, for a line at no defect's frequency
        # beside the ripple found); otherwise it is a wrong --omega, as the layer says
        kind, name = screened.defect_line
        if not (_confident_fault(condition) and explains(kind, condition["condition"])):
            raise TraceError(f"{trace.source}: {ripple.problem()}")
        if kind == ANY_FAULT:
            notes.append(
                f"the strongest line ({ripple.frequency_hz:.1f} Hz, {name}): read past, as "
                f"the confident {condition['condition']} call explains it (a spall's impacts "
                "put such lines in the trace)"
            )
            ripple = replace(ripple.near, beside=replace(ripple, near=None))
        else:
            notes.append(
                f"the strongest line ({ripple.frequency_hz:.1f} Hz) is the {name} line of the "
                f"{kind} condition, not the ball-pass ripple"
            )
    # a trace the condition model calls faulty is answered by the load-state model that
    # learnt defective runs too (docs/diagnosis: F_r with a defect present)
    faulty = condition.get("condition") not in (None, HEALTHY)
    load = model.faulty if faulty and model.faulty is not None else model
    domain = load.domain
    score = domain.score(feats)
    where = trace.source
    problem = None
    if ripple.status == "none" and score < NO_LINE_REFUSE_SCORE:
        problem = (
            f"{where}: {ripple.problem()} (no line, and the trace is unlike the training "
            f"traces: in-domain score {score:.2g})"
        )
    elif score < REFUSE_SCORE:
        problem = (
            f"{where}: unlike every training trace (in-domain score {score:.2g} < "
            f"{REFUSE_SCORE:g}; farthest: {', '.join(domain.farthest(feats))})"
        )
    if problem is not None:
        if not _confident_fault(condition):
            raise DomainError(problem)
        # a confident defect whose signature takes the trace out of the load-state domain:
        # the condition is the answer, the load state is not given
        notes.append(f"load state not estimated: {problem.split(': ', 1)[-1]}")
        return _result(condition, notes, trace, feats, ripple, model)
    out = load.predict_one(feats) | condition
    out["interval_coverage"] = load.info.get("coverage", DEFAULT_COVERAGE)
    out["in_domain_score"] = score
    if score < WARN_SCORE:
        notes.append(
            f"warning: in-domain score {score:.2g} (below {WARN_SCORE:g}: fewer than "
            f"{WARN_SCORE:.0%} of the training traces are this atypical; farthest: "
            f"{', '.join(domain.farthest(feats))}): the answer is an extrapolation, so no "
            "regime call is confident"
        )
    if ripple.status == "none":
        notes.append(
            f"warning: {ripple.problem()} (false-alarm probability {ripple.false_alarm:.2g} "
            "at best): the speed cannot be checked on this trace, so no regime call is "
            "confident; a running bearing shows no line where the load zone's edge sits on a "
            "zero of the ripple (epsilon about 0.35-0.43 or 0.525-0.55), which the model has "
            "learnt"
        )
    probs = {r: out[f"regime_probability_{r}"] for r in REGIMES if f"regime_probability_{r}" in out}
    if probs:
        sure = bool(max(probs.values()) >= CONFIDENT_PROBABILITY)
        # without a line the speed is unchecked: a wrong --omega costs a fifth of the regime
        # calls there (held-out runs at +-20 %: 58 % right against 70 %)
        # (as atypical as the 1 % most atypical training traces: an extrapolation, where a
        # user's 6208 model called a preloaded trace clearance at 0.92, score 6e-5)
        out["regime_confident"] = sure and ripple.status != "none" and score >= WARN_SCORE
        if not sure:
            likely = [r for r, q in sorted(probs.items(), key=lambda kv: -kv[1]) if q >= 0.1]
            notes.append(
                f"regime uncertain: {' or '.join(likely)} (no probability reaches "
                f"{CONFIDENT_PROBABILITY:.0%}); these load states give resistance signatures "
                "alike within this trace's noise, so a longer or quieter trace is needed to tell"
            )
    return _result(out, notes, trace, feats, ripple, model, omega_rad_s, load)


def _confident_fault(condition: dict) -> bool:
    """A confident condition other than healthy."""
    c = condition.get("condition")
    return c not in (None, HEALTHY) and bool(condition.get("condition_confident"))


def _result(out, notes, trace, feats, ripple, model, omega_rad_s=None, answered=None) -> dict:
    """The estimate with its notes, the trace's figures and the model's summary; ``omega_rad_s``
    checked against the training range of the load-state model that ``answered``."""
    if (speeds := outside_speeds((answered or model).info.get("ranges"), omega_rad_s)) is not None:
        lo, hi = speeds
        notes.append(
            f"omega {omega_rad_s:g} rad/s is outside the training range {lo:g}-{hi:g} rad/s: "
            "extrapolating, so no regime call is confident"
        )
        if "regime_confident" in out:  # (a 2000 rad/s trace was called preload at 0.999)
            out["regime_confident"] = False
    out["notes"] = notes
    out["trace"] = {
        "source": trace.source,
        "sample_rate_hz": trace.sample_rate_hz,
        "duration_s": trace.duration_s,
        "n_samples": int(trace.resistance_ohm.size),
        "ball_passes": feats["duration_ball_passes"],
        "ball_pass_expected_hz": feats["ball_pass_expected_hz"],
        "ball_pass_found_hz": feats["ball_pass_found_hz"],
        "ripple": ripple.status,
        "ripple_hz": ripple.frequency_hz if math.isfinite(ripple.frequency_hz) else None,
        "ripple_false_alarm": ripple.false_alarm,
        "level_ohm": feats["level_mean_ohm"],
        "noise_rms_rel": feats["noise_rms_rel"],
        "repairs": list(trace.repairs),
    }
    # (``bearing``: the one it learnt, None for the seed's)
    keys = ("trained_on", "n_runs", "n_rows", "signatelec", "bearing")
    out["model"] = {k: model.info.get(k) for k in keys}
    return out


def under_prior(result: dict, condition_model, prior) -> dict:
    """``result`` (of :func:`estimate`) with its condition probabilities moved to ``prior`` (a
    probability of healthy or each condition's share: :meth:`~signatelec.estimation.condition.
    ConditionModel.move_to_prior`) and a note saying so; the call, ``condition_confident`` and
    the notes made from them stay the training mix's (the call's false-alarm rate is measured
    there). A result whose condition was not assessed is returned as it is."""
    out = dict(result)
    if not condition_model.move_records([out], prior):
        return result
    out["notes"] = [*result.get("notes", []), condition_model.prior_note(prior)]
    return out
