"""Measurement model: what an instrument makes of the simulated bearing resistance.

The DEM records the resistance at the simulation's own rate (point samples of the state every
``record_every`` steps). :class:`MeasurementModel` turns that into the signal a resistance meter
would give, in this order:

1. **anti-alias filter**: a zero-phase Butterworth low-pass (``scipy.signal.sosfiltfilt``, order
   ``anti_alias_order``, cut-off ``anti_alias_cutoff`` x the output Nyquist frequency) over the
   steady phase at the simulation's record rate, *before* decimation;
2. **resampling** to ``sample_rate_hz``: linear interpolation of the filtered signal at
   ``t0 + k / sample_rate_hz`` (the simulation records at ``oversample`` x the output rate, so
   the interpolation works on a smooth, oversampled signal). This is the *clean* signal;
3. **constant offset** ``offset_ohm`` added to the whole resistance (leads, brushes: unknown to
   an estimator, hence a nuisance parameter);
4. **slow drift**: a Wiener process (random walk, power ~ 1/f^2) scaled so that its standard
   deviation at the end of the window is ``drift_fraction`` x the mean clean resistance;
5. **white noise**: Gaussian, standard deviation ``noise_fraction`` x the mean clean resistance;
6. **quantisation**: rounding to multiples of ``quantisation_ohm`` (0: none), as an ADC does.

``noise_fraction``, ``drift_fraction`` and ``offset_ohm`` are ranges ``(low, high)``: each trace
draws its own value uniformly (a fixed value is a range of zero width). Every random number comes
from the generator handed in (one per trace, see :func:`signatelec.data.design.trace_rng`),
always in the same order, so a trace is reproducible on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Leading and trailing margins of steady signal kept around the window, in output samples, so
#: the zero-phase filter's edge transients fall outside it.
GUARD_SAMPLES = 20


class MeasurementError(ValueError):
    """The simulated signal cannot be measured (window not covered, resistance not finite)."""


@dataclass(frozen=True)
class MeasurementDraw:
    """The random measurement parameters of one trace."""

    noise_fraction: float
    drift_fraction: float
    offset_ohm: float


@dataclass(frozen=True)
class MeasurementModel:
    sample_rate_hz: float = 10000.0
    oversample: int = 4
    anti_alias: bool = True
    anti_alias_order: int = 8
    anti_alias_cutoff: float = 0.8
    noise_fraction: tuple[float, float] = (0.0, 0.0)
    drift_fraction: tuple[float, float] = (0.0, 0.0)
    offset_ohm: tuple[float, float] = (0.0, 0.0)
    quantisation_ohm: float = 0.0

    def simulation_rate_hz(self, dt_s: float) -> float:
        """Record rate to ask of the simulation: oversample x the output rate, at most 1/dt."""
        return min(self.oversample * self.sample_rate_hz, 1.0 / dt_s)

    @property
    def guard_s(self) -> float:
        return GUARD_SAMPLES / self.sample_rate_hz

    def draw(self, rng: np.random.Generator) -> MeasurementDraw:
        """Draw the trace's noise level, drift level and offset (three uniforms, always)."""
        u = rng.random(3)
        ranges = (self.noise_fraction, self.drift_fraction, self.offset_ohm)
        values = [lo + (hi - lo) * x for (lo, hi), x in zip(ranges, u, strict=True)]
        return MeasurementDraw(*values)

    def clean(self, time_s, resistance_ohm, t0_s: float, n_samples: int) -> np.ndarray:
        """Anti-alias filter, then resample at ``t0_s + k / sample_rate_hz``, k < n_samples.

        ``time_s`` and ``resistance_ohm`` are the simulation's records (uniformly spaced); they
        must cover the window and should extend :data:`GUARD_SAMPLES` output samples beyond it.
        Raises MeasurementError when they do not or when the resistance is not finite.
        """
        t = np.asarray(time_s, dtype=float)
        r = np.asarray(resistance_ohm, dtype=float)
        out_t = t0_s + np.arange(n_samples) / self.sample_rate_hz
        if len(t) < 2 or t[0] > out_t[0] + 1e-12 or t[-1] < out_t[-1] - 1e-12:
            raise MeasurementError(
                f"the simulated signal ({t[0] if len(t) else 0:g}-{t[-1] if len(t) else 0:g} s) "
                f"does not cover the window {out_t[0]:g}-{out_t[-1]:g} s"
            )
        bad = ~np.isfinite(r)
        if bad.any():
            raise MeasurementError(
                f"resistance not finite at {int(bad.sum())} of {len(r)} steady instants "
                "(no ball touches both rings)"
            )
        sim_rate = 1.0 / float(np.median(np.diff(t)))
        if sim_rate < self.sample_rate_hz * (1.0 - 1e-9):
            raise MeasurementError(
                f"simulation record rate {sim_rate:g} Hz is below the output rate "
                f"{self.sample_rate_hz:g} Hz (time step too large)"
            )
        if self.anti_alias:
            from scipy.signal import butter, sosfiltfilt

            wn = self.anti_alias_cutoff * self.sample_rate_hz / sim_rate
            if wn < 1.0:
                sos = butter(self.anti_alias_order, wn, output="sos")
                r = sosfiltfilt(sos, r)
        return np.interp(out_t, t, r)

    def measure(
        self, clean_ohm: np.ndarray, draw: MeasurementDraw, rng: np.random.Generator
    ) -> np.ndarray:
        """Offset, drift, white noise and quantisation applied to the clean signal."""
        n = len(clean_ohm)
        mean = float(np.mean(clean_ohm)) if n else 0.0
        white = rng.standard_normal(n)
        steps = rng.standard_normal(n)
        drift = np.cumsum(steps) / np.sqrt(max(n, 1))
        signal = (
            clean_ohm
            + draw.offset_ohm
            + draw.drift_fraction * mean * drift
            + draw.noise_fraction * mean * white
        )
        if self.quantisation_ohm > 0.0:
            signal = np.round(signal / self.quantisation_ohm) * self.quantisation_ohm
        return signal
