"""Silhouette and boundary edges for discontinuity edge overdraw, on meshes with known outlines."""

import numpy as np

from renderer.edges import edge_table, front_facing, overdraw_edges

# a regular octahedron, counter-clockwise seen from outside: +x, -x, +y, -y, +z, -z
OCTA_V = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float)
OCTA_T = np.array(
    [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
)


def _ortho(v):
    """Orthographic view along -z: clip x, y and w = 1."""
    return np.column_stack([v[:, 0], v[:, 1], np.ones(len(v))])


def _pairs(edges):
    return {tuple(sorted(e[:2])) for e in edges.tolist()}


def test_edge_table_of_a_closed_mesh_pairs_every_edge():
    table = edge_table(OCTA_T)
    assert len(table.a) == 12 and (table.t1 >= 0).all()
    for a, b, t0, t1, o0, o1 in zip(
        table.a, table.b, table.t0, table.t1, table.o0, table.o1, strict=True
    ):
        for t, o in ((t0, o0), (t1, o1)):
            assert set(OCTA_T[t]) == {a, b, o}


def test_edge_table_marks_open_boundaries():
    square = np.array([[0, 1, 2], [0, 2, 3]])
    table = edge_table(square)
    assert len(table.a) == 5
    inner = np.flatnonzero(table.t1 >= 0)
    assert len(inner) == 1 and {table.a[inner[0]], table.b[inner[0]]} == {0, 2}


def test_front_facing_is_counter_clockwise_in_front_of_the_camera():
    tris = np.array([[0, 1, 2], [0, 2, 1], [3, 4, 5]])
    xyw = np.array(
        [[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 0, -1], [1, 0, -1], [0, 1, -1]], float
    )  # the last is behind the eye
    assert front_facing(tris, xyw).tolist() == [True, False, False]


def test_octahedron_seen_from_the_front_has_its_equator_as_silhouette():
    edges = overdraw_edges(edge_table(OCTA_T), OCTA_T, _ortho(OCTA_V))
    assert _pairs(edges) == {(0, 2), (1, 2), (1, 3), (0, 3)}
    assert set(edges[:, 2].tolist()) == {4}  # the inside is towards the front apex


def test_turned_octahedron_outline_follows_the_view():
    # a quarter turn about y: -x comes to the front, the outline passes through +-y and +-z
    c, s = 0.0, 1.0
    rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    v = OCTA_V @ rot.T
    assert np.allclose(v[0], [0, 0, -1]) and np.allclose(v[5], [-1, 0, 0])
    edges = overdraw_edges(edge_table(OCTA_T), OCTA_T, _ortho(v))
    # the front apex is now the vertex nearest the viewer (+z after the turn): -x
    front = int(np.argmax(v[:, 2]))
    assert front == 1
    assert _pairs(edges) == {(2, 4), (3, 4), (2, 5), (3, 5)}
    assert set(edges[:, 2].tolist()) == {front}


def test_open_boundary_of_a_front_facing_sheet_is_overdrawn():
    square = np.array([[0, 1, 2], [0, 2, 3]])
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    edges = overdraw_edges(edge_table(square), square, _ortho(v))
    assert _pairs(edges) == {(0, 1), (1, 2), (2, 3), (0, 3)}
    # seen from behind (mirrored), the sheet faces away: nothing to overdraw
    assert len(overdraw_edges(edge_table(square), square, _ortho(v * [-1, 1, 1]))) == 0


def test_hidden_vertices_drop_their_edges():
    hidden = np.zeros(6, bool)
    hidden[[0, 2]] = True
    table = edge_table(OCTA_T, hidden)
    assert len(table.a) == 11
    edges = overdraw_edges(table, OCTA_T, _ortho(OCTA_V))
    assert _pairs(edges) == {(1, 2), (1, 3), (0, 3)}


def test_examples_in_the_docstrings_hold():
    import doctest

    import renderer.edges as edges

    assert doctest.testmod(edges).failed == 0
