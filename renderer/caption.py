"""On-screen instructions drawn into a clip: the attention check's "PRESS LEFT".

An attention check whose instruction is part of the video can only be passed by a participant
who watched it (ITU-T P.910's crowdsourcing annex asks for such checks; a text on the page can be
read without looking at the clip). The text is drawn with a built-in 5x7 bitmap font, scaled to
the frame, white on a dark box across the top of the frame, so the faces stay visible; no font
files and no drawing library are needed, and the mask is built once per clip, so stamping a
frame is one masked assignment.

>>> import numpy as np
>>> frame = np.zeros((64, 128, 3), np.uint8)
>>> stamped = CaptionStamp("PRESS LEFT", width=128, height=64)(frame)
>>> bool(stamped.max() == 255), stamped.shape
(True, (64, 128, 3))
"""

from __future__ import annotations

from typing import Final

import numpy as np

from app.errors import InputError

#: Rows of each glyph, 5 pixels wide ("#" = ink), 7 rows high.
_GLYPHS: Final[dict[str, tuple[str, ...]]] = {
    "A": (" ### ", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"),
    "B": ("#### ", "#   #", "#   #", "#### ", "#   #", "#   #", "#### "),
    "C": (" ####", "#    ", "#    ", "#    ", "#    ", "#    ", " ####"),
    "D": ("#### ", "#   #", "#   #", "#   #", "#   #", "#   #", "#### "),
    "E": ("#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#####"),
    "F": ("#####", "#    ", "#    ", "#### ", "#    ", "#    ", "#    "),
    "G": (" ####", "#    ", "#    ", "#  ##", "#   #", "#   #", " ####"),
    "H": ("#   #", "#   #", "#   #", "#####", "#   #", "#   #", "#   #"),
    "I": ("#####", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", "#####"),
    "J": ("  ###", "   # ", "   # ", "   # ", "#  # ", "#  # ", " ##  "),
    "K": ("#   #", "#  # ", "# #  ", "##   ", "# #  ", "#  # ", "#   #"),
    "L": ("#    ", "#    ", "#    ", "#    ", "#    ", "#    ", "#####"),
    "M": ("#   #", "## ##", "# # #", "# # #", "#   #", "#   #", "#   #"),
    "N": ("#   #", "##  #", "# # #", "#  ##", "#   #", "#   #", "#   #"),
    "O": (" ### ", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "),
    "P": ("#### ", "#   #", "#   #", "#### ", "#    ", "#    ", "#    "),
    "Q": (" ### ", "#   #", "#   #", "#   #", "# # #", "#  # ", " ## #"),
    "R": ("#### ", "#   #", "#   #", "#### ", "# #  ", "#  # ", "#   #"),
    "S": (" ####", "#    ", "#    ", " ### ", "    #", "    #", "#### "),
    "T": ("#####", "  #  ", "  #  ", "  #  ", "  #  ", "  #  ", "  #  "),
    "U": ("#   #", "#   #", "#   #", "#   #", "#   #", "#   #", " ### "),
    "V": ("#   #", "#   #", "#   #", "#   #", "#   #", " # # ", "  #  "),
    "W": ("#   #", "#   #", "#   #", "# # #", "# # #", "## ##", "#   #"),
    "X": ("#   #", "#   #", " # # ", "  #  ", " # # ", "#   #", "#   #"),
    "Y": ("#   #", "#   #", " # # ", "  #  ", "  #  ", "  #  ", "  #  "),
    "Z": ("#####", "    #", "   # ", "  #  ", " #   ", "#    ", "#####"),
    " ": ("     ",) * 7,
    ":": ("     ", "  #  ", "     ", "     ", "     ", "  #  ", "     "),
}
GLYPH_W, GLYPH_H = 5, 7


def text_mask(text: str) -> np.ndarray:
    """The text as a boolean bitmap, 7 rows high, 6 columns per character (one of spacing).

    >>> text_mask("I").astype(int)[:, :5].sum(axis=1).tolist()
    [5, 1, 1, 1, 1, 1, 5]
    """
    upper = text.upper()
    unknown = sorted({c for c in upper if c not in _GLYPHS})
    if unknown or not upper:
        raise InputError(
            f"caption: cannot draw {''.join(unknown)!r} (letters, spaces and ':' only)"
            if unknown
            else "caption: empty text",
            field="caption",
        )
    columns = []
    for char in upper:
        rows = _GLYPHS[char]
        glyph = np.array([[c == "#" for c in row] for row in rows], dtype=bool)
        columns += [glyph, np.zeros((GLYPH_H, 1), dtype=bool)]
    return np.hstack(columns[:-1])


class CaptionStamp:
    """Draws ``text`` across the top of ``width`` x ``height`` RGB frames.

    The letters are as large as fits in 60 % of the width and an eighth of the height (at
    least one pixel per font pixel), centred on a dark box with a margin of one letter
    height's quarter. Calling the stamp on a frame returns a stamped copy.
    """

    def __init__(self, text: str, *, width: int, height: int) -> None:
        mask = text_mask(text)
        scale = max(1, min(int(0.6 * width) // mask.shape[1], (height // 8) // GLYPH_H))
        big = np.kron(mask, np.ones((scale, scale), dtype=bool))
        pad = max(2, scale * GLYPH_H // 4)
        box_h, box_w = big.shape[0] + 2 * pad, big.shape[1] + 2 * pad
        if box_w > width or box_h > height:
            raise InputError(
                f"caption: {text!r} does not fit a {width}x{height} frame", field="caption"
            )
        top, left = pad, (width - box_w) // 2
        self.box = (slice(top, top + box_h), slice(left, left + box_w))
        self.ink = np.zeros((box_h, box_w), dtype=bool)
        self.ink[pad : pad + big.shape[0], pad : pad + big.shape[1]] = big

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        out = np.array(frame, copy=True)
        region = out[self.box]
        region[...] = (region.astype(np.uint16) * 3 // 10).astype(out.dtype)  # dim the box
        region[self.ink] = 255
        return out
