"""Draw docs/img/avatar-compressed.png: a compressed third-party-style avatar speaking.

The avatar is the built-in head exported by ``facepair face export`` and packed by
``gltfpack -c`` (meshopt compression, quantised attributes; gltfpack drops the extras, so the
file carries no facepair feature points, as an avatar from elsewhere carries none: its mouth is
found from ``jawOpen``). It is driven by the demo's ground-truth track
(app/data/demo/ground_truth.fap: jaw FAP 3 and lip FAP 4, 5, 51, 52) without the mosaic, at
three frames: the mouth closed, half open and at its widest; a fourth panel draws the widest
frame with the jaw alone (the lip FAPs left out, as avatars were driven before). Run (tools as in
make_compressed_avatars.py)::

    python tests/renderer/data/make_avatar_picture.py /tmp/gltftools
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import imageio.v3 as iio
import numpy as np

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "docs" / "img" / "avatar-compressed.png"


def main(tools: Path) -> None:
    from app.stimuli.fapfile import read_fap
    from app.stimuli.track import MotionTrack
    from renderer import RenderSettings, render_still
    from renderer.faceexport import export_builtin_head
    from renderer.lips import mouth_weights

    track = read_fap(ROOT / "app" / "data" / "demo" / "ground_truth.fap")
    jaw = track.dense()[:, 2]
    peak = int(np.argmax(jaw))
    half = int(np.argmin(np.abs(jaw[:peak] - jaw[peak] / 2)))
    closed = int(np.argmin(jaw))
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        head = export_builtin_head(tmp / "head.glb")
        packed = tmp / "avatar.glb"
        subprocess.run(
            [str(tools / "node_modules" / ".bin" / "gltfpack"), "-i", str(head), "-o", str(packed)]
            + ["-c"],
            check=True,
            stderr=subprocess.DEVNULL,
        )
        settings = RenderSettings(face=str(packed), size=256)
        images = []
        for k, frame in enumerate((closed, half, peak)):
            path = render_still(track, frame, tmp / f"{k}.png", settings=settings, mosaic=False)
            images.append(iio.imread(path))
        # the widest frame again with the jaw alone, as avatars were driven before the lips
        jaw_only = MotionTrack.from_channels(track.fps, {3: jaw})
        path = render_still(jaw_only, peak, tmp / "jaw.png", settings=settings, mosaic=False)
        images.append(iio.imread(path))
        print(f"{packed.stat().st_size} bytes packed from {head.stat().st_size}")
    iio.imwrite(OUT, np.concatenate(images, axis=1))
    lips = mouth_weights(track.dense()[peak])
    print(
        f"{OUT}: frames {closed}, {half}, {peak}; at {peak} jaw FAP 3 = {jaw[peak]:g}, "
        f"mouthUpperUp {float(lips['MouthUpperUpLeft']):.2f}, "
        f"mouthLowerDown {float(lips['MouthLowerDownLeft']):.2f}"
    )


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/gltftools"))
