"""The change detector's split statistic is the Gaussian GLR of a change of mean.

For windows z_i ~ N(mu, P_i^-1), the GLR statistic of a change of mean at k is
T_k = (m_L - m_R)' (A^-1 + B^-1)^-1 (m_L - m_R) (Basseville & Nikiforov 1993, section 2.4),
m the precision-weighted means and A, B the sides' summed precisions; under no change it is
chi^2 with d degrees of freedom.
"""

import numpy as np
from scipy import stats

from signatelec.estimation.changes import _best_split


def _windows(rng, n: int, d: int, shift: np.ndarray | None = None, at: int = 0):
    root = rng.normal(size=(n, d, d)) / np.sqrt(d)
    p = root @ root.transpose(0, 2, 1) + 0.5 * np.eye(d)
    z = np.array([rng.multivariate_normal(np.zeros(d), np.linalg.inv(pi)) for pi in p])
    if shift is not None:
        z[at:] += shift
    cum_p = np.concatenate([np.zeros((1, d, d)), np.cumsum(p, axis=0)])
    cum_px = np.vstack([np.zeros(d), np.cumsum(np.einsum("kij,kj->ki", p, z), axis=0)])
    return p, z, cum_p, cum_px


def _textbook(p, z, k):
    a, b = p[:k].sum(axis=0), p[k:].sum(axis=0)
    m_l = np.linalg.solve(a, np.einsum("kij,kj->i", p[:k], z[:k]))
    m_r = np.linalg.solve(b, np.einsum("kij,kj->i", p[k:], z[k:]))
    delta = m_l - m_r
    return float(delta @ np.linalg.solve(np.linalg.inv(a) + np.linalg.inv(b), delta))


def test_split_statistic_is_the_textbook_glr_at_its_best_split():
    rng = np.random.default_rng(3)
    p, z, cum_p, cum_px = _windows(rng, 60, 5, shift=np.full(5, 0.8), at=37)
    k, t = _best_split(cum_p, cum_px, 0, 60, 3)
    every = [_textbook(p, z, j) for j in range(3, 58)]
    assert k == 3 + int(np.argmax(every))
    assert abs(t - max(every)) <= 1e-9 * max(every)
    assert abs(k - 37) <= 2  # a step of 0.8 sd in 5 series is placed within a few windows


def test_split_statistic_under_no_change_is_chi2_with_d_degrees_of_freedom():
    # at a fixed split (n = 20 windows, at least 10 a side: k = 10 alone) the statistic is
    # chi^2(d): its mean d (sd sqrt(2 d / 400) over 400 draws) and 5 % above chi2.isf(0.05, d)
    rng = np.random.default_rng(4)
    d, n = 3, 20
    t = np.array([_best_split(*_windows(rng, n, d)[2:], 0, n, n // 2)[1] for _ in range(400)])
    assert abs(t.mean() - d) < 4 * np.sqrt(2 * d / t.size)
    exceed = np.mean(t > stats.chi2.isf(0.05, d))
    assert abs(exceed - 0.05) < 4 * np.sqrt(0.05 * 0.95 / t.size)


def test_a_sum_that_is_not_positive_definite_gives_no_statistic():
    # a window's precision broken to -30 I (rounding can leave a short segment's summed
    # precision so): the splits whose sides hold it have no statistic, never NaN or inf
    rng = np.random.default_rng(5)
    p, z, _, _ = _windows(rng, 30, 3)
    p[8] = -30.0 * np.eye(3)
    cum_p = np.concatenate([np.zeros((1, 3, 3)), np.cumsum(p, axis=0)])
    cum_px = np.vstack([np.zeros(3), np.cumsum(np.einsum("kij,kj->ki", p, z), axis=0)])
    for a, b in ((0, 30), (0, 12), (5, 30)):
        k, t = _best_split(cum_p, cum_px, a, b, 3)
        assert k == -1 or np.isfinite(t)
