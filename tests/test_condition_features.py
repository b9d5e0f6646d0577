"""Envelope analysis and condition features against signals whose answers are known in closed form.

- spectral kurtosis (Antoni 2006; Antoni and Randall 2006, eq. 8): 0 for stationary Gaussian
  noise, -1 for a steady sinusoid, large where impulses dominate;
- the squared Hilbert envelope of an amplitude-modulated carrier (1 + m cos 2 pi f_m t)
  cos 2 pi f_c t is (1 + m cos 2 pi f_m t)^2: its spectrum has lines of amplitude 2 m at f_m
  and m^2 / 2 at 2 f_m;
- a train of rectangular pulses of height h, width w, period 1 / f has the Fourier amplitude
  2 h w f |sinc(k f w)| at k f;
- Gaussian noise has Pearson kurtosis 3; a sinusoid has crest factor sqrt 2;
- a spall's pulses at BPFO, BPFI or 2 BSF (Randall and Antoni 2011, eqs 1-4) put their line,
  and only theirs, above the noise of the envelope spectrum; an inner-race spall modulated by
  the load zone at f_s gives sidebands at BPFI -+ f_s, a ball's at 2 BSF -+ FTF.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from signatelec.config.catalogue import catalogue_bearing
from signatelec.estimation.condition_features import (
    CONDITION_GROUPS,
    condition_feature_names,
    condition_features,
)
from signatelec.estimation.envelope import (
    Band,
    Spectrum,
    amplitude_spectrum,
    analyse_envelope,
    band_envelope,
    spectral_kurtosis,
)
from signatelec.physics.kinematics import characteristic_frequencies_hz
from tests.synthetic_traces import FS, LEVEL, OMEGA, spalled_trace


def test_spectral_kurtosis_of_noise_tone_and_impulses():
    rng = np.random.default_rng(1)
    n = 40000
    _, sk_noise = spectral_kurtosis(rng.standard_normal(n), 64)
    # Gaussian noise: SK = 0; the estimate's standard deviation is 2 / sqrt(K) for K
    # segments (Antoni 2006, section 4): K = 2500 here, so 0.04; 0.15 is ~4 of them
    assert np.all(np.abs(sk_noise[2:-2]) < 0.15)
    t = np.arange(n) / FS
    tone = np.cos(2 * np.pi * 2500.0 * t) + 1e-3 * rng.standard_normal(n)
    _, sk_tone = spectral_kurtosis(tone, 64)
    assert sk_tone[8] == pytest.approx(-1.0, abs=0.02)  # 2500 Hz is bin 8 of 64 at 20 kHz
    pulses = np.zeros(n)
    pulses[::2000] = 60.0
    _, sk_pulses = spectral_kurtosis(pulses + rng.standard_normal(n), 64)
    assert np.median(sk_pulses[2:-2]) > 5.0


def test_amplitude_spectrum_reads_a_sinusoid_amplitude():
    t = np.arange(4000) / FS
    for f in (417.3, 1234.5):
        a, df = amplitude_spectrum(0.7 * np.cos(2 * np.pi * f * t + 1.0), FS)
        spec = Spectrum(a, df, t.size / FS)
        # Hann window padded x4: the scalloping loss at 1/8 of a bin is below 1 %
        assert spec.line(f) == pytest.approx(0.7, rel=0.01)


def test_envelope_of_an_amplitude_modulated_carrier():
    t = np.arange(8000) / FS
    m, fm, fc = 0.3, 123.0, 4000.0
    x = (1.0 + m * np.cos(2 * np.pi * fm * t)) * np.cos(2 * np.pi * fc * t)
    _, env = band_envelope(x, FS, Band(3000.0, 5000.0, math.nan, 0))
    inner = env[500:-500]  # away from the ends, where the brick-wall filter rings
    exact = (1.0 + m * np.cos(2 * np.pi * fm * t[500:-500])) ** 2
    assert np.max(np.abs(inner - exact)) < 0.02
    a, df = amplitude_spectrum(env, FS)
    spec = Spectrum(a, df, t.size / FS)
    assert spec.line(fm) == pytest.approx(2.0 * m, rel=0.02)
    assert spec.line(2.0 * fm) == pytest.approx(0.5 * m**2, rel=0.05)


def test_raw_line_of_a_pulse_train_is_its_fourier_amplitude():
    lines = characteristic_frequencies_hz(OMEGA)
    f, w, h = lines["bpfi"], 2e-4, 0.01
    r = spalled_trace("outer", noise=0.0, pulse_rel=0.0)
    t = np.arange(r.size) / FS
    r = r + LEVEL * h * ((t * f) % 1.0 < w * f)
    feats = condition_features(r, FS, OMEGA)
    # the sampled pulse lasts round(w fs) samples: its width is that over fs
    w_sampled = np.mean((t * f) % 1.0 < w * f) / f
    for k in (1, 2):
        expected = 2 * h * w_sampled * f * abs(np.sinc(k * f * w_sampled))
        assert feats[f"raw_bpfi_h{k}_rel"] == pytest.approx(expected, rel=0.03)


def test_noise_kurtosis_and_sine_crest():
    from signatelec.estimation.condition_features import _kurtosis_crest

    rng = np.random.default_rng(2)
    k, _ = _kurtosis_crest(rng.standard_normal(200000))
    assert k == pytest.approx(3.0, abs=0.05)  # sampling sd of kurtosis sqrt(24 / n) = 0.011
    _, c = _kurtosis_crest(np.cos(2 * np.pi * np.arange(100000) / 100.0))
    assert c == pytest.approx(math.sqrt(2.0), rel=1e-6)


@pytest.mark.parametrize(
    "kind, line", [("outer", "bpfo"), ("inner", "bpfi"), ("ball", "ball_defect")]
)
@pytest.mark.parametrize("bearing", [None, catalogue_bearing("6205")], ids=["seed", "6205"])
def test_a_spall_raises_its_own_envelope_line(kind, line, bearing):
    omega = OMEGA if bearing is None else 1800.0 * 2 * math.pi / 60
    healthy = condition_features(
        spalled_trace("healthy", bearing=bearing, omega=omega), FS, omega, bearing=bearing
    )
    spalled = condition_features(
        spalled_trace(kind, bearing=bearing, omega=omega), FS, omega, bearing=bearing
    )
    lines = ("bpfo", "bpfi", "ball_defect")
    gain = {n: spalled[f"env_{n}_snr"] / healthy[f"env_{n}_snr"] for n in lines}
    assert max(gain, key=gain.get) == line
    assert spalled[f"env_{line}_snr"] > 4.0 * healthy[f"env_{line}_snr"]
    assert spalled["residual_kurtosis"] > healthy["residual_kurtosis"] + 1.0


def test_load_zone_modulation_gives_the_sidebands():
    healthy = condition_features(spalled_trace("healthy"), FS, OMEGA)
    inner = condition_features(spalled_trace("inner"), FS, OMEGA)
    ball = condition_features(spalled_trace("ball"), FS, OMEGA)
    assert inner["env_bpfi_shaft_sb_rel"] > 3.0 * healthy["env_bpfi_shaft_sb_rel"]
    assert ball["env_ball_ftf_sb_rel"] > 3.0 * healthy["env_ball_ftf_sb_rel"]
    unbalance = condition_features(spalled_trace("unbalance"), FS, OMEGA)
    # 0.3 % of the level at f_s: the raw line reads it (white noise adds ~1e-5 at 0.2 s)
    assert unbalance["raw_shaft_h1_rel"] == pytest.approx(3e-3, rel=0.05)
    assert healthy["raw_shaft_h1_rel"] < 3e-4


def test_features_have_their_names_and_are_finite_on_any_length():
    names = condition_feature_names()
    assert len(names) == len(set(names))
    assert names == [n for g in CONDITION_GROUPS for n in g.feature_names()]
    for n in (16, 300, 4000):
        r = spalled_trace("inner")[:n]
        f = condition_features(r, FS, OMEGA)
        assert list(f) == names
        assert all(np.isfinite(v) for v in f.values())
    a = analyse_envelope(spalled_trace("healthy"), FS, OMEGA)
    assert a.cage_revolutions == pytest.approx(0.2 * characteristic_frequencies_hz(OMEGA)["ftf"])


def test_twins_match_transformers():
    from signatelec.estimation import transformers as T

    X = np.stack([spalled_trace(kind, duration_s=0.1) for kind in ("healthy", "inner", "ball")])
    for transformer, function in zip(
        T.CONDITION_TRANSFORMERS, CONDITION_GROUPS + (condition_features,), strict=True
    ):
        tr = transformer(sample_rate_hz=FS, omega_rad_s=OMEGA).fit(X)
        out = tr.transform(X)
        names = list(tr.get_feature_names_out())
        assert names == function.feature_names()
        for row, x in zip(out, X, strict=True):
            d = function(x, FS, OMEGA)
            np.testing.assert_allclose(row, [d[n] for n in names], rtol=1e-12)
