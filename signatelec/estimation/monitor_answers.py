"""What the monitor (:mod:`signatelec.estimation.monitor`) asks about a block: its ripple and
level screen (the first block's first :data:`SCREEN_S`, then one block's every
``SCREEN_EVERY_S``, screened as ``estimate`` screens a trace:
:func:`~signatelec.measurement.sanity.check_level`,
:func:`~signatelec.measurement.ripple.find_ripple`), and the load-state model's estimates of a
batch of its windows."""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np

from signatelec.estimation.domain import outside_speeds, refuse_score
from signatelec.estimation.estimate import CONFIDENT_PROBABILITY
from signatelec.estimation.features import analysis_options, trace_feature_names
from signatelec.estimation.health import defect_explains
from signatelec.estimation.models import DEFAULT_COVERAGE, LoadStateModel
from signatelec.estimation.monitor_settings import TRACK_JUMP
from signatelec.measurement.band import N_HARMONICS
from signatelec.measurement.ripple import find_ripple
from signatelec.measurement.sanity import check_level
from signatelec.measurement.traces import TraceError

#: Length of each block's ripple and level screening (the ripple search costs ~T^2).
SCREEN_S = 0.5
#: Features kept per window beside the estimate (the change detector reads some), before the
#: model's own (:func:`kept_features`).
KEPT_FEATURES = (
    "level_mean_ohm",
    "noise_rms_rel",
    "h1_rel",
    "h2_rel",
    "h2_even_rel",
    "ball_pass_found_hz",
    "harmonic_snr",
)


def screen_block(
    trace,
    omegas,
    model: LoadStateModel,
    first: bool,
    speed=None,
    window_s=None,
    bearing=None,
    track: bool = False,
):
    """(ripple status, note, speed moved to or None) of a block's first :data:`SCREEN_S`, or
    TraceError naming ``speed``
    (what the user gave for the speed: :func:`~signatelec.estimation.monitor_settings.
    speed_given`). ``omegas``: the speeds of the block's first and last :data:`SCREEN_S`
    (:func:`~signatelec.estimation.monitor_settings.screen_speeds`; a first one NaN: the block
    starts at rest, and its last is screened instead). A later block whose first
    :data:`SCREEN_S` shows the line elsewhere has its last :data:`SCREEN_S` screened too, and is
    refused
    only when both do: a change of state within the screened trace joins two ripples whose
    phases do not continue, which can move the periodogram's peak out of the tolerance (a
    calibration record's zero-to-preload step 0.24 s into a screen put it at +0.56 %). A line
    elsewhere that lies on a defect's line is kept (status ``defect``) when the condition is
    assessed (``window_s``: the windows' length, None when it is not) and the condition model
    confidently calls that very condition on the block's first window, as ``estimate`` keeps a
    trace (:func:`~signatelec.estimation.health.defect_explains`). ``bearing``: its geometry,
    which places the ball-pass and the defects' lines (default: the seed's). ``track``: the
    speed is tracked from the line, and a line elsewhere within
    :data:`~signatelec.estimation.monitor_settings.TRACK_JUMP` of the speed that is not a
    defect's (as above) is the speed moved: found, at the speed it implies."""
    omega, omega_last = omegas
    n = min(trace.resistance_ohm.size, int(SCREEN_S * trace.sample_rate_hz))
    if math.isnan(omega):  # the block starts at rest (a speed column's): its end is screened,
        # and a defect's line judged on its end's window
        m = max(n, int(round((window_s or 0.0) * trace.sample_rate_hz)))
        ends = slice(max(0, trace.resistance_ohm.size - m), None)
        trace = replace(trace, time_s=trace.time_s[ends], resistance_ohm=trace.resistance_ohm[ends])
        omega = omega_last
    r = trace.resistance_ohm[:n]
    note = None
    if model.domain is not None:
        note = check_level(float(np.mean(r)), model.domain.level_range_ohm, trace.source)
    ripple = find_ripple(r, trace.sample_rate_hz, omega, bearing=bearing, units=first)
    if ripple.status == "elsewhere" and not first and trace.resistance_ohm.size >= 2 * n:
        end = trace.resistance_ohm[-n:]
        again = find_ripple(end, trace.sample_rate_hz, omega_last, bearing=bearing, units=False)
        if again.status not in ("elsewhere", "constant"):
            ripple = again
    if (
        ripple.status == "elsewhere"
        and window_s is not None
        and defect_explains(
            trace,
            omega,
            getattr(model, "condition", None),
            ripple,
            window_s,
            n,
            bearing,
            getattr(model, "bearing", None),
        )  # fmt: skip
    ):
        return "defect", note if first else None, None
    moved = ripple.implied_omega_rad_s  # (a tracked speed follows a line that is no defect's)
    if track and ripple.status == "elsewhere" and abs(moved / omega - 1.0) <= TRACK_JUMP:
        return "found", note if first else None, moved
    if ripple.status in ("elsewhere", "constant"):
        raise TraceError(f"{trace.source}: {ripple.problem(speed)}")
    return ripple.status, note if first else None, None


@functools.cache
def feature_columns(n_harmonics: int = N_HARMONICS) -> dict[str, int]:
    """Column of each feature in :func:`~signatelec.estimation.features.window_features`."""
    return {name: i for i, name in enumerate(trace_feature_names(n_harmonics))}


def kept_features(model: LoadStateModel) -> tuple[str, ...]:
    """The features a window's row keeps: :data:`KEPT_FEATURES`, then the model's own (a
    stretch's mean features are what its stretch model reads) and its ``faulty`` model's (which
    answers a stretch called faulty)."""
    faulty = getattr(model, "faulty", None)
    extra = faulty.features if faulty is not None else ()
    return tuple(dict.fromkeys([*KEPT_FEATURES, *model.features, *extra]))


def analysed(model: LoadStateModel) -> dict:
    """The options of :func:`~signatelec.estimation.analysis.analyse_windows` for what the
    monitor reads of a window: :func:`kept_features`, the stretch model's and the condition
    model's features (what none of them reads is not computed)."""
    models = (getattr(model, "stretch", None), getattr(model, "condition", None))
    names = [*kept_features(model), *(n for m in models if m is not None for n in m.features)]
    return analysis_options(names)


def estimate_batch(rows: list[dict], feats: list[np.ndarray], model: LoadStateModel) -> None:
    """The model's estimates of a batch of windows (their rows of the feature table), asked
    once, written into ``rows``."""
    if not feats:
        return
    table = np.stack(feats)
    column = feature_columns()
    # one thread: the compiled walk of the trees (scikit-learn's threaded one was ~10x slower
    # on busy cores)
    pred = model.predict_columns(table[:, [column[name] for name in model.features]])
    scores = np.ones(len(table))
    if model.domain is not None:
        scores = model.domain.scores(table[:, [column[name] for name in model.domain.features]])
    coverage = model.info.get("coverage", DEFAULT_COVERAGE)
    # a speed outside the training range is an extrapolation: no regime call is confident there
    ranges = model.info.get("ranges")
    probs = [c for c in pred if c.startswith("regime_probability_")]
    names, values = list(pred), [v.tolist() for v in pred.values()]
    for i, row in enumerate(rows):
        out = {name: v[i] for name, v in zip(names, values, strict=True)}
        out["in_domain_score"] = float(scores[i])
        out["interval_coverage"] = coverage
        if probs:
            top = max(out[c] for c in probs)
            line = row["ripple"] not in ("none", "unconfirmed")
            seen = outside_speeds(ranges, row.get("omega_rad_s", math.nan)) is None
            out["regime_confident"] = bool(top >= CONFIDENT_PROBABILITY) and line and seen
        limit = refuse_score(row["ripple"] != "none")
        if scores[i] < limit:
            row["status"] = f"out of domain (in-domain score {scores[i]:.2g} < {limit:g})"
        row.update(out)
