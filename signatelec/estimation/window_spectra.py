"""The spectra of a block of windows: the zero-padded ball-pass search and the Welch densities.

:func:`~signatelec.estimation.analysis.analyse_windows` transforms every window of a block
twice over (the padded search spectrum, then the Welch segments of the detrended trace and of
the residual); the transforms are most of its time. Here the rows go to pocketfft in batches
whose inputs are written by compiled passes into buffers kept for the next block, and what is
read from the spectra (the power at the search's bins, the mean over segments) is formed in
compiled passes: the same numbers as the numpy forms, bit for bit.
"""

from __future__ import annotations

import functools
import math
import threading

import numpy as np
from numba import njit
from scipy import fft as sfft

from signatelec.measurement.ripple import PAD, hann

#: Bytes of windowed Welch segments transformed at once: a block of windows is transformed in
#: pieces written into a buffer kept for the next block (:func:`_segment_buffer`); fresh
#: arrays for all the segments of 10 windows at once cost ~2x the same in pieces of 256 kB
#: (their pages faulted in on every block), a kept buffer of 1 MB ~5 % less than 256 kB
#: pieces (measured, pocketfft through scipy 1.17).
_TRANSFORM_BYTES = 1 << 20
#: Rows of the zero-padded search spectrum (:func:`find_ball_pass`) transformed in one call.
#: pocketfft vectorises a transform over rows (SIMD lanes across rows, the same operations
#: per row, the same numbers): at 40000 points ~95 us a row from 5 rows at once up to 32,
#: against ~170 us for one row alone (1-D) and 300-500 us for 2-4 rows of a 2-D call
#: (measured, scipy 1.17, AVX-512).
_PAD_ROWS = 16
_PAD_MIN_ROWS = 5
#: Largest padded buffer kept for the next call (a long trace's is not held).
_SCRATCH_BYTES = 8 << 20


def _pieces(rows: int, row_bytes: int) -> list[slice]:
    """Slices of ``rows`` rows of ``row_bytes`` each whose transforms fit
    :data:`_TRANSFORM_BYTES`."""
    step = max(1, _TRANSFORM_BYTES // max(row_bytes, 1))
    return [slice(i, i + step) for i in range(0, rows, step)]


def take_rows(x: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """x[idx] for ascending rows ``idx``, without the copy when they are all of x's rows (a
    block's windows mostly share their harmonics and segment length)."""
    return x if idx.size == x.shape[0] else x[idx]


@njit(cache=True, error_model="numpy")
def sorted_select(s: np.ndarray, q: float) -> float:
    """np.percentile (linear) of ``s`` sorted, ``q`` in [0, 1]: numpy's interpolation (from
    the nearer neighbour when the weight exceeds 1/2); q = 1/2 is np.median's value."""
    n = s.size
    if q == 0.5:
        h = n // 2
        return s[h] if n % 2 else (s[h - 1] + s[h]) / 2.0
    v = q * (n - 1)
    i = int(math.floor(v))
    j = min(i + 1, n - 1)
    g = v - i
    a, b = s[i], s[j]
    return b - (b - a) * (1.0 - g) if g >= 0.5 else a + (b - a) * g


def find_ball_pass(
    x: np.ndarray,
    line: tuple[np.ndarray, np.ndarray, np.ndarray],
    fs: float,
    f_exp: np.ndarray,
    n_harmonics: int,
    search_rel: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Per row of ``x`` less its ``line`` (level, slope per row, times tc), f_bp maximising the
    summed power of its harmonics in the zero-padded Hann spectrum of the sanity layer's
    :func:`~signatelec.measurement.ripple.padded_power` (bin width ``df``); the power |X|^2
    taken only at the bins the search reads (~70 of 20001 for 0.2 s at 50 kHz), rows of one
    expected f_bp together.

    Returns (frequencies, peak-to-median ratios of the harmonic sum over the search band);
    rows whose expected f_bp is not > 0 keep it, with ratio 1. The sum over harmonics keeps
    the search on f_bp where the first harmonic vanishes (comb zeros). The power between bins
    is np.interp's straight line (the same operations, on a grid of unit step).
    """
    n = x.shape[1]
    duration = n / fs
    n_fft = sfft.next_fast_len(PAD * n, real=True)
    df = fs / n_fft
    last = n_fft // 2  # the transform's last bin: beyond it np.interp holds its value
    found, ratio = np.array(f_exp, dtype=float), np.ones(len(f_exp))
    padded = _padded_buffer(min(x.shape[0], _PAD_ROWS), n, n_fft)
    for f0 in np.unique(f_exp[f_exp > 0.0]):
        rows = np.flatnonzero(f_exp == f0)
        step = min(1.0 / (8.0 * duration * n_harmonics), 1e-3 * f0)
        lo, hi = f0 * (1.0 - search_rel), f0 * (1.0 + search_rel)
        cand = np.arange(lo, hi + step, step)
        oks, weights, columns = [], [], []
        for k in range(1, n_harmonics + 1):
            fk = k * cand
            oks.append(fk < 0.5 * fs)
            pos = fk[oks[-1]] / df
            j = np.minimum(np.floor(pos).astype(int), last)
            weights.append(pos - j)
            columns += [j, np.minimum(j + 1, last)]
        columns = np.concatenate(columns)
        power = np.empty((rows.size, columns.size))
        for part in range(0, rows.size, _PAD_ROWS):
            take = rows[part : part + _PAD_ROWS]
            if take.size >= _PAD_MIN_ROWS:
                _windowed(x, *line, hann(n), take, padded)
                spectra = sfft.rfft(padded[: take.size], axis=1)
                power[part : part + take.size] = np.abs(spectra[:, columns]) ** 2
                continue
            for i in range(take.size):
                _windowed(x, *line, hann(n), take[i : i + 1], padded)
                power[part + i] = np.abs(sfft.rfft(padded[0])[columns]) ** 2
        found[rows], ratio[rows] = _search_peaks(
            power,
            np.concatenate([np.flatnonzero(ok) for ok in oks]),
            np.concatenate(weights),
            np.array([w.size for w in weights]),
            cand,
            step,
        )
    return found, ratio


@njit(cache=True, error_model="numpy")
def _windowed(x, level, slope, tc, window, take, out) -> None:
    """out[i, :n] = (x[w] - level[w] - slope[w] tc) window for the i-th row w of ``take``: the
    detrended rows windowed into the padded buffer in one pass (the same numbers as the
    detrended rows times the window)."""
    for i in range(take.size):
        w = take[i]
        for j in range(x.shape[1]):
            out[i, j] = (x[w, j] - level[w] - slope[w] * tc[j]) * window[j]


@njit(cache=True, error_model="numpy")
def _search_peaks(power, at_candidate, weights, sizes, cand, step):
    """Per row of ``power`` (|X|^2 at the bins below and above each harmonic's candidates, by
    harmonic), the summed harmonic power at the candidates (the straight line between the two
    bins, ``weights`` of the upper), its peak refined by a parabola through the neighbours, and
    the peak-to-median ratio: the (frequency, ratio) of :func:`find_ball_pass`."""
    rows = power.shape[0]
    found, ratio = np.empty(rows), np.empty(rows)
    total = np.empty(cand.size)
    for w in range(rows):
        total[:] = 0.0
        col = off = 0
        for m in sizes:
            for q in range(m):
                below, above = power[w, col + q], power[w, col + m + q]
                total[at_candidate[off + q]] += (above - below) * weights[off + q] + below
            col += 2 * m
            off += m
        i = np.argmax(total)
        med = sorted_select(np.sort(total), 0.5)
        f = cand[i]
        if 0 < i < cand.size - 1:
            a, b, c = total[i - 1], total[i], total[i + 1]
            den = a - 2.0 * b + c
            if den < 0.0:
                f += step * min(max(0.5 * (a - c) / den, -0.5), 0.5)
        found[w], ratio[w] = f, total[i] / med if med > 0 else 1.0
    return found, ratio


_scratch = threading.local()


def _padded_buffer(rows: int, n: int, n_fft: int) -> np.ndarray:
    """A (>= rows, n_fft) array whose columns from ``n`` on are 0, kept per thread for the next
    block when at most :data:`_SCRATCH_BYTES`: a fresh one (3 MB for 10 windows of 0.2 s at
    50 kHz) faulted its pages in on every block, ~1.5 ms of a block's ~10 ms (measured)."""
    buf, filled = getattr(_scratch, "padded", None), getattr(_scratch, "filled", 0)
    if buf is None or buf.shape[0] < rows or buf.shape[1] != n_fft:
        buf, filled = np.zeros((rows, n_fft)), 0
    elif filled > n:
        buf[:, n:filled] = 0.0
    if buf.nbytes <= _SCRATCH_BYTES:
        _scratch.padded, _scratch.filled = buf, n
    return buf


@functools.lru_cache(maxsize=4)
def _periodic_hann(n: int) -> np.ndarray:
    """The periodic Hann window of ``n`` points (np.hanning(n + 1) less its last point), kept
    as :func:`~signatelec.measurement.ripple.hann` is (read-only)."""
    window = np.hanning(n + 1)[:-1] if n > 1 else np.ones(1)
    window.flags.writeable = False
    return window


@njit(cache=True, error_model="numpy")
def _mean_square(a: np.ndarray, scale: float, out: np.ndarray) -> None:
    """out[r] = mean over segments of a[r] ** 2 (a: rows, segments, bins) divided by ``scale``,
    in one pass without the numpy form's two temporaries. The segments are added one after the
    other, as numpy's mean over a non-contiguous axis adds them: the same numbers as
    ``np.mean(a ** 2, axis=1) / scale``."""
    rows, segs, bins = a.shape
    for r in range(rows):
        for j in range(bins):
            v = a[r, 0, j]
            out[r, j] = v * v
        for k in range(1, segs):
            for j in range(bins):
                v = a[r, k, j]
                out[r, j] += v * v
        for j in range(bins):
            out[r, j] = out[r, j] / segs / scale


def _welch(xs: tuple, fs: float, nper: int) -> tuple[np.ndarray, list[np.ndarray]]:
    """One-sided Welch density (Hann, half overlap) of each row of each array of ``xs`` (rows of
    one length), segments of ``nper`` samples (:func:`welch_rows`: ``passes`` ball passes).

    The same estimate as ``scipy.signal.welch(..., detrend=False)``, with the segments
    transformed in batches of rows (a 1 s trace at 50 kHz has ~200 of them).
    """
    step = max(nper // 2, 1)
    win = _periodic_hann(nper)
    scale = fs * float(win @ win)
    rows, n = xs[0].shape
    segments = (n - nper) // step + 1
    pieces = _pieces(rows, segments * nper * 8)
    buf = _segment_buffer(min(rows, pieces[0].stop), segments, nper)
    out = []
    for x in xs:
        p = np.empty((rows, nper // 2 + 1))
        for part in pieces:
            k = len(range(rows)[part])
            _windowed_segments(x[part], step, win, buf[:k])
            _mean_square(np.abs(sfft.rfft(buf[:k], axis=2)), scale, p[part])
        p[:, 1 : (None if nper % 2 else -1)] *= 2.0
        out.append(p)
    return sfft.rfftfreq(nper, 1.0 / fs), out


@njit(cache=True, error_model="numpy")
def _windowed_segments(x: np.ndarray, step: int, window: np.ndarray, out: np.ndarray) -> None:
    """out[r, k] = x[r, k step : k step + nper] window (nper = window.size): the windowed
    segments of each row, written in one pass into a buffer kept for the next block."""
    nper = window.size
    for r in range(out.shape[0]):
        for k in range(out.shape[1]):
            for j in range(nper):
                out[r, k, j] = x[r, k * step + j] * window[j]


def _segment_buffer(rows: int, segments: int, nper: int) -> np.ndarray:
    """A (rows, segments, nper) array for :func:`_windowed_segments`, kept per thread for the
    next block of the same shape when at most :data:`_SCRATCH_BYTES` (as
    :func:`_padded_buffer`)."""
    buf = getattr(_scratch, "segments", None)
    if buf is None or buf.shape != (rows, segments, nper):
        buf = np.empty((rows, segments, nper))
        if buf.nbytes <= _SCRATCH_BYTES:
            _scratch.segments = buf
    return buf


def welch_rows(xs: tuple, fs: float, f_bp: np.ndarray, passes: int) -> list[tuple]:
    """The Welch densities of the rows of each array of ``xs`` by :func:`_welch`, rows of one
    segment length together: (rows, freq, [density of those rows of each array]) per length."""
    n = xs[0].shape[1]
    nper = np.array([max(1, min(int(round(passes * fs / f)) if f > 0 else n, n)) for f in f_bp])
    groups = []
    for length in np.unique(nper):
        rows = np.flatnonzero(nper == length)
        groups.append((rows, *_welch(tuple(take_rows(x, rows) for x in xs), fs, int(length))))
    return groups
