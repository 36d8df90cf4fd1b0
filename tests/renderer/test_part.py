"""Merging the head's parts: indices offset, layers and groups carried, texture coordinates."""

import numpy as np

from renderer.part import Part, merge


def _triangle(offset: float, **kw) -> Part:
    vertices = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]) + offset
    return Part(vertices, np.array([[0, 1, 2]]), np.ones((3, 4)), **kw)


def test_merged_parts_keep_their_triangles_groups_and_layers():
    jaw = np.array([0.0, 0.5, 1.0])
    a = _triangle(0.0, groups={"fp:2.1": np.array([2])}, layers={"jaw": jaw})
    b = _triangle(5.0, groups={"fp:2.1": np.array([0])}, uvs=np.full((3, 2), 0.25, np.float32))
    merged = merge([a, b])
    assert len(merged.vertices) == 6
    np.testing.assert_array_equal(merged.triangles, [[0, 1, 2], [3, 4, 5]])
    np.testing.assert_array_equal(merged.groups["fp:2.1"], [2, 3])
    # a part without a layer takes its default: all of the head, none of anything else
    np.testing.assert_array_equal(merged.layers["jaw"], [0.0, 0.5, 1.0, 0.0, 0.0, 0.0])
    assert merged.uvs is None


def test_default_uv_fills_the_parts_without_texture_coordinates():
    a = _triangle(0.0, layers={"head": np.zeros(3)})
    b = _triangle(5.0, uvs=np.full((3, 2), 0.25, np.float32))
    merged = merge([a, b], default_uv=(0.5, 0.99))
    assert merged.uvs is not None and merged.uvs.dtype == np.float32
    np.testing.assert_allclose(merged.uvs[:3], [[0.5, 0.99]] * 3)
    np.testing.assert_allclose(merged.uvs[3:], 0.25)
    np.testing.assert_array_equal(merged.layers["head"], [0, 0, 0, 1, 1, 1])
