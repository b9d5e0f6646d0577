"""Estimators of the load state from trace features: F_r, epsilon, clearance, regime.

Each follows scikit-learn's contract (``__init__`` stores the parameters, what ``fit`` learns ends
in ``_``, ``fit`` returns the estimator) and passes ``parametrize_with_checks``:

- :class:`IntervalRegressor`: the median of a gradient-boosted quantile model and a prediction
  interval of nominal coverage ``coverage`` (default 90 %): quantile models at
  (1 -+ coverage) / 2, widened or narrowed by the conformal margin measured on out-of-fold
  predictions grouped by simulation run (conformalised quantile regression; Romano, Patterson,
  Candes 2019). Where two load states give the same signature within the noise the quantile
  models see both in the training data and the interval spans both. With ``interval =
  "residual"`` the interval is instead the median -+ q s(x), s a model of the median's own
  out-of-fold error (locally weighted split conformal; Papadopoulos, Gammerman, Vovk 2008;
  Lei et al. 2018, sec. 5.2): it widens where a model that never saw a state errs there;
- :class:`RegimeClassifier`: class probabilities of a gradient-boosted classifier,
  temperature-scaled on out-of-fold predictions so that they are calibrated (Guo et al. 2017);
- :class:`LoadStateEstimator`: both together over a table of labels. The load goes through the
  physics first: R ~ F_r^(-4/3) (Hertz, seed section 3), so the model learns
  log F_r + 0.75 log R (a slow function of epsilon) and not the power law itself.

:class:`LoadStateModel` is a fitted estimator with the features it reads and what it was
trained on: what model files hold (:mod:`signatelec.estimation.persistence`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, ClassifierMixin, RegressorMixin
from sklearn.ensemble import HistGradientBoostingClassifier, HistGradientBoostingRegressor
from sklearn.model_selection import GroupKFold, KFold, StratifiedGroupKFold, StratifiedKFold
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_consistent_length, check_is_fitted, validate_data

from signatelec.config.bearing import Bearing, same_bearing
from signatelec.estimation.domain import Domain
from signatelec.estimation.forest import FlatForest

TARGETS = ("radial_load_n", "epsilon", "clearance_m")
CLASS_TARGET = "regime"
DEFAULT_COVERAGE = 0.9
#: How :class:`IntervalRegressor` draws its interval (its docstring).
INTERVALS = ("quantile", "residual")
#: Exponent of log R that the load target is corrected by (R ~ F_r^(-4/3): 3/4).
HERTZ_EXPONENT = 0.75
LEVEL_FEATURE = "level_mean_ohm"


# --- shared parameters and out-of-fold predictions --------------------------------------------


@dataclass(eq=False, repr=False, kw_only=True)
class _Boosting:
    """The hyper-parameters every estimator here shares: those of its gradient-boosted models
    (scikit-learn's HistGradientBoosting*, without early stopping) and the number of
    out-of-fold splits its calibration uses. A dataclass, so that each estimator's ``__init__``
    stores exactly its parameters, as scikit-learn requires."""

    max_iter: int = 150
    learning_rate: float = 0.1
    max_leaf_nodes: int = 31
    min_samples_leaf: int = 20
    l2_regularization: float = 1.0
    n_splits: int = 3
    random_state: int | None = 0

    def _boosting_params(self) -> dict:
        """The shared parameters, to hand to another estimator of this module."""
        return {f.name: getattr(self, f.name) for f in fields(_Boosting)}

    def _hgb_params(self) -> dict:
        """Parameters of the HistGradientBoosting models."""
        params = self._boosting_params()
        del params["n_splits"]
        return {**params, "early_stopping": False}


def _splits(n_samples: int, groups, n_splits: int, classes=None):
    """Out-of-fold splits, grouped when groups are given and stratified by ``classes`` (for a
    classifier); [] when there are too few samples."""
    z = np.zeros(n_samples)
    if groups is not None:
        groups = np.asarray(groups)
        k = min(n_splits, len(np.unique(groups)))
        if k < 2:
            return []
        if classes is not None:
            return list(StratifiedGroupKFold(k).split(z, classes, groups=groups))
        return list(GroupKFold(k).split(z, groups=groups))
    if classes is not None:
        k = min(n_splits, int(np.bincount(classes).min()))
        return list(StratifiedKFold(k).split(z, classes)) if k >= 2 else []
    k = min(n_splits, n_samples // 2)
    return list(KFold(k).split(z)) if k >= 2 else []


def out_of_fold(
    X: np.ndarray,
    y: np.ndarray,
    fit_predict: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray | None],
    n_columns: int,
    groups=None,
    n_splits: int = 3,
    classes: np.ndarray | None = None,
) -> np.ndarray:
    """Predictions of every row by a model fitted without its fold, shape (n, ``n_columns``).

    ``fit_predict(X_train, y_train, X_test)`` fits on one side and predicts the other (None:
    this fold cannot be fitted). Folds keep a group (a simulation run) whole and are stratified
    by ``classes`` when given; rows no fold predicted hold NaN. Calibration on these
    predictions (a conformal margin, a temperature) reflects runs the model never saw.
    """
    out = np.full((X.shape[0], n_columns), np.nan)
    for train, test in _splits(X.shape[0], groups, n_splits, classes=classes):
        pred = fit_predict(X[train], y[train], X[test])
        if pred is not None:
            out[test] = np.asarray(pred).reshape(len(test), n_columns)
    return out


def conformal_margin(scores: np.ndarray, coverage: float) -> float:
    """The split-conformal margin of nonconformity ``scores`` (how far each calibration sample
    lies outside its interval, negative inside): the ceil((n + 1) ``coverage``)-th smallest,
    so that a new exchangeable sample falls within the interval widened by it with probability
    at least ``coverage`` (Romano, Patterson, Candes 2019)."""
    s = np.asarray(scores, dtype=np.float64)
    level = min(1.0, math.ceil((s.size + 1) * coverage) / s.size)
    return float(np.quantile(s, level, method="higher"))


def _check_coverage(coverage) -> float:
    if not (isinstance(coverage, int | float) and 0.0 < coverage < 1.0):
        raise ValueError(f"coverage = {coverage!r}: must be in (0, 1)")
    return float(coverage)


# --- regression with an interval ---------------------------------------------------------------


@dataclass(eq=False, repr=False, kw_only=True)
class IntervalRegressor(RegressorMixin, _Boosting, BaseEstimator):
    """Gradient-boosted median with a conformalised quantile prediction interval.

    ``predict`` gives the median; ``predict_interval`` an (n, 2) array [low, high] of nominal
    coverage ``coverage``: the (1 -+ coverage) / 2 quantile models, moved out (or in) by the
    margin that makes ``coverage`` of the out-of-fold samples fall inside (``groups`` in ``fit``
    keeps a simulation run's windows in one fold).

    ``interval = "residual"``: the median -+ ``scale_margin_`` s(x) instead, s(x) the exp of a
    median model of log |y - out-of-fold median| (the error of a median that never saw the
    row's run, which the quantile models, fitted on every run, do not see), ``scale_margin_``
    the conformal quantile of |y - median| / s over rows whose s is out of fold as well.
    """

    coverage: float = DEFAULT_COVERAGE
    interval: str = "quantile"

    def _model(self, quantile: float) -> HistGradientBoostingRegressor:
        return HistGradientBoostingRegressor(
            loss="quantile", quantile=quantile, **self._hgb_params()
        )

    def fit(self, X, y, groups=None):
        X, y = validate_data(self, X, y, y_numeric=True, dtype=np.float64)
        coverage = _check_coverage(self.coverage)
        if self.interval not in INTERVALS:
            raise ValueError(f"interval = {self.interval!r}: must be one of {INTERVALS}")
        if self.interval == "residual":
            return self._fit_residual(X, y, groups, coverage)
        self.scale_margin_ = None
        lo_q, hi_q = (1.0 - coverage) / 2.0, (1.0 + coverage) / 2.0
        self.median_ = self._model(0.5).fit(X, y)
        self.lower_ = self._model(lo_q).fit(X, y)
        self.upper_ = self._model(hi_q).fit(X, y)
        self.n_iter_ = self.median_.n_iter_
        self.forest_ = FlatForest([self.median_, self.lower_, self.upper_])

        def bounds(X_fit, y_fit, X_test):
            models = (self._model(lo_q), self._model(hi_q))
            return np.stack([m.fit(X_fit, y_fit).predict(X_test) for m in models], axis=1)

        oof = out_of_fold(X, y, bounds, 2, groups, self.n_splits)
        done = ~np.isnan(oof).any(axis=1)
        if done.any():
            s = np.maximum(oof[done, 0] - y[done], y[done] - oof[done, 1])
            self.margin_ = conformal_margin(s, coverage)
        else:
            self.margin_ = 0.0
        return self

    def _fit_residual(self, X, y, groups, coverage: float):
        """``interval = "residual"`` (class docstring): the median, the scale model s and the
        margin, each calibration step on rows a model fitted without their run predicts."""

        def median(X_fit, y_fit, X_test):
            return self._model(0.5).fit(X_fit, y_fit).predict(X_test)

        self.median_ = self._model(0.5).fit(X, y)
        self.n_iter_ = self.median_.n_iter_
        self.margin_ = 0.0
        error = np.abs(y - out_of_fold(X, y, median, 1, groups, self.n_splits)[:, 0])
        done = np.isfinite(error)
        self.scale_margin_, self.scale_ = 0.0, None
        self.forest_ = FlatForest([self.median_])
        if not done.any():  # too few runs to tell: no interval beyond the median
            return self
        floor = max(float(np.median(error[done])) * 1e-3, np.finfo(float).tiny)
        log_error = np.log(error[done] + floor)
        g = None if groups is None else np.asarray(groups)[done]
        scale = out_of_fold(X[done], log_error, median, 1, g, self.n_splits)[:, 0]
        ok = np.isfinite(scale)
        self.scale_margin_ = conformal_margin(error[done][ok] / np.exp(scale[ok]), coverage)
        self.scale_ = self._model(0.5).fit(X[done], log_error)
        self.forest_ = FlatForest([self.median_, self.scale_])
        return self

    def _quantiles(self, X: np.ndarray) -> np.ndarray:
        """(median, lower, upper) of validated rows, shape (n, 3); quantile links are identity."""
        raw = self.forest_.raw(X)
        if getattr(self, "scale_margin_", None) is None:  # quantile models (or a former file)
            return raw
        half = self.scale_margin_ * np.exp(raw[:, 1]) if raw.shape[1] > 1 else 0.0 * raw[:, 0]
        return np.stack([raw[:, 0], raw[:, 0] - half, raw[:, 0] + half], axis=1)

    def _median_and_interval(
        self, X: np.ndarray, margin: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Median and [low, high] of validated rows; ``margin`` (per row) instead of the
        out-of-fold ``margin_``."""
        q = self._quantiles(X)
        mid = q[:, 0]
        m = self.margin_ if margin is None else margin
        lo = np.minimum(q[:, 1] - m, mid)
        hi = np.maximum(q[:, 2] + m, mid)
        return mid, np.stack([lo, hi], axis=1)

    def predict(self, X):
        check_is_fitted(self, "margin_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self.forest_.raw(X)[:, 0]

    def predict_interval(self, X) -> np.ndarray:
        """[low, high] per row, shape (n, 2), always around the median."""
        check_is_fitted(self, "margin_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self._median_and_interval(X)[1]


# --- classification with calibrated probabilities ---------------------------------------------


def _softmax_log(p: np.ndarray, temperature: float) -> np.ndarray:
    z = np.log(np.clip(p, 1e-12, 1.0)) / temperature
    z -= z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


def _fit_temperature(p: np.ndarray, y_index: np.ndarray) -> float:
    """Temperature T minimising the log loss of softmax(log p / T) (Guo et al. 2017)."""
    from scipy.optimize import minimize_scalar

    def nll(log_t: float) -> float:
        q = _softmax_log(p, math.exp(log_t))
        return float(-np.mean(np.log(np.clip(q[np.arange(len(y_index)), y_index], 1e-12, 1))))

    res = minimize_scalar(nll, bounds=(math.log(0.05), math.log(20.0)), method="bounded")
    return float(math.exp(res.x))


@dataclass(eq=False, repr=False, kw_only=True)
class RegimeClassifier(ClassifierMixin, _Boosting, BaseEstimator):
    """Gradient-boosted classifier whose probabilities are temperature-scaled out of fold.

    With ``groups`` in ``fit`` the folds keep a simulation run together, so the temperature
    reflects runs never seen; probabilities of classes the signature cannot tell apart split.
    """

    def _model(self) -> HistGradientBoostingClassifier:
        return HistGradientBoostingClassifier(**self._hgb_params())

    def fit(self, X, y, groups=None):
        X, y = validate_data(self, X, y, dtype=np.float64)
        check_classification_targets(y)
        self.classes_, y_index = np.unique(y, return_inverse=True)
        self.temperature_ = 1.0
        self.n_iter_ = 1
        if self.classes_.size == 1:
            self.model_ = None
            return self
        self.model_ = self._model().fit(X, y_index)
        self.n_iter_ = self.model_.n_iter_
        self.forest_ = FlatForest([self.model_])
        n_classes = self.classes_.size

        def probabilities(X_fit, y_fit, X_test):
            if np.unique(y_fit).size < 2:
                return None
            m = self._model().fit(X_fit, y_fit)
            # a fold may lack a class: place its columns by class index
            p = np.zeros((X_test.shape[0], n_classes))
            p[:, m.classes_] = m.predict_proba(X_test)
            return p

        oof = out_of_fold(
            X, y_index, probabilities, n_classes, groups, self.n_splits, classes=y_index
        )
        done = ~np.isnan(oof).any(axis=1)
        if done.sum() >= 10:
            self.temperature_ = _fit_temperature(oof[done], y_index[done])
        # calibrated out-of-fold probabilities (NaN where no fold predicted): what a decision
        # threshold is set on
        self.oof_proba_ = np.full_like(oof, np.nan)
        if done.any():
            self.oof_proba_[done] = _softmax_log(oof[done], self.temperature_)
        return self

    def _proba(self, X: np.ndarray) -> np.ndarray:
        if self.model_ is None:
            return np.ones((X.shape[0], 1))
        p = self.model_._loss.predict_proba(self.forest_.raw(X))
        return _softmax_log(p, self.temperature_)

    def predict_proba(self, X) -> np.ndarray:
        check_is_fitted(self, "temperature_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self._proba(X)

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "temperature_")
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]


# --- the load state ----------------------------------------------------------------------------


def _target_columns(y) -> list[tuple[str, np.ndarray, bool]]:
    """(name, values, is_class) per target column of ``y`` (DataFrame, Series or array)."""
    if y is None:
        raise ValueError("LoadStateEstimator requires y to be passed, but the target y is None")
    if isinstance(y, pd.DataFrame):
        cols = [(str(c), y[c].to_numpy()) for c in y.columns]
    elif isinstance(y, pd.Series):
        cols = [(str(y.name) if y.name is not None else "y", y.to_numpy())]
    else:
        arr = np.asarray(y)
        if arr.ndim == 1:
            cols = [("y", arr)]
        elif arr.ndim == 2:
            cols = [(f"y{j}", arr[:, j]) for j in range(arr.shape[1])]
        else:
            raise ValueError(f"y has {arr.ndim} dimensions; give a 1-D or 2-D target")
    out = []
    for name, values in cols:
        is_class = (
            name == CLASS_TARGET
            or values.dtype.kind in "OUSb"
            or isinstance(values.dtype, pd.CategoricalDtype)
        )
        if not is_class:
            values = np.asarray(values, dtype=np.float64)
            if not np.all(np.isfinite(values)):
                raise ValueError(f"target {name!r} holds NaN or infinite values")
        out.append((name, np.asarray(values), is_class))
    return out


@dataclass(eq=False, repr=False, kw_only=True)
class LoadStateEstimator(_Boosting, BaseEstimator):
    """F_r, epsilon and clearance with intervals, and the regime with probabilities.

    ``fit(X, y, groups)``: ``X`` the features (a DataFrame with the model's feature columns, or
    any numeric array), ``y`` the labels: a DataFrame with any of ``radial_load_n``,
    ``epsilon``, ``clearance_m`` (numbers: an :class:`IntervalRegressor` each) and ``regime``
    (a :class:`RegimeClassifier`), or a numeric array (each column a regression target);
    ``groups`` the simulation run of each row (cross-fitting keeps runs whole).

    ``radial_load_n`` is learnt as log F_r + ``hertz_exponent`` log R when ``X`` names the
    level feature (``level_mean_ohm``; R ~ F_r^(-4/3) leaves only epsilon's slow effect).

    ``predict`` gives point estimates (a DataFrame when fitted on one, else an array);
    ``predict_frame`` adds ``<target>_low``, ``<target>_high`` and
    ``regime_probability_<class>``.
    """

    coverage: float = DEFAULT_COVERAGE
    hertz_exponent: float = HERTZ_EXPONENT
    interval: str = "quantile"

    def _level_index(self) -> int | None:
        names = list(getattr(self, "feature_names_in_", []))
        return names.index(LEVEL_FEATURE) if LEVEL_FEATURE in names else None

    def fit(self, X, y=None, groups=None):
        X = validate_data(self, X, dtype=np.float64)
        targets = _target_columns(y)
        for _, values, _ in targets:
            check_consistent_length(X, values)
        if groups is not None:
            check_consistent_length(X, groups)
        params = self._boosting_params()
        level = self._level_index()
        self.targets_ = []
        self.estimators_ = {}
        self.load_transform_ = {}
        self.frame_output_ = isinstance(y, pd.DataFrame | pd.Series)
        for name, values, is_class in targets:
            if is_class:
                est = RegimeClassifier(**params).fit(X, values, groups=groups)
            else:
                target = values
                if name == "radial_load_n" and level is not None:
                    if np.any(values <= 0) or np.any(X[:, level] <= 0):
                        raise ValueError("radial_load_n and the level must be > 0 for log F_r")
                    target = np.log(values) + self.hertz_exponent * np.log(X[:, level])
                    self.load_transform_[name] = level
                est = IntervalRegressor(coverage=self.coverage, interval=self.interval, **params)
                est.fit(X, target, groups=groups)
            self.targets_.append((name, is_class))
            self.estimators_[name] = est
        return self

    def _regression(self, name: str, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Median and interval of validated rows, back on the target's own scale."""
        mid, band = self.estimators_[name]._median_and_interval(X)
        if name in self.load_transform_:
            shift = self.hertz_exponent * np.log(
                np.maximum(X[:, self.load_transform_[name]], 1e-300)
            )
            mid = np.exp(mid - shift)
            band = np.exp(band - shift[:, None])
        return mid, band

    def predict_frame(self, X) -> pd.DataFrame:
        """Point estimates, interval bounds and class probabilities, one row per sample."""
        check_is_fitted(self, "estimators_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return pd.DataFrame(self._predict_columns(X))

    def _predict_columns(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """The columns of :meth:`predict_frame` for validated rows."""
        out: dict[str, np.ndarray] = {}
        for name, is_class in self.targets_:
            est = self.estimators_[name]
            if is_class:
                proba = est._proba(X)
                out[name] = est.classes_[np.argmax(proba, axis=1)]
                for j, cls in enumerate(est.classes_):
                    out[f"{name}_probability_{cls}"] = proba[:, j]
            else:
                mid, band = self._regression(name, X)
                out[name] = mid
                out[f"{name}_low"] = band[:, 0]
                out[f"{name}_high"] = band[:, 1]
        return out

    def predict(self, X):
        check_is_fitted(self, "estimators_")
        X = validate_data(self, X, reset=False, dtype=np.float64)
        cols = {}
        for name, is_class in self.targets_:
            est = self.estimators_[name]
            if is_class:
                cols[name] = est.classes_[np.argmax(est._proba(X), axis=1)]
            else:
                cols[name] = self._regression(name, X)[0]
        if self.frame_output_:
            return pd.DataFrame(cols)
        values = list(cols.values())
        if len(values) == 1:
            return values[0]
        if any(is_class for _, is_class in self.targets_):
            return np.stack([np.asarray(v, dtype=object) for v in values], axis=1)
        return np.stack(values, axis=1)


@dataclass
class LoadStateModel:
    """A fitted :class:`LoadStateEstimator` with what it needs to be used and trusted: the
    feature columns it reads, in order, ``info`` on its training (source, rows, runs,
    targets, coverage, ranges of the labels, of omega and of the level), the ``domain`` of
    its training traces (:class:`~signatelec.estimation.domain.Domain`: level range, in-domain
    score) and, when trained on condition labels, the ``condition`` model beside it; the
    ``faulty`` model answers the load state where the condition model calls a fault, the
    ``stretch`` model that of a stretch of windows from their mean features."""

    estimator: LoadStateEstimator
    features: list[str]
    info: dict
    domain: Domain | None = None
    #: The bearing's condition (:class:`~signatelec.estimation.condition.ConditionModel`), or
    #: None for a model trained on a table without condition labels.
    condition: object | None = None
    #: The load-state model of a trace on which the condition model calls a defect or an
    #: unbalance (a :class:`LoadStateModel` trained on defective runs too), or None.
    faulty: object | None = None
    #: The load state of a stretch of windows from their MEAN features (a
    #: :class:`LoadStateModel` trained on stretches' mean features: the noise averaged, the
    #: ripple's shape kept), which the monitor asks about a healthy stretch, or None.
    stretch: object | None = None
    #: The bearing whose traces it learnt, its features read at that bearing's ball-pass line
    #: (:class:`~signatelec.config.bearing.Bearing`), or None for the seed's.
    bearing: Bearing | None = None

    def knows(self, bearing: Bearing | None) -> bool:
        """Whether it learnt the load state of ``bearing`` (None: the seed's)."""
        return same_bearing(self.bearing, bearing)

    def predict_frame(self, features: pd.DataFrame) -> pd.DataFrame:
        return self.estimator.predict_frame(features[self.features])

    def predict_columns(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """The columns of :meth:`predict_frame` for rows of features in the order of
        :attr:`features` (an array), without pandas or validation overhead (a monitor asks
        for thousands of windows); ValueError naming the features that are not finite."""
        x = np.asarray(x, dtype=np.float64)
        if not np.all(np.isfinite(x)):
            finite = np.isfinite(x).all(axis=0)
            bad = [n for n, ok in zip(self.features, finite, strict=True) if not ok]
            raise ValueError(f"features not finite: {', '.join(bad)}")
        return self.estimator._predict_columns(x)

    def predict_one(self, features: dict[str, float]) -> dict:
        """Estimates for one trace's features (a dict by name), without pandas or validation
        overhead (~5 ms less): the columns are put in the fitted order here."""
        x = np.array([[features[name] for name in self.features]], dtype=np.float64)
        cols = self.predict_columns(x)
        return {k: (v[0].item() if hasattr(v[0], "item") else v[0]) for k, v in cols.items()}
