import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from app.trials.adaptive import (
    ScorePosterior,
    fit_posterior,
    information_gain,
    next_pair,
    wins_from_votes,
)


def _gaussian_kl(m1, s1, m0, s0):
    """KL(N(m1, s1) || N(m0, s0)), by matrices."""
    inv = np.linalg.inv(s0)
    k = m0.size
    d = m0 - m1
    return 0.5 * (
        np.trace(inv @ s1) + d @ inv @ d - k + np.log(np.linalg.det(s0) / np.linalg.det(s1))
    )


def test_gain_is_the_expected_kl_of_the_updated_posterior():
    rng = np.random.default_rng(4)
    root = rng.normal(size=(4, 4))
    post = ScorePosterior(rng.normal(0, 0.7, 4), root @ root.T / 4 + 0.2 * np.eye(4))
    gain = information_gain(post)
    for i, j in ((0, 1), (2, 3), (1, 3)):
        d = np.zeros(4)
        d[i], d[j] = 1.0, -1.0
        m, v = d @ post.mean, d @ post.cov @ d
        q = 1 / (1 + np.exp(-m))
        w = q * (1 - q)
        cov_new = post.cov - np.outer(post.cov @ d, post.cov @ d) * w / (1 + w * v)
        p = 1 / (1 + np.exp(-m / np.sqrt(1 + np.pi * v / 8)))
        expected = 0.0
        for y, prob in ((1.0, p), (0.0, 1 - p)):
            mean_new = post.mean + post.cov @ d * (y - q) / (1 + w * v)
            expected += prob * _gaussian_kl(mean_new, cov_new, post.mean, post.cov)
        np.testing.assert_allclose(gain[i, j], gain[j, i], rtol=1e-12)
        np.testing.assert_allclose(gain[i, j], expected, rtol=1e-9)


def test_the_posterior_mode_and_curvature():
    wins = np.array([[0, 7, 9], [3, 0, 6], [1, 4, 0]], dtype=float)
    post = fit_posterior(wins, prior_sd=1.5)

    def log_post(s):
        diff = s[:, None] - s[None, :]
        return float((wins * -np.log1p(np.exp(-diff))).sum() - (s**2).sum() / (2 * 1.5**2))

    h = 1e-4
    eye = np.eye(3)
    grad = [(log_post(post.mean + h * e) - log_post(post.mean - h * e)) / (2 * h) for e in eye]
    np.testing.assert_allclose(grad, 0.0, atol=1e-6)
    hess = np.array(
        [
            [
                (
                    log_post(post.mean + h * (a + b))
                    - log_post(post.mean + h * (a - b))
                    - log_post(post.mean - h * (a - b))
                    + log_post(post.mean - h * (a + b))
                )
                / (4 * h * h)
                for b in eye
            ]
            for a in eye
        ]
    )
    np.testing.assert_allclose(np.linalg.inv(-hess), post.cov, rtol=1e-4)
    assert post.mean[0] > post.mean[1] > post.mean[2]


def test_a_posterior_certain_about_all_but_one_pair_asks_for_that_pair():
    n = 8
    wins = np.full((n, n), 40.0)  # equal scores, every pair judged 80 times
    wins[2, 5] = wins[5, 2] = 0.0  # but 2 against 5 never
    np.fill_diagonal(wins, 0.0)
    post = fit_posterior(wins)
    showable = [(i, j) for i in range(n) for j in range(n) if i != j]
    pair = next_pair(post, showable, np.zeros((n, n)), np.zeros(n), np.random.default_rng(0))
    assert set(pair) == {2, 5}


def test_the_closest_scores_are_the_most_informative_pair():
    post = ScorePosterior(np.array([0.0, 3.0, 3.1, 6.0, 9.0]), 0.1 * np.eye(5))
    showable = [(i, j) for i in range(5) for j in range(5) if i != j]
    pair = next_pair(post, showable, np.zeros((5, 5)), np.zeros(5), np.random.default_rng(1))
    assert set(pair) == {1, 2}


def test_each_pair_comes_in_both_orders_and_sides_even_out():
    post = ScorePosterior(np.array([0.0, 0.0, 5.0]), 0.1 * np.eye(3))
    all_pairs = [(i, j) for i in range(3) for j in range(3) if i != j]
    shown = np.zeros((3, 3))
    shown[0, 1] = 1
    rng = np.random.default_rng(2)
    assert next_pair(post, all_pairs, shown, np.zeros(3), rng) == (1, 0)
    shown[1, 0] = 1  # both orders shown once: the participant's sides decide
    assert next_pair(post, all_pairs, shown, np.array([1.0, -1.0, 0.0]), rng) == (1, 0)
    assert next_pair(post, all_pairs, shown, np.array([-1.0, 1.0, 0.0]), rng) == (0, 1)
    # the order it would pick cannot be shown: the other one is taken
    assert next_pair(post, [(0, 1), (0, 2)], shown, np.array([1.0, -1.0, 0.0]), rng) == (0, 1)


@settings(max_examples=60, deadline=None)
@given(
    st.integers(2, 9),
    st.integers(0, 2**32 - 1),
    st.lists(st.tuples(st.integers(0, 8), st.integers(0, 8)), max_size=30),
)
def test_it_never_proposes_a_pair_it_cannot_show(n, seed, raw):
    rng = np.random.default_rng(seed)
    showable = [(i % n, j % n) for i, j in raw]
    votes = rng.integers(0, n, (2, 20))
    wins = wins_from_votes(n, votes[0], votes[1], rng.integers(0, 3, 20))
    post = fit_posterior(wins)
    pair = next_pair(post, showable, rng.integers(0, 3, (n, n)), rng.integers(-2, 3, n), rng)
    different = [p for p in showable if p[0] != p[1]]
    if different:
        assert pair in different
    else:
        assert pair is None


@settings(max_examples=60, deadline=None)
@given(st.integers(2, 10), st.integers(0, 2**32 - 1), st.floats(0.01, 30.0))
def test_every_pairs_gain_is_finite_and_not_negative(n, seed, scale):
    rng = np.random.default_rng(seed)
    root = rng.normal(size=(n, n)) * scale
    post = ScorePosterior(rng.normal(0, scale, n), root @ root.T + 1e-6 * np.eye(n))
    gain = information_gain(post)
    assert np.all(np.isfinite(gain)) and np.all(gain >= -1e-12)
    np.testing.assert_allclose(gain, gain.T, rtol=1e-9, atol=1e-15)
