"""Skin parts: the displacement they add and the normals they recompute (no GL needed)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from renderer.face import vertex_normals
from renderer.headmodel import builtin_face
from renderer.skin import SkinPart, ZoneNormals, one_ring

FACE = builtin_face()


def test_one_ring_is_every_vertex_of_the_touching_triangles():
    # a strip of four triangles over vertices 0..5
    tri = np.array([[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4]])
    assert one_ring(tri, np.array([0]), 6).tolist() == [0, 1, 2]
    assert one_ring(tri, np.array([5]), 6).tolist() == [3, 4, 5]
    assert one_ring(tri, np.array([2]), 6).tolist() == [0, 1, 2, 3, 4]


def test_zone_normals_are_the_area_weighted_vertex_normals_on_the_zone():
    rng = np.random.default_rng(3)
    v = FACE.vertices + rng.normal(0, 0.3, FACE.vertices.shape).astype(np.float32)
    zone = np.flatnonzero(FACE.vertices[:, 1] > 40.0)  # the top of the head
    got = ZoneNormals(FACE.triangles, zone, FACE.n_vertices)(v)
    np.testing.assert_allclose(got, vertex_normals(v, FACE.triangles)[zone], atol=2e-5)


@settings(max_examples=25, deadline=None)
@given(coeff=st.lists(st.floats(-400, 400), min_size=3, max_size=3))
def test_a_part_moves_its_zone_and_reshades_exactly_the_normals_it_changes(coeff):
    rng = np.random.default_rng(5)
    n = FACE.n_vertices
    # three columns, each a bump on one patch of the cheek, forehead and chin
    centres = FACE.vertices[[FACE.fp_vertices[p] for p in ("2.1", "4.1", "8.4")]]
    basis = np.zeros((3, n, 3))
    for k, c in enumerate(centres):
        d = np.linalg.norm(FACE.vertices - c, axis=1)
        basis[k] = np.maximum(0.0, 1.0 - d / 15.0)[:, None] * rng.normal(0, 0.01, 3)
    part = SkinPart(np.arange(3), basis, FACE.triangles)
    pos, nrm = FACE.vertices.astype(np.float32), FACE.normals()
    c = np.asarray(coeff, np.float32)
    moved = part.move(c, pos)
    np.testing.assert_allclose(pos, FACE.vertices + np.tensordot(c, basis, 1), atol=1e-3)
    assert moved == bool(c.any())
    part.shade(pos, nrm)
    # (the texture's seam twins share their normals, as the face's own normals do)
    expected = vertex_normals(pos, FACE.triangles, weld=FACE.groups["uv_seam"])
    np.testing.assert_allclose(nrm, expected, atol=2e-5)
