"""The textured built-in head: its texture, its light, its lashes and brows, in pixels."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from app.errors import InputError
from renderer import RenderSettings
from renderer.camera import camera_for, project
from renderer.deform import Rig
from renderer.headmodel import N_AZIMUTH, N_ELEVATION, builtin_face
from renderer.skintexture import (
    brow_strands,
    cached_skin_texture,
    grid_uvs,
    skin_texture,
    white_uv,
)
from tests.support.head_pixels import SIZE, draw_head


@pytest.fixture(scope="module")
def grid():
    face = builtin_face("plain")
    return face.vertices[: N_ELEVATION * N_AZIMUTH].reshape(N_ELEVATION, N_AZIMUTH, 3)


@pytest.fixture(scope="module")
def rig():
    return Rig(builtin_face())


def test_the_texture_is_the_same_for_a_seed_and_changes_with_it(grid):
    a = skin_texture(grid, -58.0, 25.0, size=128, seed=7)
    b = skin_texture(grid, -58.0, 25.0, size=128, seed=7)
    c = skin_texture(grid, -58.0, 25.0, size=128, seed=8)
    assert a.dtype == np.uint8 and a.shape == (128, 128, 3)
    assert np.array_equal(a, b)
    assert np.abs(a.astype(int) - c.astype(int)).mean() > 1.0


def test_a_painted_texture_is_read_back_and_a_changed_grid_paints_anew(grid, tmp_path, monkeypatch):
    first = cached_skin_texture(grid, -58.0, 25.0, size=64, seed=7, directory=tmp_path)
    assert np.array_equal(first, skin_texture(grid, -58.0, 25.0, size=64, seed=7))
    [stored] = tmp_path.glob("skin-*.npy")
    # the second call reads the file: painting is not called again
    monkeypatch.setattr(
        "renderer.skintexture.skin_texture", lambda *a, **k: pytest.fail("painted again")
    )
    assert np.array_equal(
        cached_skin_texture(grid, -58.0, 25.0, size=64, seed=7, directory=tmp_path), first
    )
    monkeypatch.undo()
    moved = grid + np.array([0.0, 1.0, 0.0])
    cached_skin_texture(moved, -58.0, 25.0, size=64, seed=7, directory=tmp_path)
    assert len(list(tmp_path.glob("skin-*.npy"))) == 2
    # a damaged file is painted again, and a folder that cannot be written is no error
    stored.write_bytes(b"not an array")
    assert np.array_equal(
        cached_skin_texture(grid, -58.0, 25.0, size=64, seed=7, directory=tmp_path), first
    )
    blocked = tmp_path / "file"
    blocked.write_text("")
    assert np.array_equal(
        cached_skin_texture(grid, -58.0, 25.0, size=64, seed=7, directory=blocked / "sub"), first
    )


def test_the_texture_has_skin_detail_lips_and_hair_where_the_grid_puts_them(rig):
    face = rig.face
    tex = face.texture.astype(float)
    h, w, _ = tex.shape

    def texel(point):
        i = int(np.argmin(np.linalg.norm(face.vertices[: N_ELEVATION * N_AZIMUTH] - point, axis=1)))
        u, v = face.uvs[i]
        return tex[int(v * h), int(u * w)], (int(v * h), int(u * w))

    cheek, (r, c) = texel(np.array([40.0, -25.0, 80.0]))
    lip, _ = texel(np.array([0.0, -63.0, 92.0]))  # the middle of the lower lip
    crown, _ = texel(np.array([0.0, 100.0, 20.0]))
    assert cheek[0] > cheek[1] > cheek[2] and cheek[0] > 150  # skin: warm and light
    assert lip[0] - lip[1] > cheek[0] - cheek[1]  # lips redder than skin
    assert crown.mean() < 0.5 * cheek.mean()  # hair dark
    patch = tex[r - 8 : r + 8, c - 8 : c + 8].mean(axis=2)
    assert 1.5 < patch.std() < 25.0  # detail, not noise or flat
    u, v = white_uv(N_ELEVATION)
    assert (face.texture[int(v * h), :] == 255).all()


def test_grid_uvs_follow_rows_and_columns():
    uv = grid_uvs(3, 4).reshape(3, 4, 2)
    assert np.all(np.diff(uv[..., 0], axis=1) > 0) and np.all(np.diff(uv[..., 1], axis=0) > 0)
    assert uv.min() > 0 and uv.max() < 1


def _partial_peaks(coverage):
    """Local maxima of partial coverage along the rows and along the columns of a map."""

    def along(m):
        core = m[1:-1]
        return int(((core > m[:-2]) & (core > m[2:]) & (core > 0.05) & (core < 0.97)).sum())

    return along(coverage) + along(coverage.T)


def test_brow_hairs_are_strands_not_a_painted_band():
    from renderer.skinpaint import brow_mask

    hair = brow_strands(np.random.default_rng(1))
    assert 0.05 < (hair > 0.5).mean() < 0.4
    # the brow as it was painted per vertex, on the same map: a smooth band
    rows, cols = hair.shape
    x, y = np.meshgrid(6.0 + 0.1 * np.arange(cols), 14.0 + 0.1 * np.arange(rows))
    band = brow_mask(np.column_stack([x.ravel(), y.ravel(), np.full(x.size, 80.0)]))
    band = band.reshape(hair.shape)
    # a strand crossed is a ridge of coverage: hundreds of them, where the band has a few
    assert _partial_peaks(hair) > 1000
    assert _partial_peaks(band) < 200


def _luminance(img):
    return img @ np.array([0.2126, 0.7152, 0.0722]) / 255.0


def test_key_and_fill_light_both_halves_of_the_face(rig):
    (img,) = draw_head(rig, {})
    vp, _ = camera_for(rig)
    lum = _luminance(img)
    cheeks = project(vp, np.array([[38.0, -28.0, 82.0], [-38.0, -28.0, 82.0]]), SIZE)
    means = [lum[int(y) - 6 : int(y) + 6, int(x) - 6 : int(x) + 6].mean() for x, y in cheeks]
    key, fill = sorted(means, reverse=True)
    assert fill > 0.4  # the fill side is lit, not in shadow
    assert 0.65 < fill / key < 0.95  # and still modelled: the key side is brighter


def _dark_rows(img, box, threshold=0.2):
    x0, y0, x1, y1 = box
    dark = _luminance(img[y0:y1, x0:x1]) < threshold
    rows = np.nonzero(dark)[0]
    return rows.mean() + y0, int(dark.sum())


def test_the_lashes_close_with_the_lids(rig):
    vp, _ = camera_for(rig)
    fp = rig.face.feature_points
    close = {19: 600.0, 20: 600.0}
    open_img, closed_img = draw_head(rig, {}, close)
    moved = rig.deform(np.array([close.get(k, 0.0) for k in range(1, 69)]))
    top = project(vp, np.array([fp["3.1"], moved.positions[rig.face.fp_vertices["3.1"]]]), SIZE)
    x, y = top[0]
    box = (int(x) - 14, int(y) - 10, int(x) + 14, int(top[1][1]) + 8)
    before, n_before = _dark_rows(open_img, box)
    after, n_after = _dark_rows(closed_img, box)
    assert n_before > 20 and n_after > 20  # the lash line is there, open or closed
    assert after - before == pytest.approx(top[1][1] - top[0][1], abs=3.0)
    plain = Rig(builtin_face("plain"))
    (plain_img,) = draw_head(plain, {})
    assert _dark_rows(plain_img, box)[1] < 0.5 * n_before  # the lashes are what is dark


def test_the_brows_rise_in_the_image_with_faps_31_to_34(rig):
    vp, _ = camera_for(rig)
    raise_ = {31: 150.0, 32: 150.0, 33: 150.0, 34: 150.0}
    rest, raised = draw_head(rig, {}, raise_)
    frame = rig.deform(np.array([raise_.get(k, 0.0) for k in range(1, 69)]))
    for name in ("4.3", "4.4"):
        i = rig.face.fp_vertices[name]
        (x, y), (_, y2) = project(vp, np.array([rig.face.vertices[i], frame.positions[i]]), SIZE)
        box = (int(x) - 10, int(y) - 14, int(x) + 10, int(y) + 10)
        before, n = _dark_rows(rest, box, 0.3)
        after, n2 = _dark_rows(raised, box, 0.3)
        assert n > 15 and n2 > 15
        assert y2 < y - 2  # the FAPs raise the brow by pixels
        assert after - before == pytest.approx(y2 - y, abs=2.0)


def test_the_exported_head_carries_the_texture(tmp_path):
    from renderer.avatar import load_avatar
    from renderer.faceexport import export_builtin_head

    face = builtin_face()
    avatar = load_avatar(export_builtin_head(tmp_path / "head.glb"))
    assert np.array_equal(avatar.texture, face.texture)
    assert np.allclose(avatar.uvs, face.uvs)


@settings(max_examples=40, deadline=None)
@given(st.text(max_size=20))
def test_a_look_is_one_of_the_looks_or_an_error_naming_the_field(look):
    try:
        assert RenderSettings(look=look).look in ("textured", "plain")
    except InputError as exc:
        assert exc.field == "look" and "\n" not in str(exc)
