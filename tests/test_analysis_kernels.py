"""The compiled passes of the window analysis against what they replace and against theory.

The monitor's throughput rests on compiled passes (numba) that must give the numbers of the
numpy forms the shipped models were trained on: numpy's pairwise summation, the Welch density
of ``scipy.signal.welch``, the band means, the unit phasors. Each is checked bit for bit where
it claims the same operations, and against a known signal (white noise's density, a known
multi-tone series) where theory says what the answer is.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import fft as sfft
from scipy import signal

from signatelec.estimation.analysis import _line_fit, analyse_windows, band_mean, band_means
from signatelec.estimation.harmonic_fit import (
    _centred,
    _row_sums,
    pairwise_sum,
    phasor_factors,
)
from signatelec.estimation.window_spectra import _bin_powers, welch_rows
from signatelec.measurement.ripple import hann


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 100, 128, 129, 255, 1000, 10000, 10001])
def test_pairwise_sum_is_numpy_s(n):
    """np.add.reduce's pairwise summation (eight running sums up to 128 values, halves cut at
    multiples of 8 beyond) to the last bit, on values spread over 12 decades, where a
    sequential sum differs; and the passes built on it: row means, line slopes, row sums."""
    rng = np.random.default_rng(n)
    a = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 6, n)
    assert pairwise_sum(a) == np.add.reduce(a)
    zeros = np.full(n, -0.0)  # the sign of a zero sum: +0, as numpy's
    assert math.copysign(1.0, pairwise_sum(zeros)) == math.copysign(1.0, np.add.reduce(zeros))
    if n < 16:
        return
    x = rng.standard_normal((3, n)) * 10.0 ** rng.uniform(-3, 3, (3, 1)) + 5.0
    tc = (np.arange(n) - 0.5 * (n - 1)) / 50000.0
    tcc = tc - tc.mean()
    denom = float(np.sum(tcc * tcc))
    level, slope = _line_fit(x, tcc, denom)
    assert np.array_equal(level, x.mean(axis=1))
    assert np.array_equal(slope, np.sum(tcc * (x - level[:, None]), axis=1) / denom)
    total, moment = _row_sums(x, tc)
    assert np.array_equal(total, x.sum(axis=1))
    assert np.array_equal(moment, (x * tc).sum(axis=1))
    assert np.array_equal(_centred(x), x - x.mean(axis=1, keepdims=True))


def test_line_fit_recovers_a_line():
    """A straight line a + b t is its own least-squares fit: level a (t centred), slope b, to
    round-off (sums of 10^4 terms: measured 5e-15 relative, 5e-14 allowed)."""
    n, fs = 10000, 50000.0
    tc = (np.arange(n) - 0.5 * (n - 1)) / fs
    tcc = tc - tc.mean()
    a, b = np.array([2.5e-3, -7.0]), np.array([0.4, 1e-3])
    level, slope = _line_fit(a[:, None] + b[:, None] * tc, tcc, float(np.sum(tcc * tcc)))
    assert level == pytest.approx(a, rel=5e-14)
    assert slope == pytest.approx(b, rel=5e-14)


@pytest.mark.parametrize("top", [9.0, 20.0, None])
def test_welch_is_scipy_s_and_white_noise_s(top):
    """The Welch density (Hann, half overlap, both arrays' rows of one segment length
    together) at its bins up to the first at or above ``top`` f_bp (None: every bin):
    scipy.signal.welch's estimate to 1e-13 relative (measured 1.5e-15), by the compiled DFT at
    those bins (9 f_bp: 38 bins of 4-pass segments) or, asked for more (20 f_bp, every bin),
    by pocketfft's transform of the segments; the power below the last bin df times the sum
    of scipy's density over them to 1e-13 (measured 7e-16); at even and odd lengths, with a
    large prime factor (538 = 2 x 269, 487) or none (480), down to segments of 3 and 4 samples.
    A row's numbers are those it gets alone, though the rows of its length ask for one bin more
    (409.7 and 409.9 Hz: 36 and 37 bins of 488); the same bits wherever the rows lie in memory.
    For white noise of variance s^2 the one-sided level 2 s^2 / fs (Parseval: the variance is
    the density's integral over [0, fs / 2]) within the estimate's scatter (~1 % for 2 rows
    averaged over ~40 segments; measured 1.7 % and 0.2 %, 5 % allowed)."""
    fs, n, sigma = 50000.0, 10000, 3e-3
    rng = np.random.default_rng(7)
    lengths = [488, 488, 667, 538, 487, 480, 4, 3]
    f_bp = 4 * fs / np.array(lengths, dtype=float)
    f_bp[:2] = 409.7, 409.9
    x = sigma * rng.standard_normal((len(lengths), n))
    y = rng.standard_normal((len(lengths), n)) + np.sin(2 * np.pi * 1234.0 * np.arange(n) / fs)
    groups = welch_rows((x, y), fs, f_bp, 4, top)
    assert sorted(tuple(rows) for rows, *_ in groups) == sorted(
        [(0, 1), (2,), (3,), (4,), (5,), (6,), (7,)]
    )
    for rows, freq, densities, powers in groups:
        nper = lengths[rows[0]]
        for arr, p, power in zip((x, y), densities, powers, strict=True):
            # a step of nper // 2 samples (half overlap, rounded down for an odd segment)
            ref_f, ref = signal.welch(
                arr[rows], fs, "hann", nperseg=nper, noverlap=nper - nper // 2, detrend=False
            )
            above = np.flatnonzero(ref_f >= (top or 0.0) * np.max(f_bp[rows]))
            kept = ref_f.size if top is None or not above.size else int(above[0]) + 1
            assert kept < ref_f.size or top is None or nper < 18
            assert np.array_equal(freq, ref_f[:kept])
            assert np.max(np.abs(p - ref[:, :kept]) / ref[:, :kept]) < 1e-13
            below = (fs / nper) * ref[:, :-1].sum(axis=1)
            assert np.max(np.abs(power - below) / below) < 1e-13
        if nper == 488:
            assert np.mean(densities[0][:, 1:]) == pytest.approx(2 * sigma**2 / fs, rel=0.05)
        for i, r in enumerate(rows):
            (_, f_alone, dens, pows), *_ = welch_rows(
                (x[r : r + 1], y[r : r + 1]), fs, f_bp[r : r + 1], 4, top
            )
            for a, b in zip(densities + powers, dens + pows, strict=True):
                assert np.array_equal(a[i, ..., : f_alone.size] if a.ndim == 2 else a[i], b[0])
    for shift in (1, 3):
        moved = [np.empty(a.size + shift)[shift:].reshape(a.shape) for a in (x, y)]
        for a, m in zip((x, y), moved, strict=True):
            m[...] = a
        again = welch_rows(tuple(moved), fs, f_bp, 4, top)
        for (_, _, dens, pows), (_, _, dens2, pows2) in zip(groups, again, strict=True):
            assert all(
                np.array_equal(a, b) for a, b in zip(dens + pows, dens2 + pows2, strict=True)
            )


@pytest.mark.parametrize("n", [3, 4, 5, 1999, 10000, 10001, 10002, 10003])
def test_search_powers_are_the_padded_transform_s(n):
    """The ball-pass search's power at its bins, by Goertzel's recursion in Reinsch's form,
    equals |rfft|^2 of the detrended, Hann-windowed row zero-padded to the search's length, at
    bins from 0 Hz through the first harmonic and pi / 2 (where the recursion changes form) to
    the last bin (pi): to 1e-10 of each bin's own power (measured 3e-12, on bins ~1e5 below the
    line), at lengths that are and are not multiples of the four samples a pass reads."""
    fs = 50000.0
    rng = np.random.default_rng(5)
    t = np.arange(n) / fs
    tc = t - t.mean()
    x = 1e-3 * (1.0 + 0.01 * np.sin(2 * np.pi * 410.0 * t) + 0.002 * rng.standard_normal((3, n)))
    level, slope = x.mean(axis=1), np.full(3, 1e-6)
    n_fft = sfft.next_fast_len(4 * n, real=True)
    line, quarter, last = int(410.0 * n_fft / fs), n_fft // 4, n_fft // 2
    bins = [0, 1, 2, 5, line, line + 1, 4 * line, quarter - 1, quarter, quarter + 1, last - 1]
    bins = np.unique(np.clip([*bins, last], 0, last))
    take = np.array([0, 2])
    power = np.empty((take.size, bins.size))
    _bin_powers(x, level, slope, tc, hann(n), take, 2.0 * np.pi * bins / n_fft, power)
    y = (x[take] - level[take, None] - slope[take, None] * tc) * hann(n)
    expected = np.abs(sfft.rfft(y, n_fft, axis=1)[:, bins]) ** 2
    assert np.max(np.abs(power - expected) / expected) < 1e-10


def test_search_of_a_long_trace_is_the_short_one_s(monkeypatch):
    """A trace whose search bands hold more bins than Goertzel's recursion forms cheaply (2 s
    at 50 kHz: ~750 bins, whose cost grows as n^2) goes to the padded transform of every bin:
    the same frequency and peak ratio as the recursion gives it, to round-off (measured 2e-13
    of the ratio)."""
    from signatelec.estimation import window_spectra
    from signatelec.estimation.analysis import _sample_times

    fs, n = 50000.0, 100000
    t = np.arange(n) / fs
    rng = np.random.default_rng(9)
    x = 1e-3 * (1.0 + 0.01 * np.sin(2 * np.pi * 409.0 * t) + 0.002 * rng.standard_normal(n))
    x = x[None]
    _, tc, tcc, denom = _sample_times(n, fs)
    level, slope = _line_fit(x, tcc, denom)
    f_exp = np.array([410.0])
    found = window_spectra.find_ball_pass(x, (level, slope, tc), fs, f_exp, 4, 0.01)
    monkeypatch.setattr(window_spectra, "GOERTZEL_BINS", math.inf)
    by_recursion = window_spectra.find_ball_pass(x, (level, slope, tc), fs, f_exp, 4, 0.01)
    assert found[0] == pytest.approx(by_recursion[0], rel=1e-12)
    assert found[1] == pytest.approx(by_recursion[1], rel=1e-10)
    assert found[0][0] == pytest.approx(409.0, abs=0.05)


def test_band_means_are_band_mean():
    """The compiled band means equal :func:`band_mean` bin for bin; bands holding no bin are
    left to it (NaN), as the analysis does."""
    rng = np.random.default_rng(3)
    f = np.linspace(0.0, 25000.0, 245)
    p = rng.random((4, 245)) * 10.0 ** rng.uniform(-3, 3, (4, 245))
    lo = rng.uniform(-200.0, 25500.0, (4, 6))
    hi = lo + rng.choice([1.0, 50.0, 3000.0], (4, 6))
    out = band_means(np.tile(f, 4), p.ravel(), np.arange(5) * f.size, lo, hi)
    empty = np.isnan(out)
    assert empty.any() and not empty.all()
    for w in range(4):
        for b in range(6):
            if not empty[w, b]:
                assert out[w, b] == band_mean(f, p[w], lo[w, b], hi[w, b])
            else:
                i, j = np.searchsorted(f, [lo[w, b], hi[w, b]])
                assert i == j


def test_unit_phasors():
    """exp(2 pi i f t) per row as (cos, sin) of the phase: numpy's complex exp of the
    imaginary phase bit for bit, on the unit circle to round-off, and the product of a block
    start and a within-block factor is the phasor at that sample."""
    n, fs = 10000, 50000.0
    tc = (np.arange(n) - 0.5 * (n - 1)) / fs
    f = np.array([409.7, 1234.5, 7.0])
    starts, within = phasor_factors(tc, f)
    block = within.shape[1]
    dt = tc[1] - tc[0]
    assert block == math.isqrt(n) and starts.shape[1] == -(-n // block)
    assert np.array_equal(
        within, np.exp(2j * math.pi * f[:, None] * (tc[0] + dt * np.arange(block)))
    )
    assert np.array_equal(
        starts, np.exp(2j * math.pi * f[:, None] * (dt * block * np.arange(starts.shape[1])))
    )
    assert np.max(np.abs(np.abs(within) - 1.0)) < 1e-15
    # on the grid tc[0] + i dt that the factors take (dt carries the ulp of tc[0], a phase
    # error of ~1e-10 rad against tc itself, which the harmonic tests bound), in extended
    # precision: the product's round-off at up to ~800 rad (measured 2.3e-13)
    grid = np.longdouble(tc[0]) + np.longdouble(dt) * np.arange(n, dtype=np.longdouble)
    phase = 2 * np.pi * f[:, None].astype(np.longdouble) * grid
    z = (starts[:, :, None] * within[:, None, :]).reshape(3, -1)[:, :n]
    assert np.max(np.abs(z.real - np.cos(phase)) + np.abs(z.imag - np.sin(phase))) < 1e-12


def test_windows_recover_known_harmonic_series():
    """Ten windows, each a known level, drift and four ball-pass harmonics at its own f_bp
    (within the search band of 500 rad/s), analysed together: each window's f_bp and
    amplitudes come back to what one Gauss-Newton step from the padded spectrum's peak leaves
    on a noise-free trace (~1e-6 f_bp, :func:`refine_frequency`; measured 6e-7 of f_bp, 7e-7
    of the summed amplitudes on the coefficients, 2e-7 on the level; 3e-6 allowed)."""
    from signatelec.physics.kinematics import expected_ball_pass_hz

    n, fs = 10000, 50000.0
    t = np.arange(n) / fs
    tc = t - 0.5 * (n - 1) / fs
    f0 = expected_ball_pass_hz(500.0)
    rng = np.random.default_rng(9)
    f = f0 * (1.0 + rng.uniform(-0.004, 0.004, 10))
    c = (rng.standard_normal((10, 4)) + 1j * rng.standard_normal((10, 4))) * 1e-4
    level, drift = 2.5e-3 + 1e-4 * rng.random(10), 1e-5 * rng.standard_normal(10)
    x = level[:, None] + drift[:, None] * tc
    for k in range(1, 5):
        x = x + np.real(c[:, k - 1, None] * np.exp(2j * np.pi * k * f[:, None] * tc))
    for w, a in enumerate(analyse_windows(x, fs, 500.0)):
        assert a.ball_pass_hz == pytest.approx(f[w], rel=3e-6)
        scale = np.abs(c[w]).sum()
        assert np.max(np.abs(a.coefficients - c[w])) < 3e-6 * scale
        assert a.level_ohm == pytest.approx(level[w], abs=3e-6 * scale)


def test_no_rows_and_no_harmonic_below_nyquist():
    """No windows give no analyses; a speed whose ball-pass frequency lies far above Nyquist
    finds no ripple at once (its candidate grid, at a step set by the highest harmonic below
    Nyquist, does not exist: it had been built at 1 Hz steps up to the expected frequency,
    12 GB at 1e11 rad/s)."""
    from signatelec.estimation.analysis import analyse_windows
    from signatelec.measurement.ripple import find_ripple

    assert analyse_windows(np.empty((0, 4000)), 20000.0, 500.0) == []
    trace = 1.0 + 0.01 * np.random.default_rng(0).standard_normal(4000)
    assert find_ripple(trace, 20000.0, 1e11).status == "none"
