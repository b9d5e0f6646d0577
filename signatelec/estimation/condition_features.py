"""Features of a bearing's condition from its resistance trace: envelope lines, raw lines,
impulsiveness.

Read from one :class:`~signatelec.estimation.envelope.EnvelopeAnalysis` per trace (the band by
spectral kurtosis, the Hilbert envelope, the amplitude spectra; the physics of each line is in
:mod:`signatelec.estimation.envelope`). Each function takes one trace ``(resistance_ohm,
sample_rate_hz, omega_rad_s, bearing=None)`` of any length, or ``analysis=`` its envelope
analysis, and returns a ``dict`` whose keys are ``function.feature_names()`` in that order; each
has a scikit-learn transformer twin in :mod:`signatelec.estimation.transformers`:

==========================  ============================  =====================================
transformer                 function                      features
==========================  ============================  =====================================
:class:`EnvelopeFeatures`   :func:`envelope_features`     envelope amplitudes at k f_n, sidebands
:class:`LineFeatures`       :func:`line_features`         trace amplitudes at k f_n, sidebands
:class:`ImpulseFeatures`    :func:`impulse_features`      kurtosis, crest factor, band, SK
:class:`ConditionFeatures`  :func:`condition_features`    all of the above (one analysis)
==========================  ============================  =====================================

Amplitudes are relative to the trace's level (a spall's pulse height scales with the
resistance); each line's first harmonic also as the ratio to its spectrum's local median (its
height above the noise, which grows as sqrt(T) for a steady line). f_n are the lines of
:data:`~signatelec.estimation.envelope.LINES`: shaft, cage (ftf), BPFO, BPFI and the ball's
defect line 2 BSF.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from signatelec.config.bearing import Bearing
from signatelec.estimation.envelope import (
    LINE_HARMONICS,
    LINES,
    EnvelopeAnalysis,
    analyse_envelope,
)

#: Bumped whenever a condition feature changes meaning: models trained on others are refused.
CONDITION_FEATURE_SET_VERSION = 1
#: Sidebands read: (name, carrier line, modulating line).
SIDEBANDS = (("bpfi_shaft", "bpfi", "shaft"), ("ball_ftf", "ball_defect", "ftf"))
RAW_SIDEBANDS = (("bpfo_shaft", "bpfo", "shaft"),)


def _group(names: Callable[[], list[str]]):
    """Make ``compute(analysis) -> dict`` a feature function of one trace (or of its envelope
    analysis) that carries its names: ``function.feature_names()``."""

    def wrap(compute: Callable[[EnvelopeAnalysis], dict[str, float]]):
        def function(
            resistance_ohm,
            sample_rate_hz: float | None = None,
            omega_rad_s: float | None = None,
            *,
            bearing: Bearing | None = None,
            analysis: EnvelopeAnalysis | None = None,
        ) -> dict[str, float]:
            if analysis is None:
                if sample_rate_hz is None or omega_rad_s is None:
                    raise TypeError("give sample_rate_hz and omega_rad_s (or an analysis)")
                analysis = analyse_envelope(
                    resistance_ohm, sample_rate_hz, omega_rad_s, bearing=bearing
                )
            return compute(analysis)

        for attr in ("__module__", "__name__", "__qualname__", "__doc__"):
            setattr(function, attr, getattr(compute, attr))
        function.feature_names = names
        return function

    return wrap


def _line_names(prefix: str, sidebands) -> list[str]:
    names = [f"{prefix}_{n}_h{k}_rel" for n in LINES for k in range(1, LINE_HARMONICS + 1)]
    names += [f"{prefix}_{n}_snr" for n in LINES]
    names += [f"{prefix}_{name}_sb_rel" for name, _, _ in sidebands]
    return names


def _lines(a: EnvelopeAnalysis, spectrum, prefix: str, sidebands) -> dict[str, float]:
    scale = abs(a.level_ohm) if a.level_ohm != 0.0 else 1.0
    out = {}
    for n in LINES:
        f = a.lines_hz[n]
        for k in range(1, LINE_HARMONICS + 1):
            out[f"{prefix}_{n}_h{k}_rel"] = spectrum.line(k * f) / scale
    for n in LINES:
        f = a.lines_hz[n]
        floor = spectrum.floor(f)
        out[f"{prefix}_{n}_snr"] = spectrum.line(f) / floor if floor > 0.0 else 0.0
    for name, carrier, mod in sidebands:
        fc, fm = a.lines_hz[carrier], a.lines_hz[mod]
        out[f"{prefix}_{name}_sb_rel"] = 0.5 * (spectrum.line(fc - fm) + spectrum.line(fc + fm))
        out[f"{prefix}_{name}_sb_rel"] /= scale
    return out


def envelope_feature_names() -> list[str]:
    return _line_names("env", SIDEBANDS)


@_group(envelope_feature_names)
def envelope_features(a: EnvelopeAnalysis) -> dict[str, float]:
    """Envelope-spectrum amplitudes at the first harmonics of each characteristic line, each
    first harmonic over its local floor, and the mean sideband amplitude at BPFI -+ f_s and
    2 BSF -+ FTF, relative to the level."""
    return _lines(a, a.envelope, "env", SIDEBANDS)


def line_feature_names() -> list[str]:
    return _line_names("raw", RAW_SIDEBANDS)


@_group(line_feature_names)
def line_features(a: EnvelopeAnalysis) -> dict[str, float]:
    """Amplitudes of the trace itself (less level and drift) at the first harmonics of each
    characteristic line, each first harmonic over its local floor, and the mean sideband
    amplitude at BPFO -+ f_s (a load turning at shaft speed), relative to the level."""
    return _lines(a, a.raw, "raw", RAW_SIDEBANDS)


def impulse_feature_names() -> list[str]:
    return [
        "residual_kurtosis",
        "residual_crest",
        "band_kurtosis",
        "band_crest",
        "band_sk",
        "band_centre_rel",
        "band_width_rel",
        "envelope_mean_rel",
        "cage_revolutions",
    ]


def _kurtosis_crest(x: np.ndarray) -> tuple[float, float]:
    """Pearson kurtosis (3 for Gaussian noise) and crest factor max|x| / rms of x less its
    mean."""
    x = x - x.mean()
    m2 = float(np.mean(x * x))
    if m2 <= 0.0:
        return 3.0, 1.0
    return float(np.mean(x**4)) / m2**2, float(np.max(np.abs(x))) / np.sqrt(m2)


@_group(impulse_feature_names)
def impulse_features(a: EnvelopeAnalysis) -> dict[str, float]:
    """How impulsive the trace is: kurtosis and crest factor of what the ball-pass ripple leaves
    and of the demodulation band's signal; the band's spectral kurtosis, centre and width
    relative to BPFO; the envelope's mean relative to the level; the cage revolutions the
    trace spans (how well it resolves the ball's lines)."""
    rk, rc = _kurtosis_crest(a.residual)
    bk, bc = _kurtosis_crest(a.band_signal)
    bpfo = a.lines_hz["bpfo"]
    scale = abs(a.level_ohm) if a.level_ohm != 0.0 else 1.0
    sk = a.band.kurtosis
    return {
        "residual_kurtosis": rk,
        "residual_crest": rc,
        "band_kurtosis": bk,
        "band_crest": bc,
        "band_sk": float(sk) if np.isfinite(sk) else 0.0,
        "band_centre_rel": 0.5 * (a.band.low_hz + a.band.high_hz) / bpfo,
        "band_width_rel": (a.band.high_hz - a.band.low_hz) / bpfo,
        "envelope_mean_rel": a.envelope_mean / scale,
        "cage_revolutions": a.cage_revolutions,
    }


def condition_feature_names() -> list[str]:
    return envelope_feature_names() + line_feature_names() + impulse_feature_names()


@_group(condition_feature_names)
def condition_features(a: EnvelopeAnalysis) -> dict[str, float]:
    """Every condition feature of one trace (one envelope analysis serves all groups)."""
    return {**envelope_features(None, analysis=a), **line_features(None, analysis=a)} | (
        impulse_features(None, analysis=a)
    )


#: The groups in the order of :func:`condition_feature_names`.
CONDITION_GROUPS = (envelope_features, line_features, impulse_features)
