"""The zones of the translational FAPs: Xface's raised cosine, each lip point moved by its own
FAP, the eyeballs never (no GL needed)."""

import numpy as np
import pytest

from app.stimuli.fap import FAPS, FEATURE_POINT, INNER_LIPS, OUTER_LIPS, fapu_values
from renderer.fapzones import direction, raised_cosine, translation_basis
from renderer.headmodel import builtin_face
from renderer.rigweights import derive_weights


def test_raised_cosine_known_values():
    d = np.array([0.0, 5.0, 10.0, 20.0])
    assert np.allclose(raised_cosine(d, 10.0), [1.0, 0.5, 0.0, 0.0])


@pytest.fixture(scope="module")
def basis():
    face = builtin_face()
    fu = fapu_values(face.fapu)
    columns, brow_lower_limit = translation_basis(face, derive_weights(face), fu)
    return face, fu, columns, brow_lower_limit


def test_a_lip_feature_point_moves_by_its_own_fap_times_fapu(basis):
    face, fu, columns, _ = basis
    for fap in INNER_LIPS + OUTER_LIPS:
        i = face.fp_vertices[FEATURE_POINT[fap]]
        moved = columns[fap][i] / fu[FAPS[fap].unit]
        vertical = direction(fap)[0] == 0
        if vertical and FEATURE_POINT[fap] not in ("2.4", "2.5", "8.3", "8.4"):
            assert np.allclose(moved, direction(fap), atol=1e-5), fap
        else:  # a corner is shared by its two lips, or by its inner and outer zones
            assert np.allclose(moved, 0.5 * direction(fap), atol=1e-5), fap


def test_the_eyeballs_never_move_and_lowered_brows_saturate(basis):
    face, _, columns, brow_lower_limit = basis
    eyes = np.concatenate([face.groups["eyeball_l"], face.groups["eyeball_r"]])
    assert not any(np.abs(c[eyes]).any() for c in columns.values())
    assert 0 < brow_lower_limit < np.inf
