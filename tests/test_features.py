"""Features of a resistance trace: invariance, physics, the transformer twins.

Invariance: one continuous signal (the quasi-static tier's steady resistance at 200 kHz, band-
limited by the measurement model's anti-alias filter to 20 and 50 kHz) gives the same features
at either rate and for 50 or 200 ms, except those that by design measure how well the trace
determines the rest (:data:`signatelec.estimation.features.LENGTH_DEPENDENT`) and the noise
features,
checked on added white noise instead: per-sample ones for the same per-sample noise, density
ones for the same density.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from signatelec.config.bearing import Bearing
from signatelec.estimation import features as F
from signatelec.estimation import transformers as T
from signatelec.estimation.analysis import analyse_trace

#: Features of the signal itself (the ripple and the level), compared on the noise-free trace.
SIGNAL_FEATURES = (
    [n for n in F.level_feature_names() if n != "level_drift_rel_per_s"]
    + ["psd_h1_rel", "psd_h2_rel", "psd_h3_rel", "psd_h4_rel", "psd_high_rel", "psd_total_rel"]
    + ["omega_rad_s", "ball_pass_expected_hz", "ball_pass_found_hz"]
    + [n for n in F.harmonic_feature_names() if "_odd_" not in n]
    + F.ripple_feature_names()
)
#: Per-sample noise features (invariant for the same noise per sample).
PER_SAMPLE_NOISE = ("noise_rms_rel", "noise_mad_rel", "noise_white_rel", "level_mad_rel")


@pytest.fixture(scope="module")
def clean_signal():
    """The same signal at 20 and 50 kHz: {rate: resistance over 0.2 s}."""
    from signatelec.config.scene import Scene
    from signatelec.engines.simulate import simulate
    from signatelec.measurement.model import MeasurementModel

    scene = Scene().with_overrides(
        radial_load_n=7000.0,
        clearance_m=8e-6,
        duration_s=0.007 + 0.215,
        sample_rate_hz=200000.0,
        fidelity="quasistatic",
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = simulate(scene).steady()
    t, r = st["time_s"].to_numpy(), st["resistance_ohm"].to_numpy()
    return {
        fs: MeasurementModel(sample_rate_hz=fs).clean(t, r, t[0] + 0.005, int(0.2 * fs))
        for fs in (20000.0, 50000.0)
    }


def _features(signal, fs, length_s, noise=None):
    r = signal[fs][: int(round(length_s * fs))]
    if noise is not None:
        r = r + noise(fs, r.size)
    return F.trace_features(r, fs, 500.0)


def _close(a: float, b: float, name: str, level: float) -> bool:
    """Within 2 % of the larger value, or an absolute floor for values near 0: 0.02 in log10
    (band powers), 2e-7 of the level (amplitudes), 0.02 for shape statistics."""
    if name.startswith("psd_"):
        floor = 0.02
    elif name.endswith("_ohm"):
        floor = 2e-7 * level
    elif name.startswith(("ripple_", "fold_", "raw_")) and not name.endswith("_rel"):
        floor = 0.02
    else:
        floor = 2e-7
    return abs(a - b) <= max(0.02 * max(abs(a), abs(b)), floor)


def test_rate_and_length_invariance(clean_signal):
    cases = [(fs, length) for fs in (20000.0, 50000.0) for length in (0.05, 0.2)]
    feats = {case: _features(clean_signal, *case) for case in cases}
    ref = feats[(20000.0, 0.05)]
    level = ref["level_mean_ohm"]
    for case, f in feats.items():
        bad = [(n, ref[n], f[n]) for n in SIGNAL_FEATURES if not _close(ref[n], f[n], n, level)]
        assert not bad, f"{case}: {bad}"
    # the length-dependent ones grow with the length, as they should
    assert feats[(20000.0, 0.2)]["duration_ball_passes"] == pytest.approx(
        4 * ref["duration_ball_passes"], rel=1e-3
    )


def test_ball_pass_frequency_found(clean_signal):
    f = _features(clean_signal, 20000.0, 0.05)
    # the quasi-static tier turns the cage at the kinematic speed: no slip
    assert abs(f["ball_pass_slip"]) < 1e-4
    assert f["ball_pass_expected_hz"] == pytest.approx(Bearing().ball_pass_frequency_hz(500.0))


def test_per_sample_noise_invariance(clean_signal):
    """White noise of the same std per sample: per-sample noise features agree."""
    sigma = 0.002 * 2.5e-3

    def noise(fs, n):
        return np.random.default_rng(int(fs)).normal(0.0, sigma, n)

    a = _features(clean_signal, 20000.0, 0.2, noise)
    b = _features(clean_signal, 50000.0, 0.05, noise)
    for name in PER_SAMPLE_NOISE:
        # 2500-4000 samples: the MAD scatters by ~2.5 %
        assert a[name] == pytest.approx(b[name], rel=0.08), name
    assert a["noise_rms_rel"] == pytest.approx(sigma / a["level_mean_ohm"], rel=0.06)


def test_noise_density_invariance(clean_signal):
    """White noise of the same density (std ~ sqrt(fs)): the density feature agrees, and the
    debiased harmonic amplitudes stay within their noise of the noise-free ones."""
    density = (0.002 * 2.5e-3) ** 2 / 10000.0  # ohm^2/Hz one-sided, 0.2 % per sample at 20 kHz

    def noise(fs, n):
        return np.random.default_rng(int(fs) + 1).normal(0.0, np.sqrt(density * fs / 2.0), n)

    a = _features(clean_signal, 20000.0, 0.2, noise)
    b = _features(clean_signal, 50000.0, 0.2, noise)
    assert a["noise_density_rel"] == pytest.approx(b["noise_density_rel"], abs=0.1)
    ref = _features(clean_signal, 20000.0, 0.2)
    sd = np.sqrt(density / 0.2) / ref["level_mean_ohm"]  # std of a coefficient, relative
    for f in (a, b):
        assert abs(f["h1_rel"] - ref["h1_rel"]) < 4 * sd
        assert abs(f["h2_rel"] - ref["h2_rel"]) < 4 * sd


def test_debiased_amplitudes():
    """E|c|^2 = |c|^2 + 2 S / T: a second harmonic of 1e-4 of the level under 0.15 % noise
    (50 ms): the raw fit nearly doubles its power, the debiased one much less."""
    fs, f0 = 20000.0, Bearing().ball_pass_frequency_hz(500.0)
    t = np.arange(1000) / fs
    clean = 1e-3 * (1.0 + 1e-3 * np.cos(2 * np.pi * f0 * t) + 1e-4 * np.cos(4 * np.pi * f0 * t))
    rng = np.random.default_rng(3)
    debiased, raw = [], []
    for _ in range(200):
        a = analyse_trace(clean + rng.normal(0, 1.5e-6, t.size), fs, 500.0)
        debiased.append(F.harmonic_features(None, analysis=a)["h2_rel"] ** 2)
        raw.append((abs(a.coefficients[1]) / a.level_ohm) ** 2)
    bias_raw = np.mean(raw) / 1e-8 - 1.0
    bias_debiased = np.mean(debiased) / 1e-8 - 1.0
    assert bias_raw > 0.6
    # what is left is the clipping at 0 of draws below the bias
    assert abs(bias_debiased) < 0.5 * bias_raw


def test_synthetic_harmonics_and_slip():
    """Known harmonics, a 1 % slow cage: amplitudes, even parts and slip come back."""
    fs = 50000.0
    f0 = 0.99 * Bearing().ball_pass_frequency_hz(600.0)
    t = np.arange(int(0.1 * fs)) / fs
    level = 2e-3
    r = level * (
        1.0
        + 1e-3 * np.cos(2 * np.pi * f0 * t + 0.7)
        - 2e-4 * np.cos(2 * np.pi * 2 * f0 * t + 1.4)
        + 5e-5 * np.cos(2 * np.pi * 3 * f0 * t + 2.1)
    )
    f = F.trace_features(r, fs, 600.0)
    assert f["ball_pass_slip"] == pytest.approx(-0.01, abs=1e-5)
    assert f["h1_rel"] == pytest.approx(1e-3, rel=1e-3)
    assert f["h2_rel"] == pytest.approx(2e-4, rel=1e-3)
    assert f["h2_even_rel"] == pytest.approx(-2e-4, rel=1e-3)  # a dip where harmonic 1 peaks
    assert f["h3_even_rel"] == pytest.approx(5e-5, rel=1e-2)
    assert abs(f["h2_odd_rel"]) < 1e-7
    assert f["level_mean_ohm"] == pytest.approx(level, rel=1e-6)
    assert f["ripple_skew"] < 0.0  # sharp dips


def test_twins_match_transformers():
    fs = 20000.0
    rng = np.random.default_rng(0)
    t = np.arange(1000) / fs
    f0 = Bearing().ball_pass_frequency_hz(500.0)
    X = np.stack(
        [
            3e-3 * (1 + 1e-3 * np.cos(2 * np.pi * f0 * t + p)) + rng.normal(0, 3e-6, t.size)
            for p in (0.0, 1.0, 2.0)
        ]
    )
    for transformer, function in zip(
        T.TRANSFORMERS[:-1],
        (
            F.level_features,
            F.spectrum_features,
            F.ball_pass_features,
            F.harmonic_features,
            F.noise_features,
            F.ripple_features,
        ),
        strict=True,
    ):
        tr = transformer(sample_rate_hz=fs, omega_rad_s=500.0).fit(X)
        out = tr.transform(X)
        names = list(tr.get_feature_names_out())
        for i, row in enumerate(X):
            d = function(row, fs, 500.0)
            assert list(d) == names
            np.testing.assert_allclose(out[i], [d[n] for n in names], rtol=1e-12, atol=0)
    whole = T.TraceFeatures(sample_rate_hz=fs, omega_rad_s=500.0).fit_transform(X)
    assert whole.shape == (3, len(F.trace_feature_names()))


@pytest.mark.validation
@pytest.mark.parametrize("fraction", [0.1, 0.4])
def test_first_harmonic_at_zero_clearance(fraction):
    """Quasi-static tier at zero clearance: the first harmonic is 0.123-0.126 % of the level
    from 0.1 to 0.4 C_r (the ripple follows the load zone, not the load)."""
    from signatelec.config.scene import Scene
    from signatelec.engines.simulate import simulate

    scene = Scene().with_overrides(
        radial_load_n=fraction * 29100.0, duration_s=0.007 + 0.06, fidelity="quasistatic"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        st = simulate(scene).steady()
    f = F.trace_features(st["resistance_ohm"].to_numpy(), 20000.0, 500.0)
    assert 1.20e-3 < f["h1_rel"] < 1.29e-3


def test_windows_analysed_together_equal_one_by_one(clean_signal):
    """The monitor's batch of windows (one transform and one set of least-squares products
    for all) gives each window the features ``estimate`` gives it alone: consecutive 20 ms
    windows of the 50 kHz signal with 0.2 % noise, each at its own speed (one 1 % off, so that
    its ball-pass search and Welch segments differ), and a noise-free one. Round-off only:
    measured equal to the last bit; 1e-9 relative allowed (features are read by trees whose
    thresholds sit at float32 values of the training table)."""
    from signatelec.estimation.analysis import analyse_windows

    fs = 50000.0
    r = clean_signal[fs]
    rng = np.random.default_rng(7)
    n = int(0.02 * fs)
    rows = r[: 6 * n].reshape(6, n).copy()
    rows[:5] *= 1.0 + 0.002 * rng.standard_normal((5, n))
    omegas = np.array([500.0, 500.0, 505.0, 500.0, 500.0, 500.0])
    analyses = analyse_windows(rows, fs, omegas)
    together = [F.trace_features(None, analysis=a) for a in analyses]
    table = F.window_features(analyses)
    assert table.shape == (len(rows), len(F.trace_feature_names()))
    for row, omega, batch, measured in zip(rows, omegas, together, table, strict=True):
        alone = F.trace_features(row, fs, omega)
        assert list(batch) == list(alone)
        for name, value in alone.items():
            assert batch[name] == pytest.approx(value, rel=1e-9, abs=1e-300), name
        # the features of the batch measured together: the same bits as the window alone
        assert measured.tolist() == list(batch.values())


def test_what_no_feature_asked_for_is_left_out(clean_signal):
    """The analysis computes what only some features read when they are asked for: the
    residual's MAD (one sort per row) for ``noise_mad_rel``, the fold at f_bp for the fold
    features; the model's features ask for neither. Without them those features are NaN and
    every other is the full analysis's, to the bit."""
    from signatelec.estimation.analysis import analyse_windows
    from signatelec.estimation.training import model_features

    fs = 50000.0
    n = int(0.05 * fs)
    rows = clean_signal[fs][: 4 * n].reshape(4, n)
    rows = rows * (1.0 + 0.002 * np.random.default_rng(5).standard_normal(rows.shape))
    names = F.trace_feature_names()
    assert F.analysis_options(names) == {"residual_mad": True, "fold": True}
    options = F.analysis_options(model_features())
    assert options == {"residual_mad": False, "fold": False}
    full = F.window_features(analyse_windows(rows, fs, 500.0))
    lean = F.window_features(analyse_windows(rows, fs, 500.0, **options))
    left_out = [names.index(c) for c in ("noise_mad_rel", *F.FOLDED)]
    kept = [i for i in range(len(names)) if i not in left_out]
    assert np.isnan(lean[:, left_out]).all() and np.isfinite(full[:, left_out]).all()
    assert lean[:, kept].tobytes() == full[:, kept].tobytes()


def test_analysis_does_not_depend_on_the_one_before(clean_signal):
    """What the analysis keeps from one call to the next (the Hann windows and DFT tables of a
    length) does not touch a window's numbers: a window of 1998 samples (padded to 8000 in the
    search, as 2000 are) analysed after windows of 2000 gives the features it gets after a
    trace of another padded length, to the last bit, in a batch of rows and alone."""
    from signatelec.estimation.analysis import analyse_windows

    fs = 50000.0
    r = clean_signal[fs] * (1.0 + 0.002 * np.random.default_rng(3).standard_normal(10000))
    short = r[: 5 * 1998].reshape(5, 1998)

    def features():
        return [F.trace_features(None, analysis=a) for a in analyse_windows(short, fs, 500.0)]

    analyse_windows(r[:3000].reshape(1, 3000), fs, 500.0)  # another padded length
    fresh = features()
    analyse_windows(r.reshape(5, 2000), fs, 500.0)  # 2000 samples written per row
    assert features() == fresh
    analyse_windows(r.reshape(5, 2000), fs, 500.0)
    assert F.trace_features(short[0], fs, 500.0) == fresh[0]


@pytest.mark.parametrize("derivative", [True, False])
def test_harmonic_gram_matrix_in_closed_form(derivative):
    """The normal equations of the harmonic fit without its design: the Gram matrix from the
    Dirichlet kernel sin(N x) / sin(x) and its derivatives (Zygmund 1959, Trigonometric Series,
    vol. I, ch. II) equals the products of the design's columns summed in extended precision,
    to 1e-15 of the diagonal's scale (measured 3e-16; the same products summed in double from
    the sampled phasors miss by 2e-12); design r to the phasors' round-off. A frequency near
    0, where the quotients fail, is left to the summed design (None)."""
    from signatelec.estimation.harmonic_fit import harmonic_equations

    n, fs = 10000, 50000.0
    tc = (np.arange(n) - 0.5 * (n - 1)) / fs
    f = np.array([431.3, 97.0])
    r = np.random.default_rng(3).standard_normal((2, n))
    ks = [1, 2, 3, 4]
    gram, rhs = harmonic_equations(tc, f, ks, r, derivative, fs)
    tl = (np.arange(n, dtype=np.longdouble) - np.longdouble(n - 1) / 2) / np.longdouble(fs)
    for w in range(2):
        phase = 2 * np.pi * np.longdouble(f[w]) * tl
        cols = [np.ones(n, np.longdouble), tl]
        for k in ks:
            c, s = np.cos(k * phase), np.sin(k * phase)
            cols += [c, s] + ([tl * c, tl * s] if derivative else [])
        design = np.array(cols)
        exact = (design @ design.T).astype(float)
        scale = np.sqrt(np.diag(exact))
        assert np.max(np.abs(gram[w] - exact) / np.outer(scale, scale)) < 1e-15
        exact_rhs = (design @ r[w].astype(np.longdouble)).astype(float)
        # the phasors' phases carry round-off of ~1e-16 of up to ~1e3 rad: measured 4e-12
        assert np.max(np.abs(rhs[w] - exact_rhs) / (scale * np.linalg.norm(r[w]))) < 1e-11
    assert harmonic_equations(tc, np.array([1e-9]), ks, r[:1], derivative, fs) is None


def test_harmonic_residual_removes_an_exact_harmonic_series():
    """r - level - drift t - sum_k (a_k cos + b_k sin)(2 pi k f t), formed in one compiled pass
    from the phasors' powers, against the same series evaluated in extended precision: what
    is left is the noise added to the series, to the phasors' phase error: their step
    tc[1] - tc[0] carries the ulp of tc[0], ~1e-12 of the step, which the ~1e3 rad of the
    fourth harmonic's phase turn into ~3e-10 rad (measured 3.1e-10 of the series' amplitude;
    the step taken from the span gives 1.6e-13 but moves the noise-floor debiased harmonic
    features of the shipped tables by up to 3e-6 relative, so it is not taken here)."""
    from signatelec.estimation.harmonic_fit import harmonic_residual

    n, fs = 10000, 50000.0
    tc = (np.arange(n) - 0.5 * (n - 1)) / fs
    tl = (np.arange(n, dtype=np.longdouble) - np.longdouble(n - 1) / 2) / np.longdouble(fs)
    f = np.array([431.3, 97.0])
    ks = [2, 3, 4]  # consecutive, the first above 1: the kernel's zero first coefficient
    rng = np.random.default_rng(5)
    sol = rng.standard_normal((2, 2 + 2 * len(ks)))
    noise = 1e-3 * rng.standard_normal((2, n))
    series = np.empty((2, n), np.longdouble)
    for w in range(2):
        phase = 2 * np.pi * np.longdouble(f[w]) * tl
        s = sol[w, 0] + sol[w, 1] * tl
        for j, k in enumerate(ks):
            s += sol[w, 2 + 2 * j] * np.cos(k * phase) + sol[w, 3 + 2 * j] * np.sin(k * phase)
        series[w] = s
    r = (series + noise).astype(float)
    left = harmonic_residual(r, tc, f, ks, sol)
    amplitude = np.abs(sol).sum(axis=1, keepdims=True)
    assert np.max(np.abs(left - noise) / amplitude) < 1e-9
    one = harmonic_residual(r[1:], tc, f[1:], ks, sol[1:])
    assert np.array_equal(one, left[1:])


@pytest.mark.parametrize("n", [1000, 1001])
def test_window_statistics_are_numpy_s(n):
    """The compiled statistics of the windows against numpy's definitions: the order statistics
    (median, quartiles, the MADs selected from one sort by bisection) and the fold to the last
    bit, on quantised rows full of ties, even and odd lengths; the moments to 1e-12 relative,
    skewness and kurtosis (dimensionless, near 0) to 1e-12 absolute (sums in blocks
    of 128 against numpy's pairwise ones: measured 1e-14 and 3e-15; the features are held to
    1e-9)."""
    from signatelec.estimation.analysis import FOLD_BINS, _row_statistics

    fs, f_bp = 50000.0, np.array([409.7, 1234.5, 0.0])
    rng = np.random.default_rng(11)
    det = np.round(rng.standard_normal((3, n)) * 4.0) / 4.0 + 0.3 * rng.standard_normal((3, 1))
    res = rng.standard_t(5, (3, n)) * 1e-4
    out = _row_statistics(det, res, fs, f_bp)
    for w, st in enumerate(out):
        d, e = det[w], res[w]
        med, e_med = np.median(d), np.median(e)
        assert st["median"] == med and st["mad"] == np.median(np.abs(d - med))
        assert st["q25"] == np.percentile(d, 25) and st["q75"] == np.percentile(d, 75)
        assert st["residual_mad"] == np.median(np.abs(e - e_med))
        x = d - d.mean()
        moments = {
            "residual_std": e.std(),
            "residual_white": np.diff(e).std() / np.sqrt(2.0),
            "residual_var": np.mean(e**2),
            "residual_m4": np.mean(e**4),
            "raw_skew": np.mean(x**3) / np.mean(x**2) ** 1.5,
            "raw_kurtosis": np.mean(x**4) / np.mean(x**2) ** 2 - 3.0,
        }
        for name, value in moments.items():
            shape = name.startswith("raw_")
            assert st[name] == pytest.approx(
                value, rel=0 if shape else 1e-12, abs=1e-12 if shape else 0
            ), name
        if f_bp[w] > 0:
            cycles = np.arange(n) / fs * f_bp[w]
            b = np.floor((cycles - np.floor(cycles)) * FOLD_BINS).astype(int) % FOLD_BINS
            assert np.array_equal(st["fold_counts"], np.bincount(b, minlength=FOLD_BINS))
            sums = np.bincount(b, weights=d, minlength=FOLD_BINS)
            assert np.array_equal(st["fold_sums"], sums)  # the same additions, in order
        else:
            assert "fold_counts" not in st


def test_compiled_band_powers_are_numpy_s():
    """The batch's compiled band powers give numpy's bits: on spectra on uneven grids (bands
    with many bins, one, none: interpolated at the centre, or beyond the last bin) they equal
    :func:`~signatelec.estimation.analysis.band_power` band by band (the pairwise sum they
    use is tested in tests/test_analysis_kernels.py)."""
    from signatelec.estimation.analysis import band_power

    rng = np.random.default_rng(11)
    rows = []
    for n in (1, 3, 40, 260):
        f = np.sort(rng.uniform(0.0, 100.0, n))
        rows.append((f, rng.random(n)))
    start = np.concatenate([[0], np.cumsum([f.size for f, _ in rows])])
    batch = object.__new__(F._Batch)
    batch.freq, batch.start = np.concatenate([f for f, _ in rows]), start
    p = np.concatenate([q for _, q in rows])
    lo = rng.uniform(0.0, 110.0, (len(rows), 30))
    hi = lo + rng.choice([0.01, 0.5, 5.0, 60.0], size=lo.shape)
    got = batch.band_powers(p, lo, hi)
    for w, (f, q) in enumerate(rows):
        for b in range(lo.shape[1]):
            assert got[w, b] == band_power(f, q, lo[w, b], hi[w, b]), (w, b)
