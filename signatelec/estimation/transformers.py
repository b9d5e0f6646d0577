"""scikit-learn transformers of bearing-resistance traces: twins of the feature functions.

Each transformer takes ``X`` of shape ``(n_traces, n_samples)``, one trace per row, all sampled
at ``sample_rate_hz`` with the shaft at ``omega_rad_s``, and gives the features of its twin in
:mod:`signatelec.estimation.features` (one analysis per trace), in the twin's order
(``get_feature_names_out``). scikit-learn's contract fixes the number of samples between
``fit`` and ``transform``; the functions take any length. The condition transformers
(:mod:`signatelec.estimation.condition_features`) take the ``bearing`` too (None: the seed's),
whose geometry sets the characteristic lines.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from signatelec.config.bearing import Bearing
from signatelec.estimation.analysis import analyse_trace
from signatelec.estimation.condition_features import (
    condition_features,
    envelope_features,
    impulse_features,
    line_features,
)
from signatelec.estimation.envelope import analyse_envelope
from signatelec.estimation.features import (
    ball_pass_features,
    harmonic_features,
    level_features,
    noise_features,
    ripple_features,
    spectrum_features,
    trace_features,
)
from signatelec.measurement.band import N_HARMONICS


class _TraceTransformer(TransformerMixin, BaseEstimator):
    """Rows of ``X`` are traces sampled at ``sample_rate_hz``, shaft at ``omega_rad_s``.

    Stateless: ``fit`` only records the number of samples per trace. ``_function`` is the
    feature function whose twin the transformer is.
    """

    _function = staticmethod(trace_features)

    def __init__(
        self,
        sample_rate_hz: float = 20000.0,
        omega_rad_s: float = 500.0,
        n_harmonics: int = N_HARMONICS,
    ):
        self.sample_rate_hz = sample_rate_hz
        self.omega_rad_s = omega_rad_s
        self.n_harmonics = n_harmonics

    def fit(self, X, y=None):
        validate_data(self, X, dtype=np.float64)
        if not (isinstance(self.n_harmonics, int | np.integer) and self.n_harmonics >= 1):
            raise ValueError(f"n_harmonics = {self.n_harmonics!r}: must be an integer >= 1")
        return self

    def _names(self) -> list[str]:
        return self._function.feature_names(self.n_harmonics)

    def _analyse(self, row: np.ndarray):
        return analyse_trace(
            row, self.sample_rate_hz, self.omega_rad_s, n_harmonics=self.n_harmonics
        )

    def transform(self, X):
        check_is_fitted(self, "n_features_in_")
        X = validate_data(self, X, dtype=np.float64, reset=False)
        names = self._names()
        out = np.empty((X.shape[0], len(names)))
        for i, row in enumerate(X):
            d = self._function(None, analysis=self._analyse(row))
            out[i] = [d[n] for n in names]
        return out

    def get_feature_names_out(self, input_features=None):
        check_is_fitted(self, "n_features_in_")
        return np.asarray(self._names(), dtype=object)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.requires_fit = True
        return tags


def _twin(name: str, function, base: type | None = None) -> type:
    """The transformer class twin of a feature function (a subclass of ``base``, by default
    :class:`_TraceTransformer`)."""
    return type(
        name,
        (base or _TraceTransformer,),
        {
            "__module__": __name__,
            "__qualname__": name,
            "__doc__": f"Transformer twin of :func:`~{function.__module__}.{function.__name__}`.",
            "_function": staticmethod(function),
        },
    )


LevelFeatures = _twin("LevelFeatures", level_features)
SpectrumFeatures = _twin("SpectrumFeatures", spectrum_features)
BallPassFeatures = _twin("BallPassFeatures", ball_pass_features)
HarmonicFeatures = _twin("HarmonicFeatures", harmonic_features)
NoiseFeatures = _twin("NoiseFeatures", noise_features)
RippleFeatures = _twin("RippleFeatures", ripple_features)
TraceFeatures = _twin("TraceFeatures", trace_features)


class _ConditionTransformer(_TraceTransformer):
    """Rows of ``X`` are traces sampled at ``sample_rate_hz``, shaft at ``omega_rad_s``, of a
    bearing ``bearing`` (None: the seed's). Stateless; ``_function`` is the condition feature
    function whose twin the transformer is."""

    _function = staticmethod(condition_features)

    def __init__(
        self,
        sample_rate_hz: float = 20000.0,
        omega_rad_s: float = 500.0,
        bearing: Bearing | None = None,
    ):
        self.sample_rate_hz = sample_rate_hz
        self.omega_rad_s = omega_rad_s
        self.bearing = bearing

    def fit(self, X, y=None):
        validate_data(self, X, dtype=np.float64)
        if not (self.bearing is None or isinstance(self.bearing, Bearing)):
            raise ValueError(f"bearing = {self.bearing!r}: must be a Bearing or None")
        return self

    def _names(self) -> list[str]:
        return self._function.feature_names()

    def _analyse(self, row: np.ndarray):
        return analyse_envelope(row, self.sample_rate_hz, self.omega_rad_s, bearing=self.bearing)


EnvelopeFeatures = _twin("EnvelopeFeatures", envelope_features, _ConditionTransformer)
LineFeatures = _twin("LineFeatures", line_features, _ConditionTransformer)
ImpulseFeatures = _twin("ImpulseFeatures", impulse_features, _ConditionTransformer)
ConditionFeatures = _twin("ConditionFeatures", condition_features, _ConditionTransformer)

#: The condition transformers: the groups' in the order of
#: :data:`~signatelec.estimation.condition_features.CONDITION_GROUPS`, then the one of them all.
CONDITION_TRANSFORMERS = (EnvelopeFeatures, LineFeatures, ImpulseFeatures, ConditionFeatures)

#: Every load-state transformer: the groups' in the order of
#: :data:`~signatelec.estimation.features.FEATURE_GROUPS`, then the one of them all.
TRANSFORMERS = (
    LevelFeatures,
    SpectrumFeatures,
    BallPassFeatures,
    HarmonicFeatures,
    NoiseFeatures,
    RippleFeatures,
    TraceFeatures,
)
