"""A stretch's load state from its windows' mean features: the model's ``stretch`` model.

The window model reads one window at a time, and a stretch's windows of one state share its
error: at the fold of R(epsilon) near 0.35, at the vanishing first harmonic near 0.55 and near
the +-1 um regime boundaries it called states of the monitoring study wrong in every window,
with confidence (docs/monitor/model_error.md). Averaged over a stretch, the features keep the
ripple's shape and lose most of the noise (a 2 s stretch of 0.2 s windows at 0.2 % noise is
~0.06 % equivalent noise), and those states then differ from their twins of the other regime
by 5-23 noise standard deviations (docs/monitor/twins.md). A model that learnt from stretches'
mean features (:data:`~signatelec.estimation.training.STRETCH_TABLE`: 3-40 windows of
50-200 ms, noise 0.05-1 %, drawn from paper-fidelity runs) reads them there.

:func:`stretch_estimate` asks it about a stretch; :func:`~signatelec.estimation.evidence.
combine_stretch` then takes its F_r, epsilon, clearance and regime probabilities, its own
interval's sd as the model part of each interval. That interval is the median -+ a multiple of
s(x), a model of the error of a median that never saw the stretch's run (``interval =
"residual"`` of :class:`~signatelec.estimation.models.IntervalRegressor`): the stretch model's
error is a state's, shared by the stretches of the state, and the quantile models fitted on
every run see only the noise about it. On the monitoring study's calibration records
(cross-validated by state) the quantile interval covered 75 and 74 % of the epsilon and
clearance of stretches of states at epsilon 0.33-0.37 and 82-84 % at 0.55-0.61, over-covering
elsewhere; this one covers 78-100 % in every band of epsilon for every target, with an epsilon
interval half as wide (docs/monitor/model_error.md).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from signatelec.estimation.domain import REFUSE_SCORE


def stretch_estimate(windows: pd.DataFrame, stretch_model) -> dict | None:
    """The ``stretch_model``'s estimate (:meth:`~signatelec.estimation.models.LoadStateModel.
    predict_one`) of the windows' mean features, with their ``in_domain_score`` among the
    training stretches when the model has a domain, or None: no stretch model or no window, a
    feature not kept or not finite, or mean features unlike every training stretch (in-domain
    score below :data:`~signatelec.estimation.domain.REFUSE_SCORE`, as ``estimate`` refuses a
    trace). It learnt healthy bearings, as the window model did: a stretch whose condition is
    confidently another is answered all the same, and the monitor's summary warns that its load
    state is an extrapolation (:func:`~signatelec.estimation.monitor_report.qualify`). It
    learnt stretches of 3-40 windows; a segment between two changes holds at least 3, and
    leaving out the windows that straddle a change can leave one or two: the model answers them
    too, so that the two stretches of a change are read by one model (the windows' summed
    evidence is far surer of itself, and a regime alarm could come from the change of
    estimator)."""
    if stretch_model is None or windows.empty:
        return None
    if any(name not in windows for name in stretch_model.features):
        return None
    mean = windows[stretch_model.features].to_numpy(float).mean(axis=0)
    if not np.all(np.isfinite(mean)):
        return None
    features = dict(zip(stretch_model.features, mean, strict=True))
    domain = getattr(stretch_model, "domain", None)
    if domain is None:
        return stretch_model.predict_one(features)
    score = float(domain.score(features))
    if score < REFUSE_SCORE:
        return None  # unlike every training stretch: the windows' estimates answer
    return {**stretch_model.predict_one(features), "in_domain_score": score}
