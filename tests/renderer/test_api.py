"""Clips decoded back: frame count and rate, size, audio length, mosaic, order, cache."""

import subprocess

import imageio_ffmpeg
import numpy as np
import pytest

from app.errors import InputError
from renderer import RenderSettings, render_pair, render_single, render_still
from renderer.headmodel import builtin_face
from renderer.pipeline import render_frames
from tests.support.clips import decode, moving_tracks

SIZE = 160
SETTINGS = RenderSettings(size=SIZE, mosaic_block=16)


def audio_seconds(path, rate=16000):
    out = subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(),
            "-v",
            "error",
            "-i",
            str(path),
            "-map",
            "0:a:0",
            "-f",
            "s16le",
            "-ac",
            "1",
            "-ar",
            str(rate),
            "-",
        ],
        capture_output=True,
        check=True,
    ).stdout
    return len(out) / 2 / rate


@pytest.mark.gl
@pytest.mark.parametrize("audio_len", [0.7, 3.0])
def test_pair_clip_decodes_with_track_length_rate_size_and_audio(tmp_path, tone_wav, audio_len):
    a, b = moving_tracks()
    out = render_pair(a, b, tone_wav(audio_len), tmp_path / "clip.mp4", settings=SETTINGS)
    meta, frames = decode(out)
    assert len(frames) == 45
    assert meta["fps"] == pytest.approx(30.0)
    assert tuple(meta["size"]) == (2 * SIZE, SIZE)
    assert meta["codec"].startswith("h264") and meta["pix_fmt"] == "yuv420p"
    assert audio_seconds(out) == pytest.approx(1.5, abs=0.05)  # padded or trimmed to 1.5 s
    head = out.read_bytes()[:4096]
    assert head.find(b"moov") != -1 and head.find(b"moov") < max(head.find(b"mdat"), 4096)


@pytest.mark.gl
def test_mosaic_blocks_survive_encoding_within_codec_tolerance(tmp_path, tone_wav):
    a, b = moving_tracks(20)
    out = render_pair(a, b, tone_wav(1.0), tmp_path / "clip.mp4", settings=SETTINGS)
    _, frames = decode(out)
    raw = render_frames(
        [a, b],
        builtin_face(),
        size=SIZE,
        samples=4,
        background=SETTINGS.background,
        mosaic_block=16,
        mosaic_margin=0.15,
    )
    checked = 0
    for fr, dec in zip(raw, frames, strict=True):
        for x0, y0, x1, y1 in fr.boxes:
            for by in range(y0, y1, 16):
                for bx in range(x0, x1, 16):
                    cell = fr.image[by : by + 16, bx : bx + 16]
                    if not (cell == cell[0, 0]).all():  # on the face's outline
                        continue
                    checked += 1
                    inner = dec[by + 3 : by + 13, bx + 3 : bx + 13].astype(float)
                    assert inner.std(axis=(0, 1)).max() < 4.0
                    assert np.abs(inner.mean(axis=(0, 1)) - fr.image[by, bx]).max() < 12
    assert checked > 20 * 2 * 4


@pytest.mark.gl
def test_swapping_sides_swaps_the_halves(tmp_path):
    a, b = moving_tracks(3)
    ab = render_still(a, 2, tmp_path / "ab.png", right=b, settings=SETTINGS)
    ba = render_still(b, 2, tmp_path / "ba.png", right=a, settings=SETTINGS)
    import imageio.v3 as iio

    x, y = iio.imread(ab), iio.imread(ba)
    assert x.shape == (SIZE, 2 * SIZE, 3)
    assert np.array_equal(x[:, :SIZE], y[:, SIZE:]) and np.array_equal(x[:, SIZE:], y[:, :SIZE])


@pytest.mark.gl
def test_single_clip_and_still(tmp_path, tone_wav):
    a, _ = moving_tracks(10)
    out = render_single(a, tone_wav(1.0), tmp_path / "one.mp4", settings=SETTINGS)
    meta, frames = decode(out)
    assert len(frames) == 10 and tuple(meta["size"]) == (SIZE, SIZE)
    png = render_still(a, 4, tmp_path / "s.png", settings=SETTINGS, mosaic=False)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.gl
def test_cache_serves_the_same_render_and_never_a_stale_one(tmp_path, tone_wav):
    a, b = moving_tracks(8)
    audio = tone_wav(1.0)
    calls = []
    cache = tmp_path / "cache"
    first = render_pair(
        a,
        b,
        audio,
        tmp_path / "1.mp4",
        settings=SETTINGS,
        cache_dir=cache,
        progress=lambda d, n: calls.append(d),
    )
    assert len(calls) == 8
    calls.clear()
    second = render_pair(
        a,
        b,
        audio,
        tmp_path / "2.mp4",
        settings=SETTINGS,
        cache_dir=cache,
        progress=lambda d, n: calls.append(d),
    )
    assert calls == [8] and second.read_bytes() == first.read_bytes()
    changed = b.with_channels({31: b[31] + 1.0})
    render_pair(
        a,
        changed,
        audio,
        tmp_path / "3.mp4",
        settings=SETTINGS,
        cache_dir=cache,
        progress=lambda d, n: calls.append(d),
    )
    assert len(calls) == 1 + 8
    assert len(list(cache.glob("*.mp4"))) == 2


@pytest.mark.gl
def test_the_webm_rendition_shows_the_same_frames_and_is_cached_beside_the_mp4(tmp_path, tone_wav):
    """One render writes both renditions from the same frames; the cache hands back both,
    and a WebM asked of a cached MP4 that has none renders the clip again."""
    a, b = moving_tracks(8)
    audio = tone_wav(1.0)
    cache = tmp_path / "cache"
    render_pair(a, b, audio, tmp_path / "0.mp4", settings=SETTINGS, cache_dir=cache)
    calls = []
    first = render_pair(
        a,
        b,
        audio,
        tmp_path / "1.mp4",
        settings=SETTINGS,
        cache_dir=cache,
        webm_path=tmp_path / "1.webm",
        progress=lambda d, n: calls.append(d),
    )
    assert len(calls) == 8  # the cached MP4 alone did not serve
    mp4_meta, mp4_frames = decode(first)
    webm_meta, webm_frames = decode(tmp_path / "1.webm")
    assert webm_meta["codec"] == "vp9" and webm_meta["size"] == mp4_meta["size"]
    assert len(webm_frames) == len(mp4_frames) == 8
    for x, y in zip(webm_frames, mp4_frames, strict=True):  # both near the same drawing
        assert np.abs(x.astype(int) - y.astype(int)).mean() < 3
    assert abs(audio_seconds(tmp_path / "1.webm") - 8 / 30) < 0.025
    calls.clear()
    render_pair(
        a,
        b,
        audio,
        tmp_path / "2.mp4",
        settings=SETTINGS,
        cache_dir=cache,
        webm_path=tmp_path / "2.webm",
        progress=lambda d, n: calls.append(d),
    )
    assert calls == [8]
    assert (tmp_path / "2.webm").read_bytes() == (tmp_path / "1.webm").read_bytes()


def test_bad_settings_and_audio_are_input_errors(tmp_path):
    with pytest.raises(InputError, match="size: must be a multiple of 16"):
        RenderSettings(size=100)
    with pytest.raises(InputError, match="mosaic_block"):
        RenderSettings(mosaic_block=-1)
    with pytest.raises(InputError, match="antialias: must be one of edges, msaa, none"):
        RenderSettings(antialias="fxaa")
    with pytest.raises(InputError, match="encode_threads: must be a whole number"):
        RenderSettings(encode_threads=True)
    a, b = moving_tracks(3)
    with pytest.raises(InputError, match="audio file not found"):
        render_pair(a, b, tmp_path / "missing.wav", tmp_path / "x.mp4", settings=SETTINGS)
