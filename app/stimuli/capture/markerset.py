"""The thesis' marker set: 13 retro-reflective face markers and the 4 posts of a head frame.

Thesis sec. 3.2.1 and 4.1: thirteen small markers on the face (inner and middle eyebrows;
the outer ones were dropped because yaw hid them), four on the lips (top, bottom and the two
corners, after eight made the labelling swap labels), the nose bridge (the fiducial of the
eyebrow distances, sec. 3.2.4), and cheeks, nose tip and chin; plus the markers TL, TR, BL, BR
on the left and right posts of a light head-mounted frame, 17 in all (sec. 5: "17 markers").
The thesis lists the regions, not every site; the nose tip and chin markers are this
reconstruction's reading of "eyebrows, cheeks, nose, lips, and chin".

Sites are MPEG-4 feature points where the standard has one, else a position relative to the
eye line in FAPU (x in ES0 towards the face's left, y in ENS0 up). "Left" and "right" of a
face marker are the face's own (MPEG-4); the post markers are named as the camera sees them
(TL is top left in the image, on the face's right), as the thesis' figures 12 and 14 draw them.

:data:`NEUTRAL_LAYOUT` is where each face marker lies inside the frame in the neutral pose,
as fractions of the frame (``u`` from the left posts to the right, ``v`` from the top markers
to the bottom ones): the "relative location" the first frame's labelling relies on (sec.
3.1.3). It was measured on the built-in head wearing :data:`HEAD_FRAME` (a test keeps the two
in step); a subject whose markers sit elsewhere gives their own layout.

Example
-------
>>> len(MARKERS), MARKERS[:4]
(17, ('TL', 'TR', 'BL', 'BR'))
>>> SITES["brow_inner_l"].feature_point
'4.1'
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Site:
    """Where a face marker sits: an MPEG-4 feature point, or ``(x, y)`` from the eye line.

    ``x`` in ES0 (positive to the face's left), ``y`` in ENS0 (positive up), measured from
    the midpoint of the pupils (3.5, 3.6); the marker is on the skin in front of that point.
    """

    feature_point: str | None
    x: float = 0.0
    y: float = 0.0


#: The head-mounted frame's post markers, as the camera sees them.
POSTS: tuple[str, ...] = ("TL", "TR", "BL", "BR")

#: The 13 face markers and their sites (thesis sec. 3.2.1, 4.1).
SITES: dict[str, Site] = {
    "brow_inner_l": Site("4.1"),
    "brow_inner_r": Site("4.2"),
    "brow_middle_l": Site("4.3"),
    "brow_middle_r": Site("4.4"),
    # at the eye line, where the eyebrows' zones end: the fiducial the eyebrows are measured
    # from must not move with them
    "nose_bridge": Site(None, 0.0, -0.1),
    "nose_tip": Site("9.3", 0.0, -0.45),
    "cheek_l": Site(None, 0.61, -0.62),
    "cheek_r": Site(None, -0.61, -0.62),
    "lip_top": Site("8.1"),
    "lip_bottom": Site("8.2"),
    "lip_corner_l": Site("8.3"),
    "lip_corner_r": Site("8.4"),
    "chin": Site("2.10", 0.0, -2.0),
}

#: Every marker: the four posts first, then the face.
MARKERS: tuple[str, ...] = POSTS + tuple(SITES)


@dataclass(frozen=True)
class HeadFrame:
    """The head-mounted frame: two vertical posts beside the face, rigid with the head.

    ``half_width`` (ES0) is each post's distance from the midline, ``top`` and ``bottom``
    (ENS0) the heights of its markers above the eye line (negative: below), ``depth`` (ENS0)
    the posts' distance in front of the pupils' plane (negative: behind). The bottom markers
    hang below the chin, so that the two uppermost and the two bottommost markers in the
    image are the frame's, as the thesis' labelling assumes.
    """

    half_width: float = 1.37
    top: float = 1.18
    bottom: float = -2.29
    depth: float = -0.42


HEAD_FRAME = HeadFrame()

#: Face markers' neutral places inside the frame: (u, v) fractions (see the module text).
NEUTRAL_LAYOUT: dict[str, tuple[float, float]] = {
    "brow_inner_l": (0.594, 0.233),
    "brow_inner_r": (0.406, 0.233),
    "brow_middle_l": (0.682, 0.208),
    "brow_middle_r": (0.318, 0.208),
    "nose_bridge": (0.500, 0.371),
    "nose_tip": (0.500, 0.559),
    "cheek_l": (0.729, 0.513),
    "cheek_r": (0.271, 0.513),
    "lip_top": (0.500, 0.711),
    "lip_bottom": (0.500, 0.834),
    "lip_corner_l": (0.666, 0.746),
    "lip_corner_r": (0.334, 0.746),
    "chin": (0.500, 0.947),
}
