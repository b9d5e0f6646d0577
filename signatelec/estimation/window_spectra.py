"""The spectra of a block of windows: the zero-padded ball-pass search and the Welch densities.

:func:`~signatelec.estimation.analysis.analyse_windows` reads every window's spectrum twice
over (the padded search spectrum, then the Welch segments of the detrended trace and of the
residual); they are most of its time. The search reads the padded spectrum at its few bins
only (~75 of 20001 for 0.2 s at 50 kHz), each formed by Goertzel's recursion
(:func:`_bin_powers`) where that costs less than the padded transform of every bin (up to
traces of ~1.5 s at 50 kHz: the bins grow with the length, :data:`GOERTZEL_BINS`). The
Welch densities are formed by a compiled DFT of each segment at the bins the features read
(:func:`_segment_power`), with the total power from Parseval's sum: scipy's estimate at those
bins to round-off, at a cost that does not depend on the segment length's factors.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numba import njit
from scipy import fft as sfft

from signatelec.measurement.ripple import PAD, hann, padded_power

#: Most bins of the ball-pass search per log2 of its padded length that Goertzel's recursion
#: forms (:func:`_bin_powers`, ~n a bin) before the padded transform of every bin (~n log n)
#: costs less: its bins grow with the trace (the +-1 % bands in bins of fs / 4n), ~75 for a
#: window of 0.2 s at 50 kHz and 500 rad/s (5 a log2), ~560 for 1.5 s (31 a log2). Measured
#: on one row, AMD EPYC without AVX-512, Goertzel against the transform: 0.2 s 0.26 and 0.43
#: ms, 1 s 3.0 and 4.5 ms, 1.5 s 6.4 and 7.3 ms, 2 s 11.4 and 9.7 ms, 4 s 44 and 18 ms.
GOERTZEL_BINS = 32
#: Largest DFT tables kept for the next block (a long trace's are not held).
_SCRATCH_BYTES = 8 << 20


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
    formed only at the bins the search reads (:func:`_bin_powers`), rows of one expected f_bp
    together.

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
        bins, at = np.unique(np.concatenate(columns), return_inverse=True)
        power = np.empty((rows.size, bins.size))
        if bins.size <= GOERTZEL_BINS * math.log2(n_fft):
            _bin_powers(x, *line, hann(n), rows, (2.0 * np.pi / n_fft) * bins, power)
        else:  # a long trace: its bins grow with it, the padded transform as n log n
            level, slope, tc = line
            for i, w in enumerate(rows):
                power[i] = padded_power(x[w] - level[w] - slope[w] * tc, fs)[0][bins]
        found[rows], ratio[rows] = _search_peaks(
            power[:, at],
            np.concatenate([np.flatnonzero(ok) for ok in oks]),
            np.concatenate(weights),
            np.array([w.size for w in weights]),
            cand,
            step,
        )
    return found, ratio


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def _bin_powers(x, level, slope, tc, window, take, omega, out) -> None:
    """out[i, b] = |sum_j y_j exp(-i omega[b] j)|^2, y = (x[w] - level[w] - slope[w] tc) window
    for the i-th row w of ``take``: the zero-padded DFT's power at the angles ``omega`` (2 pi
    bin / n_fft, in [0, pi]), by Goertzel's second-order recursion in Reinsch's form (Stoer and
    Bulirsch 2002, section 2.3.3), whose round-off stays ~n eps where the plain recursion's
    grows as ~n^2 eps near 0 and pi: d_j = d_{j-1} + y_j - lambda s_{j-1}, s_j = s_{j-1} + d_j
    with lambda = 4 sin^2(omega / 2) up to pi / 2, and beyond it e_j = y_j + mu s_{j-1} -
    e_{j-1}, s_j = e_j - s_{j-1} with mu = 4 cos^2(omega / 2) (one form: sigma = +-1 and
    kappa = lambda or -mu). Four samples a pass over the bins, so that each bin's state is
    loaded and stored once per four (measured: ~80 us a 0.2 s window at 50 kHz for ~50 bins,
    against ~190 us for the padded transform of 40000 points it replaces)."""
    n = x.shape[1]
    nb = omega.size
    sigma, kappa = np.empty(nb), np.empty(nb)
    for b in range(nb):
        if omega[b] <= 0.5 * math.pi:
            sigma[b], kappa[b] = 1.0, 4.0 * math.sin(0.5 * omega[b]) ** 2
        else:
            sigma[b], kappa[b] = -1.0, -4.0 * math.cos(0.5 * omega[b]) ** 2
    low = 0
    while low < nb and sigma[low] > 0.0:
        low += 1
    s, d = np.empty(nb), np.empty(nb)
    for i in range(take.size):
        w = take[i]
        lv, sl = level[w], slope[w]
        s[:] = 0.0
        d[:] = 0.0
        whole = n - n % 4
        for j in range(0, whole, 4):
            y0 = (x[w, j] - lv - sl * tc[j]) * window[j]
            y1 = (x[w, j + 1] - lv - sl * tc[j + 1]) * window[j + 1]
            y2 = (x[w, j + 2] - lv - sl * tc[j + 2]) * window[j + 2]
            y3 = (x[w, j + 3] - lv - sl * tc[j + 3]) * window[j + 3]
            # the bins up to pi / 2 (sigma = 1, a prefix of the ascending angles), then the
            # others (sigma = -1): the same operations as sigma * d + (...) and sigma * s + d,
            # to the bit, without the products by sigma
            for b in range(low):
                kp, sb, db = kappa[b], s[b], d[b]
                db = db + (y0 - kp * sb)
                sb = sb + db
                db = db + (y1 - kp * sb)
                sb = sb + db
                db = db + (y2 - kp * sb)
                sb = sb + db
                db = db + (y3 - kp * sb)
                sb = sb + db
                s[b], d[b] = sb, db
            for b in range(low, nb):
                kp, sb, db = kappa[b], s[b], d[b]
                db = (y0 - kp * sb) - db
                sb = db - sb
                db = (y1 - kp * sb) - db
                sb = db - sb
                db = (y2 - kp * sb) - db
                sb = db - sb
                db = (y3 - kp * sb) - db
                sb = db - sb
                s[b], d[b] = sb, db
        for j in range(whole, n):
            yj = (x[w, j] - lv - sl * tc[j]) * window[j]
            for b in range(nb):
                d[b] = sigma[b] * d[b] + (yj - kappa[b] * s[b])
                s[b] = sigma[b] * s[b] + d[b]
        for b in range(nb):
            # X e^(i omega (n - 1)) = s_{n-1} - e^(-i omega) s_{n-2}, s_{n-2} = sigma (s - d)
            c = math.cos(omega[b])
            re = 0.5 * kappa[b] * sigma[b] * s[b] + sigma[b] * c * d[b]
            im = math.sin(omega[b]) * sigma[b] * (s[b] - d[b])
            out[i, b] = re * re + im * im


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


@functools.lru_cache(maxsize=4)
def _periodic_hann(n: int) -> np.ndarray:
    """The periodic Hann window of ``n`` points (np.hanning(n + 1) less its last point), kept
    as :func:`~signatelec.measurement.ripple.hann` is (read-only)."""
    window = np.hanning(n + 1)[:-1] if n > 1 else np.ones(1)
    window.flags.writeable = False
    return window


#: Most bins the compiled DFT forms (:func:`_segment_power`, ~nb nper / 2 products a segment):
#: a group of windows needing more, or whose whole grid holds more, goes to pocketfft's
#: transform of the whole segment (~nper log nper, several times more at lengths with a large
#: prime factor). The features' bins at the defaults: (2 K + 1) x 4 + 2 = 38.
_DFT_MAX_BINS = 64


def _dft_tables(nper: int, bins: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of 2 pi k j / nper for each bin k of ``bins`` (rows) and j in [0, nper // 2]
    (the product k j reduced mod nper before it is scaled, so the angle keeps its digits),
    read-only; tables of at most :data:`_SCRATCH_BYTES` kept for the next block."""
    if 2 * 8 * len(bins) * (nper // 2 + 1) <= _SCRATCH_BYTES:
        return _kept_tables(nper, bins)
    return _tables_of(nper, bins)


@functools.lru_cache(maxsize=8)
def _kept_tables(nper: int, bins: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    return _tables_of(nper, bins)


def _tables_of(nper: int, bins: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    k = np.asarray(bins, dtype=np.int64)[:, None]
    j = np.arange(nper // 2 + 1, dtype=np.int64)[None, :]
    angle = (2.0 * np.pi / nper) * ((k * j) % nper)
    tables = np.cos(angle), np.sin(angle)
    for t in tables:
        t.flags.writeable = False
    return tables


@njit(cache=True, fastmath={"reassoc", "contract"}, error_model="numpy")
def _segment_power(x, z, step, window, cos_t, sin_t, power, squares) -> None:
    """Per row r of ``x`` and of ``z`` (a pair of arrays of one shape), over its segments of
    nper = window.size samples every ``step``: power[a, r, i] = the sum over segments of
    |X_k|^2, X the DFT of the windowed segment y of array a (0: ``x``, 1: ``z``) and k the bin
    of row i of the tables (:func:`_dft_tables`); squares[a, r] = the sum over segments of
    sum_j y_j^2 (Parseval's side).

    A real segment's DFT from its folded halves: Re X_k = sum_j (y_j + y_{nper-j}) cos and
    Im X_k = -sum_j (y_j - y_{nper-j}) sin over j <= nper / 2, half the products of the DFT's
    definition, and only the bins asked for; the two arrays' sums share each pass over the
    tables, which forms two bins at once (one load of the halves for eight products: measured
    ~180 us a 0.2 s window at 50 kHz, against ~230 us a bin at a time and 260 us for the arrays
    one after the other; four bins at once spill registers and cost as one). Its cost grows
    with nper alone, where pocketfft's grows with nper's largest prime factor (a segment of
    538 = 2 x 269 samples cost 10x one of 480, measured). Each bin is formed by the same loop,
    to the bit whichever bin it is paired with, whatever the other bins and rows are, so a
    row's numbers do not depend on the rows analysed with it. Its round-off is that of a sum
    of nper / 2 products, ~1e-16 of the segment's energy: a bin far below the others (a
    noise-free ripple's) carries it relative to itself, more than pocketfft's (measured: 8e-9
    of ``psd_high_rel`` on a noise-free trace; 1e-15 at a 0.05 % noise floor)."""
    rows, n = x.shape
    nper = window.size
    half = nper // 2
    pairs = half if nper % 2 else half - 1  # j in [1, pairs] pairs with nper - j
    nb = cos_t.shape[0]
    segments = (n - nper) // step + 1
    even, odd = np.zeros((2, half + 1)), np.zeros((2, half + 1))
    for r in range(rows):
        power[:, r, :] = 0.0
        total = np.zeros(2)
        for s in range(segments):
            b = s * step
            for a in range(2):
                y = x if a == 0 else z
                even[a, 0] = y[r, b] * window[0]
                for j in range(1, pairs + 1):
                    lo = y[r, b + j] * window[j]
                    hi = y[r, b + nper - j] * window[nper - j]
                    even[a, j] = lo + hi
                    odd[a, j] = lo - hi
                if nper % 2 == 0 and nper > 1:
                    even[a, half] = y[r, b + half] * window[half]
                # sum_j y_j^2 = y_0^2 (+ y_half^2) + sum over pairs of (even^2 + odd^2) / 2,
                # in a loop apart that only reads: summed in the loop that writes the halves,
                # its last bits changed from one call to the next with the rows' addresses
                # (measured; a run-time overlap check choosing the vectorised loop or not)
                sq = 0.0
                for j in range(1, pairs + 1):
                    sq += even[a, j] * even[a, j] + odd[a, j] * odd[a, j]
                sq = 0.5 * sq + even[a, 0] * even[a, 0]
                if nper % 2 == 0 and nper > 1:
                    sq += even[a, half] * even[a, half]
                total[a] += sq
            ex, ox, ez, oz = even[0], odd[0], even[1], odd[1]
            for p in range(0, nb, 2):
                # two bins a pass, so that each half is loaded once for both (the last bin
                # of an odd count is paired with itself: every bin by this same loop)
                i, k = p, min(p + 1, nb - 1)
                rx_i = ix_i = rz_i = iz_i = rx_k = ix_k = rz_k = iz_k = 0.0
                for j in range(half + 1):
                    c_i, s_i, c_k, s_k = cos_t[i, j], sin_t[i, j], cos_t[k, j], sin_t[k, j]
                    e_x, o_x, e_z, o_z = ex[j], ox[j], ez[j], oz[j]
                    rx_i += e_x * c_i
                    ix_i += o_x * s_i
                    rz_i += e_z * c_i
                    iz_i += o_z * s_i
                    rx_k += e_x * c_k
                    ix_k += o_x * s_k
                    rz_k += e_z * c_k
                    iz_k += o_z * s_k
                power[0, r, i] += rx_i * rx_i + ix_i * ix_i
                power[1, r, i] += rz_i * rz_i + iz_i * iz_i
                if k > i:
                    power[0, r, k] += rx_k * rx_k + ix_k * ix_k
                    power[1, r, k] += rz_k * rz_k + iz_k * iz_k
        squares[0, r], squares[1, r] = total[0], total[1]


def _welch(xs: tuple, fs: float, nper: int, top_hz: float | None, dft: bool) -> tuple:
    """One-sided Welch density (Hann, half overlap) of each row of each of the two arrays
    ``xs`` (rows of one length), segments of ``nper`` samples (:func:`welch_rows`), at its bins
    from 0 Hz up to the first at or above ``top_hz`` (every bin when it is None or beyond the
    last; bin 0 when it is not > 0); and each row's power below the last bin, df times the sum
    of the density over every bin but the last (the density's integral over [0, f_last) as
    :func:`~signatelec.estimation.analysis.band_power` reads it).

    ``dft``: the compiled DFT at those bins (:func:`_segment_power`), the power below the last
    bin from Parseval's sum less the last bin when the grid is cut, else the bins' sum (a
    Nyquist line holding most of the power would cancel); otherwise pocketfft's transform of
    every segment. ``scipy.signal.welch(..., detrend=False)``'s estimate at those bins, to
    round-off. Returns (frequencies, [density per array], [power per array]).
    """
    step = max(nper // 2, 1)
    win = _periodic_hann(nper)
    scale = fs * float(win @ win)
    df = fs / nper
    rows, n = xs[0].shape
    segments = (n - nper) // step + 1
    freq = sfft.rfftfreq(nper, 1.0 / fs)
    last = freq.size - 1
    top = last if top_hz is None else min(last, int(freq.searchsorted(max(top_hz, 0.0))))
    if dft:
        bins = tuple(range(top + 1)) + ((last,) if last > top else ())
        cos_t, sin_t = _dft_tables(nper, bins)
    else:
        bins = tuple(range(last + 1))
    doubled = np.array([0 < k and (k < last or nper % 2 == 1) for k in bins])
    if dft:
        pair_power, pair_squares = np.empty((2, rows, len(bins))), np.empty((2, rows))
        _segment_power(*xs, step, win, cos_t, sin_t, pair_power, pair_squares)
    densities, powers = [], []
    for a, x in enumerate(xs):
        if dft:
            power, squares = pair_power[a], pair_squares[a]
        else:
            seg = np.lib.stride_tricks.sliding_window_view(x, nper, axis=1)[:, ::step][:, :segments]
            power = np.add.reduce(np.abs(sfft.rfft(seg * win, axis=2)) ** 2, axis=1)
        p = power / segments / scale
        p[:, doubled] *= 2.0
        if p.shape[1] < last + 1:  # the grid cut: Parseval's sum less the last bin
            below = squares / segments * nper / scale - p[:, -1]
        else:
            below = np.add.reduce(p[:, :last], axis=1)
        densities.append(p[:, : top + 1])
        powers.append(df * below)
    return freq[: top + 1], densities, powers


def welch_rows(xs: tuple, fs: float, f_bp, passes: int, top: float | None) -> list[tuple]:
    """The Welch densities of the rows of each of the two arrays ``xs`` (the detrended trace
    and the residual) by :func:`_welch`, rows of one segment length together, up to ``top``
    f_bp (the rows' largest; None: every bin): (rows, freq, [density of those rows of each
    array], [their power below the last bin]) per length.
    The compiled DFT forms them when the bins asked for are few enough, decided by the segment
    length, ``top`` and ``passes`` alone (not by the other rows, so a row's numbers are those
    it gets alone)."""
    n = xs[0].shape[1]
    nper = np.array([max(1, min(int(round(passes * fs / f)) if f > 0 else n, n)) for f in f_bp])
    few = top is not None and top * passes + 3 <= _DFT_MAX_BINS
    groups = []
    for length in np.unique(nper):
        rows = np.flatnonzero(nper == length)
        top_hz = None if top is None else top * float(np.max(f_bp[rows]))
        dft = few or int(length) // 2 + 1 <= _DFT_MAX_BINS
        parts = tuple(take_rows(x, rows) for x in xs)
        groups.append((rows, *_welch(parts, fs, int(length), top_hz, dft)))
    return groups
