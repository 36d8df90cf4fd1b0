import imageio.v3 as iio
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.stimuli.io import save_track
from app.stimuli.track import MotionTrack


@pytest.fixture
def fap_files(tmp_path):
    t = np.arange(12) / 30.0
    a, b = tmp_path / "a.fap", tmp_path / "b.fap"
    save_track(MotionTrack.from_channels(30.0, {3: 300 * np.sin(9 * t) ** 2}), a)
    save_track(MotionTrack.from_channels(30.0, {49: 20000 * t}), b)
    return a, b


@pytest.mark.gl
def test_render_pair_single_and_still(tmp_path, fap_files, tone_wav):
    a, b = fap_files
    wav = tone_wav(0.5)
    runner = CliRunner()
    res = runner.invoke(
        main,
        [
            "render",
            "pair",
            "--left",
            str(a),
            "--right",
            str(b),
            "--audio",
            str(wav),
            "--out",
            str(tmp_path / "p.mp4"),
            "--size",
            "96",
            "--mosaic-block",
            "16",
        ],
    )
    assert res.exit_code == 0, res.output
    assert (tmp_path / "p.mp4").stat().st_size > 1000 and "192x96, 12 frames" in res.output
    res = runner.invoke(
        main,
        [
            "render",
            "single",
            "--track",
            str(a),
            "--audio",
            str(wav),
            "--out",
            str(tmp_path / "s.mp4"),
            "--size",
            "96",
        ],
    )
    assert res.exit_code == 0, res.output
    res = runner.invoke(
        main,
        [
            "render",
            "still",
            "--track",
            str(a),
            "--frame",
            "5",
            "--out",
            str(tmp_path / "s.png"),
            "--size",
            "96",
        ],
    )
    assert res.exit_code == 0 and (tmp_path / "s.png").is_file()
    stills = {}
    for mode in ("edges", "msaa", "none"):  # --antialias reaches the renderer
        out = tmp_path / f"{mode}.png"
        res = runner.invoke(
            main,
            [
                "render",
                "still",
                "--track",
                str(a),
                "--frame",
                "5",
                "--out",
                str(out),
                "--size",
                "96",
                "--antialias",
                mode,
            ],
        )
        assert res.exit_code == 0, res.output
        stills[mode] = iio.imread(out)
    assert np.array_equal(stills["edges"], iio.imread(tmp_path / "s.png"))  # the default
    assert not np.array_equal(stills["edges"], stills["none"])
    assert not np.array_equal(stills["msaa"], stills["none"])
    for look in ("textured", "plain"):  # --look reaches the renderer; textured the default
        out = tmp_path / f"{look}.png"
        res = runner.invoke(
            main,
            [
                "render",
                "still",
                "--track",
                str(a),
                "--frame",
                "5",
                "--out",
                str(out),
                "--size",
                "96",
                "--look",
                look,
            ],
        )
        assert res.exit_code == 0, res.output
        stills[look] = iio.imread(out)
    assert np.array_equal(stills["textured"], stills["edges"])
    assert not np.array_equal(stills["textured"], stills["plain"])


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(look=st.text(min_size=1, max_size=12).filter(lambda t: t not in ("textured", "plain")))
def test_an_unknown_look_is_one_line_and_exit_2(tmp_path, fap_files, look):
    res = CliRunner().invoke(
        main,
        [
            "render",
            "still",
            "--track",
            str(fap_files[0]),
            "--out",
            str(tmp_path / "s.png"),
            "--look",
            look,
        ],
    )
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert "--look" in res.output


def test_bad_input_is_one_line_and_exit_2(tmp_path, fap_files):
    a, b = fap_files
    runner = CliRunner()
    res = runner.invoke(
        main,
        ["render", "still", "--track", str(a), "--frame", "99", "--out", str(tmp_path / "s.png")],
    )
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [
        "facepair: error: frame: must be a frame index in 0..11, got 99"
    ]
    res = runner.invoke(
        main,
        [
            "render",
            "pair",
            "--left",
            str(a),
            "--right",
            str(b),
            "--audio",
            str(tmp_path / "none.wav"),
            "--out",
            str(tmp_path / "x.mp4"),
        ],
    )
    assert res.exit_code == 2 and "none.wav: audio file not found" in res.output
    res = runner.invoke(
        main,
        ["render", "still", "--track", str(a), "--size", "100", "--out", str(tmp_path / "s.png")],
    )
    assert res.exit_code == 2 and "size: must be a multiple of 16" in res.output


def test_a_track_off_the_audio_is_refused_in_one_line_unless_padded(tmp_path, fap_files, tone_wav):
    a, b = fap_files  # 12 frames: 0.4 s
    args = ["render", "pair", "--left", str(a), "--right", str(b), "--audio", str(tone_wav(2.0))]
    res = CliRunner().invoke(main, [*args, "--out", str(tmp_path / "x.mp4")])
    assert res.exit_code == 2
    assert res.output.strip().splitlines() == [
        "facepair: error: a.fap: track: 0.40 s of motion for 2.00 s of speech: 1.60 s short, "
        "beyond the 0.2 s tolerance; check the file, or allow padding and cutting (--pad, or "
        "pad = true in the study file)"
    ]
    assert not (tmp_path / "x.mp4").exists()
