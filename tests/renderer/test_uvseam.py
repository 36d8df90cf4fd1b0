"""The skin's texture seams: no triangle sweeps across the texture, twins share a normal."""

import numpy as np

from renderer.headmodel import N_AZIMUTH, builtin_face


def test_no_skin_triangle_spans_more_than_its_own_columns_of_the_texture():
    # a wrap cell at the back of the head, between the last column and the first, swept
    # the whole texture row (a u span near 1); the pole's fan swept up to half of it
    face = builtin_face()
    uv = face.uvs[face.triangles]
    textured = ~(uv == uv[:, :1]).all(axis=(1, 2))
    span = uv[textured, :, 0].max(axis=1) - uv[textured, :, 0].min(axis=1)
    assert span.max() <= 1.5 / N_AZIMUTH + 1e-6


def test_seam_twins_share_their_normal():
    face = builtin_face()
    seam = face.groups["uv_seam"]
    assert len(seam) > N_AZIMUTH  # the wrap column's twins and the pole's
    normals = face.normals()
    _, place = np.unique(face.vertices[seam], axis=0, return_inverse=True)
    for k in np.unique(place):
        group = normals[seam[place.ravel() == k]]
        assert np.abs(group - group[0]).max() < 1e-6
    twins = np.bincount(place.ravel())
    assert twins.max() >= 2
