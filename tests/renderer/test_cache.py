import numpy as np

from app.stimuli.track import MotionTrack
from renderer import RenderSettings
from renderer.cache import cache_key, file_digest, track_digest


def _key(tracks, audio, settings=None, face="f", version="1"):
    settings = settings or RenderSettings()
    return cache_key("pair", tracks, audio, face, settings, version)


def test_key_changes_with_every_input(tmp_path):
    a = MotionTrack.from_channels(30.0, {3: np.arange(5.0)})
    b = MotionTrack.from_channels(30.0, {49: np.zeros(5)})
    wav = tmp_path / "a.wav"
    wav.write_bytes(b"RIFF0000")
    base = _key([a, b], wav)
    assert base == _key([a, b], wav)
    assert base != _key([b, a], wav)  # side order matters
    assert base != _key([a.with_channels({3: np.arange(5.0) + 1e-9}), b], wav)
    assert base != _key([a, b], wav, settings=RenderSettings(mosaic_block=32))
    assert base != _key([a, b], wav, settings=RenderSettings(antialias="msaa"))
    assert base != _key([a, b], wav, settings=RenderSettings(encode_threads=0))
    # what does not change the clip does not change the key
    assert base == _key([a, b], wav, settings=RenderSettings(workers=3))
    assert base == _key([a, b], wav, settings=RenderSettings(samples=8))  # not multisampling
    assert _key([a, b], wav, settings=RenderSettings(antialias="msaa", samples=2)) != _key(
        [a, b], wav, settings=RenderSettings(antialias="msaa", samples=8)
    )
    assert base != _key([a, b], wav, face="g")
    assert base != _key([a, b], wav, version="2")
    wav.write_bytes(b"RIFF0001")
    assert base != _key([a, b], wav)


def test_track_digest_ignores_names_but_not_fps():
    a = MotionTrack.from_channels(30.0, {3: np.arange(5.0)}, name="x")
    assert track_digest(a) == track_digest(a.replace(name="y"))
    assert track_digest(a) != track_digest(a.replace(fps=25.0))
    assert file_digest(None) == ""
