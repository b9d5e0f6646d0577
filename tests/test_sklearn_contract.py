"""scikit-learn's own conformance checks over every transformer and estimator signatelec defines.

The list is found, not written: every public ``BaseEstimator`` subclass of the estimation
modules, so a new one is checked without being added here. Estimators are built small
(``max_iter=20``, two out-of-fold splits) to keep the ~500 checks near 10 s. No check is
expected to fail (``expected_failed_checks`` stays empty).
"""

from __future__ import annotations

import inspect

import pytest
from sklearn.base import BaseEstimator
from sklearn.utils.estimator_checks import parametrize_with_checks
from threadpoolctl import threadpool_limits

from signatelec.estimation import condition, models, transformers

#: Parameters that make an estimator quick to fit in the checks (where it takes them).
QUICK = {"max_iter": 20, "n_splits": 2}


def _defined(*modules) -> list[type[BaseEstimator]]:
    found = []
    for module in modules:
        for name, obj in vars(module).items():
            if (
                inspect.isclass(obj)
                and issubclass(obj, BaseEstimator)
                and obj.__module__ == module.__name__
                and not name.startswith("_")
            ):
                found.append(obj)
    return found


ESTIMATORS = _defined(transformers, models, condition)


def _quick(cls: type[BaseEstimator]) -> BaseEstimator:
    params = cls().get_params()
    return cls(**{k: v for k, v in QUICK.items() if k in params})


@pytest.fixture(autouse=True)
def _one_thread():
    """Gradient boosting with one thread: two pytest workers on two cores do not fight."""
    with threadpool_limits(1):
        yield


def test_every_estimator_is_checked():
    names = {cls.__name__ for cls in ESTIMATORS}
    assert {"IntervalRegressor", "RegimeClassifier", "LoadStateEstimator"} <= names
    assert "ConditionEstimator" in names
    assert {cls.__name__ for cls in transformers.TRANSFORMERS} <= names


#: Options that change what an estimator fits, checked as well.
VARIANTS = [models.IntervalRegressor(interval="residual", **QUICK)]


@parametrize_with_checks([_quick(cls) for cls in ESTIMATORS] + VARIANTS)
def test_sklearn_contract(estimator, check):
    check(estimator)
