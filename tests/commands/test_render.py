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
