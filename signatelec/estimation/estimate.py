"""The load state of one measured trace: F_r, epsilon and clearance with intervals, the regime.

:func:`estimate` computes the trace's features (:mod:`signatelec.estimation.features`), asks a
:class:`~signatelec.estimation.models.LoadStateModel` (a model file, or the default model of
:mod:`signatelec.estimation.persistence`) and says where the answer is weak: a regime call below
:data:`CONFIDENT_PROBABILITY` is flagged uncertain with its rivals named (there the signature lies
within the noise of another regime's: docs/load_state, "Where the targets are out of reach"),
and an omega outside the training range is extrapolation. :mod:`signatelec.estimation.report`
renders the result.
"""

from __future__ import annotations

from signatelec.estimation.features import trace_features
from signatelec.estimation.models import DEFAULT_COVERAGE, LoadStateModel
from signatelec.physics.regimes import REGIMES

#: A regime call at or above this probability is reported as confident. Measured on held-out
#: runs at 0.2 % noise, 50 ms (docs/load_state): 95-97 % of such calls are right, against 79 %
#: of all calls; below it the note names the regimes the signature cannot tell apart.
CONFIDENT_PROBABILITY = 0.8


def estimate(trace, omega_rad_s: float, model: LoadStateModel) -> dict:
    """Estimate the load state of a prepared :class:`signatelec.measurement.traces.Trace`.

    Returns a flat dict: ``radial_load_n``, ``epsilon``, ``clearance_m`` with ``*_low`` and
    ``*_high`` (interval of nominal ``interval_coverage``), ``regime``,
    ``regime_probability_<regime>`` and ``regime_confident`` (top probability at least
    :data:`CONFIDENT_PROBABILITY`), and notes on the trace and the model's range.
    """
    feats = trace_features(trace.resistance_ohm, trace.sample_rate_hz, omega_rad_s)
    out = model.predict_one(feats)
    out["interval_coverage"] = model.info.get("coverage", DEFAULT_COVERAGE)
    notes = []
    probs = {r: out[f"regime_probability_{r}"] for r in REGIMES if f"regime_probability_{r}" in out}
    if probs:
        out["regime_confident"] = bool(max(probs.values()) >= CONFIDENT_PROBABILITY)
        if not out["regime_confident"]:
            likely = [r for r, q in sorted(probs.items(), key=lambda kv: -kv[1]) if q >= 0.1]
            notes.append(
                f"regime uncertain: {' or '.join(likely)} (no probability reaches "
                f"{CONFIDENT_PROBABILITY:.0%}); these load states give resistance signatures "
                "alike within this trace's noise, so a longer or quieter trace is needed to tell"
            )
    ranges = model.info.get("ranges", {})
    lo, hi = ranges.get("omega_rad_s", (None, None))
    if lo is not None and not lo <= omega_rad_s <= hi:
        notes.append(
            f"omega {omega_rad_s:g} rad/s is outside the training range {lo:.0f}-{hi:.0f} rad/s: "
            "extrapolating"
        )
    out["notes"] = notes
    out["trace"] = {
        "source": trace.source,
        "sample_rate_hz": trace.sample_rate_hz,
        "duration_s": trace.duration_s,
        "n_samples": int(trace.resistance_ohm.size),
        "ball_passes": feats["duration_ball_passes"],
        "ball_pass_expected_hz": feats["ball_pass_expected_hz"],
        "ball_pass_found_hz": feats["ball_pass_found_hz"],
        "level_ohm": feats["level_mean_ohm"],
        "noise_rms_rel": feats["noise_rms_rel"],
        "repairs": list(trace.repairs),
    }
    out["model"] = {k: model.info.get(k) for k in ("trained_on", "n_runs", "n_rows", "signatelec")}
    return out
