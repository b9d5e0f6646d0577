"""How far a trace lies from the traces a model was trained on: level range and in-domain score.

A model answers well only for traces like those it learnt from. :class:`Domain`, fitted with the
model (:func:`signatelec.estimation.training.train_model`) and stored in it, keeps two things:

- the **level range**: the trained traces' mean resistance, ohm, which the sanity layer checks
  (:func:`signatelec.measurement.sanity.check_level`: a unit mix-up is named);
- the **in-domain score** in [0, 1] of the trace's :data:`DOMAIN_FEATURES` (the model's features
  that describe the ripple's shape and the noise, not the level, the speed or the trace's
  length, which are checked apart or grow with the length by design): each feature as a robust
  z (median, 1.4826 MAD of the training rows), then the squared Mahalanobis distance d^2 with
  the covariance of those z. The score is the share of training traces at least as far out
  (an empirical p-value: for a trace like the training ones it is uniform on [0, 1]); beyond
  the :data:`TAIL_QUANTILE` of the training distances the tail is extrapolated as an
  exponential fitted to their excess (peaks over threshold), so the score keeps falling
  towards 0 beyond the farthest training trace.

Thresholds: below :data:`WARN_SCORE` (as atypical as the 1 % most atypical training traces)
the estimate carries a warning; below :data:`REFUSE_SCORE` (d^2 about 11 mean excesses past the
tail's start: no training trace comes near) it is refused with :class:`DomainError`, and so is
a trace in which the sanity layer found no ball-pass line below :data:`NO_LINE_REFUSE_SCORE`.
Measured with the default model on 300 held-out DEM runs of the training design (windows
measured at 0.05 % drift): at 0.2 % noise over 50 ms 0.25 % of the windows warn and none is
refused; at 1 % noise (the training range's top) 4 % warn; at 2 % noise (beyond it) 99.9 % warn
and 2.6 % are refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from signatelec.estimation.features import LENGTH_DEPENDENT

#: Model features that are not scored: the level (its own range check), the speed (the
#: ripple check and the omega range), the level-scaled first harmonic, and those that grow
#: with the length.
NOT_SCORED = ("level_mean_ohm", "omega_rad_s", "h1_amp_ohm", *LENGTH_DEPENDENT)
#: Share of training traces beyond which the distance tail is extrapolated.
TAIL_QUANTILE = 0.95
WARN_SCORE = 0.01
REFUSE_SCORE = 1e-6
#: A trace without a ball-pass line is refused below this score (see
#: :mod:`signatelec.estimation.estimate`).
NO_LINE_REFUSE_SCORE = 1e-3


#: A speed within this share of a model's training speeds counts as inside them: the runs'
#: speeds are drawn within the design's bounds (the default load-state model's 250.1-750.0 of
#: 250-750 rad/s, its condition model's 300.1-698.9 of 300-700).
SPEED_MARGIN = 0.01


def outside_speeds(ranges: dict | None, low: float | None, high: float | None = None):
    """The training speeds (lo, hi) in a model's ``ranges`` (``info["ranges"]``, its
    ``omega_rad_s``) when the speed ``low`` (or the span ``low``-``high``) leaves them widened
    by :data:`SPEED_MARGIN` (a NaN speed leaves them); None when it stays inside, or without a
    range or a speed."""
    lo, hi = (ranges or {}).get("omega_rad_s", (None, None))
    if lo is None or low is None:
        return None
    high = low if high is None else high
    inside = (1.0 - SPEED_MARGIN) * lo <= low and high <= (1.0 + SPEED_MARGIN) * hi
    return None if inside else (lo, hi)


def refuse_score(has_line: bool) -> float:
    """The in-domain score below which a window is refused: :data:`REFUSE_SCORE`, or
    :data:`NO_LINE_REFUSE_SCORE` when the sanity layer found no ball-pass line in it."""
    return REFUSE_SCORE if has_line else NO_LINE_REFUSE_SCORE


_MAD_TO_SIGMA = 1.4826


class DomainError(ValueError):
    """A trace outside the model's domain; one line saying how and what the range is."""


def domain_features(model_features) -> list[str]:
    """The features scored: the model's, less :data:`NOT_SCORED`."""
    return [f for f in model_features if f not in NOT_SCORED]


@dataclass(frozen=True)
class Domain:
    """Where the training traces lie (see the module docstring)."""

    features: tuple[str, ...]
    centre: np.ndarray
    scale: np.ndarray
    precision: np.ndarray
    #: training distances d^2, sorted
    reference: np.ndarray
    tail_start: float
    tail_scale: float
    level_range_ohm: tuple[float, float]

    @classmethod
    def fit(cls, table: pd.DataFrame, features) -> Domain:
        """The domain of a training table (rows: traces; columns: ``features`` and
        ``level_mean_ohm``)."""
        names = tuple(features)
        x = table[list(names)].to_numpy(dtype=float)
        centre = np.median(x, axis=0)
        scale = _MAD_TO_SIGMA * np.median(np.abs(x - centre), axis=0)
        std = x.std(axis=0)
        # features with mostly one value (debiased amplitudes at 0) fall back on the std
        scale = np.where(scale > 1e-12 * np.maximum(np.abs(centre), 1e-300), scale, std)
        scale = np.where(scale > 0.0, scale, 1.0)
        z = (x - centre) / scale
        cov = np.cov(z, rowvar=False) + 1e-6 * np.eye(len(names))
        precision = np.linalg.inv(cov)
        d2 = np.sort(np.einsum("ij,jk,ik->i", z, precision, z))
        start = float(np.quantile(d2, TAIL_QUANTILE))
        excess = d2[d2 > start] - start
        level = table["level_mean_ohm"].to_numpy(dtype=float)
        return cls(
            features=names,
            centre=centre,
            scale=scale,
            precision=precision,
            reference=d2,
            tail_start=start,
            tail_scale=float(excess.mean()) if excess.size else 1.0,
            level_range_ohm=(float(level.min()), float(level.max())),
        )

    def distance2(self, features: dict[str, float]) -> float:
        """Squared Mahalanobis distance of one trace's features to the training traces."""
        z = (np.array([features[f] for f in self.features]) - self.centre) / self.scale
        return float(z @ self.precision @ z)

    def score_of_distance(self, d2: float) -> float:
        """Share of training traces at least ``d2`` out; the exponential tail beyond
        :data:`TAIL_QUANTILE`."""
        if not math.isfinite(d2):
            return 0.0
        if d2 <= self.tail_start:
            n = self.reference.size
            beyond = n - int(np.searchsorted(self.reference, d2, side="left"))
            return min(1.0, (beyond + 1) / (n + 1))
        tail = 1.0 - TAIL_QUANTILE
        return float(tail * math.exp(-(d2 - self.tail_start) / self.tail_scale))

    def score(self, features: dict[str, float]) -> float:
        """In-domain score in [0, 1] (1: at the centre of the training traces)."""
        return self.score_of_distance(self.distance2(features))

    def scores(self, x: np.ndarray) -> np.ndarray:
        """In-domain scores of many traces: rows of ``x``, columns in the order of
        :attr:`features` (the same numbers as :meth:`score` of each)."""
        z = (np.asarray(x, float) - self.centre) / self.scale
        d2 = np.einsum("ij,jk,ik->i", z, self.precision, z)
        return np.array([self.score_of_distance(float(v)) for v in d2])

    def farthest(self, features: dict[str, float], n: int = 2) -> list[str]:
        """The ``n`` features farthest from the training median, in robust z, for messages."""
        z = (np.array([features[f] for f in self.features]) - self.centre) / self.scale
        order = np.argsort(-np.abs(np.nan_to_num(z, nan=np.inf)))[:n]
        return [
            f"{self.features[i]} {features[self.features[i]]:.3g} (z {z[i]:+.0f})" for i in order
        ]
