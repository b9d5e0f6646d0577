"""The bearing's condition from its resistance trace: healthy, outer, inner, ball or unbalance,
with calibrated probabilities, and the length of a spall with an interval.

:class:`ConditionEstimator` follows scikit-learn's contract like the load-state estimators of
:mod:`signatelec.estimation.models` (and passes ``parametrize_with_checks``): a
:class:`~signatelec.estimation.models.RegimeClassifier` over the conditions (gradient boosting,
probabilities temperature-scaled out of fold, runs kept whole: Guo et al. 2017), and an
:class:`~signatelec.estimation.models.IntervalRegressor` of log spall length fitted on the rows
with a spall (conformalised quantile regression: Romano, Patterson, Candes 2019). A spall's
signature grows with its length relative to the Hertz contact (a ball only loses its contact
over a spall longer than the contact, Sawalhi and Randall 2008), so the length is learnt on a
log scale.

The length interval's out-of-fold margin holds on runs like the training runs; the runs it is
asked about may differ (the default model learns from DEM runs of the "fast" preset and is
asked about the paper's fidelity: there the pooled margin covered 81 % of outer-race and 84 %
of ball spalls at a nominal 90 %, and 96 % of inner-race ones: README, "Spall length").
:meth:`ConditionEstimator.calibrate_lengths` sets one split-conformal margin per spall location
on held-out runs of the kind it will be asked about (Romano, Patterson, Candes 2019: any
held-out set exchangeable with the future runs calibrates the quantile models).

:class:`ConditionModel` is a fitted estimator with the features it reads
(:mod:`signatelec.estimation.condition_features`), what it was trained on, and the domain of its
training traces (:class:`~signatelec.estimation.domain.Domain`); a load-state model file carries
one (:class:`~signatelec.estimation.models.LoadStateModel`).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import (
    check_consistent_length,
    check_is_fitted,
    column_or_1d,
    validate_data,
)

from signatelec.config.constraints import CONDITIONS as CONDITION_NAMES
from signatelec.config.constraints import HEALTHY
from signatelec.estimation.domain import Domain
from signatelec.estimation.models import (
    DEFAULT_COVERAGE,
    IntervalRegressor,
    RegimeClassifier,
    _Boosting,
    conformal_margin,
)

#: The conditions, in report order (the dataset's labels).
CONDITIONS = CONDITION_NAMES
#: Conditions that are a spall, whose length is estimated.
SPALLS = ("outer", "inner", "ball")
CONDITION_TARGET = "condition"
SEVERITY_TARGET = "spall_length_m"
#: Prefix of the columns of the conditions' probabilities (``condition_probability_<name>``).
PROBABILITY = f"{CONDITION_TARGET}_probability_"
#: The condition labels of a dataset's traces (signatelec.data.design.condition_labels).
CONDITION_LABELS = (
    CONDITION_TARGET,
    SEVERITY_TARGET,
    "spall_depth_m",
    "spall_angle_rad",
    "unbalance_force_n",
)
#: Fewest spalled rows the length model is fitted on.
MIN_SPALL_ROWS = 10
#: Fewest calibration windows of a spall location, detected and typed right, that set its
#: own margin (below it the out-of-fold margin stays): with n windows the coverage of a
#: split-conformal interval is at most 1/(n + 1) above its nominal value (Romano et al. 2019).
MIN_CALIBRATION_ROWS = 20
#: Share of healthy training traces (out of fold) the condition may call anything but healthy:
#: the call is healthy unless the probability of healthy falls below the threshold that keeps
#: this false-alarm rate (a Neyman-Pearson detector on the calibrated probability), so that
#: spalls too small to leave a signature do not make healthy bearings look defective.
FALSE_ALARM = 0.005


def _condition_targets(y) -> tuple[np.ndarray, np.ndarray | None]:
    """(condition labels, spall lengths or None) of ``y``: a DataFrame with ``condition`` (and
    ``spall_length_m``), or the labels alone."""
    if y is None:
        raise ValueError("ConditionEstimator requires y to be passed, but the target y is None")
    if isinstance(y, pd.DataFrame):
        if CONDITION_TARGET not in y.columns:
            raise ValueError(f"y lacks the column {CONDITION_TARGET!r}")
        labels = y[CONDITION_TARGET].astype(str).to_numpy(dtype=object)
        length = None
        if SEVERITY_TARGET in y.columns:
            length = y[SEVERITY_TARGET].to_numpy(dtype=np.float64)
        return labels, length
    return column_or_1d(y, warn=True), None


@dataclass(eq=False, repr=False, kw_only=True)
class ConditionEstimator(ClassifierMixin, _Boosting, BaseEstimator):
    """The condition with calibrated probabilities, and the spall length with an interval.

    ``fit(X, y, groups)``: ``y`` a DataFrame with ``condition`` (any labels; those of
    :data:`CONDITIONS` in the shipped model) and optionally ``spall_length_m`` (read on the rows
    whose condition is in :data:`SPALLS`), or the labels alone; ``groups`` the simulation run
    of each row. ``predict`` gives the condition, ``predict_proba`` its probabilities (columns
    ``classes_``), ``predict_frame`` adds ``condition_probability_<class>`` and
    ``spall_length_m`` with ``_low`` and ``_high`` (interval of nominal ``coverage``; NaN on
    rows whose condition is not a spall). The condition called is healthy while its probability
    is at least ``healthy_threshold_`` (set on the out-of-fold probabilities of the healthy
    training rows for a false-alarm rate :data:`FALSE_ALARM`), else the likeliest other one.
    ``calibrate_lengths`` sets the length interval's margin per spall location on held-out
    windows (``length_calibration_``: location -> (windows, margin on log length)).
    """

    coverage: float = DEFAULT_COVERAGE

    def fit(self, X, y=None, groups=None):
        labels, length = _condition_targets(y)
        X, labels = validate_data(self, X, labels, dtype=np.float64)
        check_classification_targets(labels)
        if groups is not None:
            check_consistent_length(X, groups)
        params = self._boosting_params()
        self.classifier_ = RegimeClassifier(**params).fit(X, labels, groups=groups)
        self.classes_ = self.classifier_.classes_
        self.n_iter_ = self.classifier_.n_iter_
        self.healthy_threshold_ = _healthy_threshold(self.classifier_, labels)
        self.severity_ = None
        self.length_calibration_ = {}
        if length is not None:
            spall = np.isin(labels.astype(str), SPALLS) & np.isfinite(length) & (length > 0)
            if spall.sum() >= MIN_SPALL_ROWS:
                g = None if groups is None else np.asarray(groups)[spall]
                self.severity_ = IntervalRegressor(coverage=self.coverage, **params).fit(
                    X[spall], np.log(length[spall]), groups=g
                )
        return self

    def calibrate_lengths(self, X, condition, length_m) -> ConditionEstimator:
        """Set the spall-length interval's margin per spall location (split conformal) on
        held-out windows ``X`` of known ``condition`` and spall ``length_m``: on those the
        model calls right (a length is only given with a spall's call), the nonconformity of
        the log length to the quantile models' interval, its conformal quantile at
        ``coverage``. A location with fewer than :data:`MIN_CALIBRATION_ROWS` such windows
        keeps the out-of-fold margin."""
        check_is_fitted(self, "classifier_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        condition = np.asarray(condition).astype(str)
        length_m = np.asarray(length_m, dtype=np.float64)
        check_consistent_length(X, condition, length_m)
        if self.severity_ is None:
            return self
        called = self._call(self.classifier_._proba(X)).astype(str)
        q = self.severity_._quantiles(X)
        y = np.log(np.where(length_m > 0, length_m, np.nan))
        scores = np.maximum(q[:, 1] - y, y - q[:, 2])
        self.length_calibration_ = {}
        for c in SPALLS:
            rows = (condition == c) & (called == c) & np.isfinite(scores)
            if rows.sum() >= MIN_CALIBRATION_ROWS:
                margin = conformal_margin(scores[rows], self.coverage)
                self.length_calibration_[c] = (int(rows.sum()), margin)
        return self

    def predict_proba(self, X) -> np.ndarray:
        check_is_fitted(self, "classifier_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self.classifier_._proba(X)

    def _call(self, proba: np.ndarray) -> np.ndarray:
        """The condition called from calibrated probabilities: healthy while its probability
        is at least ``healthy_threshold_``, else the likeliest other condition."""
        best = np.argmax(proba, axis=1)
        if self.healthy_threshold_ is not None:
            h = int(np.flatnonzero(self.classes_.astype(str) == HEALTHY)[0])
            others = proba.copy()
            others[:, h] = -1.0
            healthy = proba[:, h] >= self.healthy_threshold_
            best = np.where(healthy, h, np.argmax(others, axis=1))
        return self.classes_[best]

    def predict(self, X) -> np.ndarray:
        return self._call(self.predict_proba(X))

    def _predict_columns(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """The columns of :meth:`predict_frame` for validated rows."""
        proba = self.classifier_._proba(X)
        best = self._call(proba)
        out: dict[str, np.ndarray] = {CONDITION_TARGET: best}
        for j, cls in enumerate(self.classes_):
            out[f"{PROBABILITY}{cls}"] = proba[:, j]
        nan = np.full(X.shape[0], np.nan)
        mid, lo, hi = nan, nan, nan
        if self.severity_ is not None:
            called = np.asarray(best).astype(str)
            margin = np.full(X.shape[0], self.severity_.margin_)
            for c, (_, m) in getattr(self, "length_calibration_", {}).items():
                margin[called == c] = m
            m, band = self.severity_._median_and_interval(X, margin)
            spall = np.isin(called, SPALLS)
            mid = np.where(spall, np.exp(m), np.nan)
            lo = np.where(spall, np.exp(band[:, 0]), np.nan)
            hi = np.where(spall, np.exp(band[:, 1]), np.nan)
        out[SEVERITY_TARGET] = mid
        out[f"{SEVERITY_TARGET}_low"] = lo
        out[f"{SEVERITY_TARGET}_high"] = hi
        return out

    def predict_frame(self, X) -> pd.DataFrame:
        """Condition, its probabilities and the spall length with its interval, per row."""
        check_is_fitted(self, "classifier_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return pd.DataFrame(self._predict_columns(X))


def _healthy_threshold(classifier: RegimeClassifier, labels: np.ndarray) -> float | None:
    """The probability of healthy below which :data:`FALSE_ALARM` of the healthy training rows
    fall, out of fold (None without healthy rows or out-of-fold predictions: plain argmax)."""
    classes = classifier.classes_.astype(str)
    oof = getattr(classifier, "oof_proba_", None)
    if HEALTHY not in classes or oof is None or classes.size < 2:
        return None
    h = int(np.flatnonzero(classes == HEALTHY)[0])
    rows = (np.asarray(labels).astype(str) == HEALTHY) & ~np.isnan(oof).any(axis=1)
    if rows.sum() < 10:
        return None
    return float(np.quantile(oof[rows, h], FALSE_ALARM))


def check_healthy_prior(value, name: str = "--healthy-prior") -> None:
    """ValueError (one line naming ``name``, the value and what is allowed) unless ``value``
    is a probability that the bearing is healthy, in (0, 1), or None (none given)."""
    if value is not None and not (_probability(value) and value < 1.0):
        raise ValueError(f"{name} {value!r}: must be a probability of healthy in (0, 1)")


def _probability(value) -> bool:
    """Whether ``value`` is a real number in (0, 1]."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and 0.0 < value <= 1.0


@dataclass
class ConditionModel:
    """A fitted :class:`ConditionEstimator` with the condition features it reads, in order,
    ``info`` on its training (source, rows, runs, classes, ranges) and the ``domain`` of its
    training traces (in-domain score of the condition features)."""

    estimator: ConditionEstimator
    features: list[str]
    info: dict
    domain: Domain

    def predict_one(self, features: dict[str, float]) -> dict:
        """Condition, probabilities and spall length for one trace's features (by name)."""
        x = np.array([[features[name] for name in self.features]], dtype=np.float64)
        if not np.all(np.isfinite(x)):
            bad = [n for n, v in zip(self.features, x[0], strict=True) if not np.isfinite(v)]
            raise ValueError(f"condition features not finite: {', '.join(bad)}")
        cols = self.estimator._predict_columns(x)
        return {k: (v[0].item() if hasattr(v[0], "item") else v[0]) for k, v in cols.items()}

    @property
    def training_mix(self) -> dict[str, float]:
        """Share of each condition among the training rows: the prior its probabilities carry
        (a classifier's probabilities are posteriors under the mix it learnt from)."""
        counts = self.info["classes"]
        total = float(sum(counts.values()))
        return {str(k): v / total for k, v in counts.items()}

    def move_to_prior(self, frame: pd.DataFrame, prior: float | dict[str, float]) -> pd.DataFrame:
        """``frame`` with its condition probabilities (columns ``condition_probability_<name>``:
        ``predict_frame``'s, a monitor's ``windows.parquet``) moved from :attr:`training_mix`
        to ``prior`` by Bayes' rule: p_k pi'_k / pi_k, renormalised (Saerens, Latinne and
        Decaestecker, Neural Computation 14 (2002) 21-41). ``prior``: each condition's share
        (they sum to 1), or the probability that the bearing is healthy, the faults sharing
        the rest in the training mix's proportions. The call (``condition``) is left as it is:
        its false-alarm rate is the training mix's. Rows without probabilities stay empty; a
        frame without their columns is returned as it is."""
        mix = self.training_mix
        target = self.prior_shares(prior)
        cols = [f"{PROBABILITY}{k}" for k in mix]
        missing = [c for c in cols if c not in frame.columns]
        if len(missing) == len(cols):  # no condition assessed
            return frame
        if missing:
            raise ValueError(f"frame lacks the probability columns {missing}")
        p = frame[cols].to_numpy(np.float64) * np.array([target[k] / mix[k] for k in mix])
        out = frame.copy()
        out[cols] = p / p.sum(axis=1, keepdims=True)
        return out

    def move_records(self, records: list[dict], prior: float | dict[str, float]) -> list[dict]:
        """Move, in place, the condition probabilities of those ``records`` (dicts: an
        estimate's result, a monitor's stretches) that hold a number for every condition, as
        :meth:`move_to_prior` moves a table's rows; returns those records."""
        cols = [f"{PROBABILITY}{k}" for k in self.training_mix]
        rows = [r for r in records if all(isinstance(r.get(c), int | float) for c in cols)]
        if rows:
            frame = pd.DataFrame([{c: r[c] for c in cols} for r in rows])
            for r, p in zip(rows, self.move_to_prior(frame, prior).to_dict("records"), strict=True):
                r.update({c: float(v) for c, v in p.items()})
        return rows

    def prior_note(self, prior: float | dict[str, float]) -> str:
        """The note of an answer whose condition probabilities were moved to ``prior``."""
        shown = f"P(healthy) = {prior:g}" if not isinstance(prior, dict) else f"the prior {prior}"
        mix = self.training_mix.get(HEALTHY)
        trained = f" (the condition model's training mix: {mix:.3g})" if mix is not None else ""
        return (
            f"condition probabilities under {shown} before the trace{trained}; the calls and "
            "their warnings were made under the training mix"
        )

    def prior_shares(self, prior: float | dict[str, float]) -> dict[str, float]:
        """Each condition's share under ``prior`` (:meth:`move_to_prior`'s), or ValueError (one
        line naming the value and what is allowed)."""
        mix = self.training_mix
        if set(mix) != set(self.estimator.classes_.astype(str)):
            raise ValueError(
                f"the model's training mix names {sorted(mix)}, its classifier "
                f"{sorted(self.estimator.classes_.astype(str))}: retrain it"
            )
        if isinstance(prior, dict):
            target = {str(k): v for k, v in prior.items()}
            if set(target) != set(mix):
                raise ValueError(f"prior {sorted(target)}: must name exactly {sorted(mix)}")
        elif HEALTHY not in mix or len(mix) < 2:
            raise ValueError(
                f"prior {prior!r}: a probability of healthy needs a model of healthy and faulty "
                f"bearings (this one learnt {sorted(mix)}); give each condition's share"
            )
        else:
            check_healthy_prior(prior, "prior")
            faults = sum(v for k, v in mix.items() if k != HEALTHY)
            target = {
                k: prior if k == HEALTHY else (1 - prior) * v / faults for k, v in mix.items()
            }
        shares = list(target.values())
        if not all(_probability(v) for v in shares) or abs(sum(shares) - 1.0) > 1e-6:
            raise ValueError(
                f"prior {prior!r}: must give each condition a share in (0, 1], summing to 1"
            )
        return target
