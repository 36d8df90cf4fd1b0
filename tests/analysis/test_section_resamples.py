"""One product for every resampled sum of a section: :mod:`app.analysis.section_resamples`."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis.counts import wins
from app.analysis.participant_level import (
    bootstrap_rank_biserial,
    net_preference,
    rank_biserial_of_groups,
)
from app.analysis.scaling import bootstrap_weights, canonical_participant_order, resampled_sums
from app.analysis.section_resamples import pair_groups, resample_section, section_order


def _section(rng, participants, n=3):
    t = rng.poisson(0.6, (participants, n, n, 3))
    return t[t.sum(axis=(1, 2, 3)) > 0]


@given(st.integers(2, 30), st.integers(2, 4), st.integers(0, 2**31))
@settings(max_examples=40, deadline=None)
def test_every_sum_is_that_of_the_weights_times_the_data(participants, n, seed):
    rng = np.random.default_rng(seed)
    t = _section(rng, participants, n)
    if t.shape[0] < 2:
        return
    t = t[section_order(t)]
    d = net_preference(t)
    got = resample_section(t, d, 50, seed=3)
    weights = bootstrap_weights(t.shape[0], 50, 3)
    expected = np.einsum("bp,pijc->bijc", weights, t)
    np.testing.assert_array_equal(got.counts, expected)
    for undecided in ("exclude", "split"):
        judged = np.einsum("bp,pij->bij", weights, wins(t, undecided).astype(float))
        judged[:, np.arange(n), np.arange(n)] = 0.0
        np.testing.assert_array_equal(got.judgements(undecided), judged)
    for q in range(d.shape[1]):
        in_group, positive = got.groups[q]
        rows, who, g = pair_groups(d[:, q])
        indicator = np.zeros((2 * g, t.shape[0]))
        indicator[rows, who] = 1.0
        np.testing.assert_array_equal(in_group, weights @ indicator[:g].T)
        np.testing.assert_array_equal(positive, weights @ indicator[g:].T)
        np.testing.assert_allclose(
            rank_biserial_of_groups(in_group, positive),
            bootstrap_rank_biserial(d[:, q], weights),
            equal_nan=True,
        )


def test_the_order_is_the_same_with_every_pair_shown_the_other_way_round():
    rng = np.random.default_rng(8)
    t = _section(rng, 40)
    swapped = np.swapaxes(t, 1, 2)[..., [1, 0, 2]]  # left <-> right, answers with them
    a, b = t[section_order(t)], swapped[section_order(swapped)]
    np.testing.assert_array_equal(wins(a), wins(b))
    np.testing.assert_array_equal(net_preference(a), net_preference(b))


def test_relabelled_participants_give_the_same_order_of_data():
    rng = np.random.default_rng(9)
    t = _section(rng, 30)
    shuffled = t[rng.permutation(len(t))]
    np.testing.assert_array_equal(t[section_order(t)], shuffled[section_order(shuffled)])


def test_resampled_sums_of_whole_counts_skip_empty_columns_exactly():
    rng = np.random.default_rng(2)
    data = rng.integers(0, 3, (25, 6))
    data[:, [1, 4]] = 0
    got = resampled_sums(data, 40, seed=1)
    np.testing.assert_array_equal(got, bootstrap_weights(25, 40, 1) @ data)
    assert got.dtype == np.float64


@given(
    st.integers(1, 40),
    st.integers(1, 70),
    st.sampled_from([1, 2, 5, 255, 256, 70000, 2**31]),
    st.sampled_from(["whole", "float", "halves"]),
    st.integers(0, 2**31),
)
@settings(max_examples=80, deadline=None)
def test_packed_order_is_the_lexicographic_order(rows, width, high, kind, seed):
    rng = np.random.default_rng(seed)
    data = rng.integers(0, high + 1, (rows, width))
    data[rng.random(rows) < 0.3] = data[0]  # ties keep their places
    if kind != "whole":
        data = data * (0.5 if kind == "halves" else 1.0)
    np.testing.assert_array_equal(
        canonical_participant_order(data), np.lexsort(data.reshape(rows, -1).T[::-1])
    )
