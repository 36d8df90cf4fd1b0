"""On-screen instructions: the bitmap text, its placement, and a rendered clip that carries it."""

import numpy as np
import pytest

from app.errors import InputError
from renderer.caption import GLYPH_H, CaptionStamp, text_mask


def test_glyphs_spell_distinct_letters_of_the_font_height():
    left, right = text_mask("PRESS LEFT"), text_mask("PRESS RIGHT")
    assert left.shape == (GLYPH_H, 10 * 6 - 1) and right.shape == (GLYPH_H, 11 * 6 - 1)
    assert not np.array_equal(left[:, -29:], right[:, -29:])
    assert np.array_equal(text_mask("press"), text_mask("PRESS"))
    assert not text_mask("   ").any()


def test_stamp_is_centred_at_the_top_and_leaves_the_faces_alone():
    frame = np.full((160, 320, 3), 100, np.uint8)
    out = CaptionStamp("PRESS LEFT", width=320, height=160)(frame)
    changed = np.argwhere((out != frame).any(axis=2))
    rows, cols = changed[:, 0], changed[:, 1]
    assert rows.max() < 160 // 4  # the top band only: both faces below stay visible
    assert abs((cols.min() + cols.max()) / 2 - 160) <= 1  # centred
    assert (out == 255).all(axis=2).sum() == text_mask("PRESS LEFT").sum() * 2 * 2  # scale 2
    assert np.array_equal(frame, np.full((160, 320, 3), 100, np.uint8))  # not in place


@pytest.mark.parametrize(
    ("text", "message"),
    [("press ←", "cannot draw '←'"), ("", "empty text"), ("PRESS LEFT NOW PLEASE", "does not fit")],
)
def test_what_cannot_be_drawn_is_an_input_error(text, message):
    with pytest.raises(InputError, match=message):
        CaptionStamp(text, width=64, height=64)


@pytest.mark.gl
def test_a_rendered_pair_carries_the_caption_and_another_cache_entry(tmp_path, tone_wav):
    from renderer import RenderSettings, render_pair
    from tests.support.clips import decode, moving_tracks

    settings = RenderSettings(size=128, mosaic_block=16)
    a, b = moving_tracks(6)
    plain = render_pair(
        a, b, tone_wav(0.3), tmp_path / "plain.mp4", settings=settings, cache_dir=tmp_path / "cache"
    )
    marked = render_pair(
        a,
        b,
        tone_wav(0.3),
        tmp_path / "marked.mp4",
        settings=settings,
        cache_dir=tmp_path / "cache",
        caption="press Right",
    )
    (_, without), (_, with_text) = decode(plain), decode(marked)
    stamp = CaptionStamp("press Right", width=256, height=128)
    ink = stamp.ink
    top = with_text[0][stamp.box].astype(int)
    assert top[ink].mean() > 200 and top[~ink].mean() < 90  # white letters on a dark box
    below = slice(stamp.box[0].stop + 2, None)
    assert np.abs(with_text[0][below].astype(int) - without[0][below]).mean() < 2
