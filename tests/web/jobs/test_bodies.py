"""The job bodies: generation hands each condition its model, a render draws what each study asks
for; a job keeps its heartbeat while it works."""

from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa

from app.errors import InputError
from app.stimuli.generate import generate_conditions
from app.stimuli.io import load_track
from app.stimuli.shared import differing_channels
from app.trials.studyfile import loads_study
from app.web.extensions import db
from app.web.infra.storage import media_dir
from app.web.models import Job, Study, Track
from app.web.study.studies import create_study
from tests.conftest import create_test_user, write_tone_wav
from tests.support.jobrows import add_job, job_row
from tests.support.studies import NAMED_CONDITIONS


def test_named_conditions_keep_their_model_settings_and_render_settings(app, tmp_path):
    from app.web.jobs.bodies import generate_tracks

    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    spec = loads_study(NAMED_CONDITIONS.format(), base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        assert study.settings["render"] == {"size": 128, "mosaic_block": 16}
        assert study.settings["eyes"] == "still"
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        assert message == "2 tracks generated"
        paths = {
            t.condition.name: media_dir(study) / t.path
            for t in db.session.scalars(sa.select(Track))
        }
    calm, lively = load_track(paths["calm"]), load_track(paths["lively"])
    direct = generate_conditions(
        tmp_path / "s1.wav",
        seed=5,
        conditions={"calm": {"model": "random", "octaves": 1, "persistence": 0.5}},
    ).tracks["calm"]
    np.testing.assert_allclose(calm[48], direct[48], atol=1.0)  # .fap stores integers
    assert not np.allclose(calm[48], lively[48])


def test_a_trackers_ground_truth_is_converted_and_its_gaps_reported(app, tmp_path):
    from app.web.jobs.bodies import generate_tracks
    from tests.stimuli.capture.files import write_openface

    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    t = np.arange(30) / 30.0
    success = np.ones(30, int)
    success[10:13] = 0
    write_openface(tmp_path / "openface.csv", t, {"pose_Ry": 0.1 * np.sin(t)}, success=success)
    text = NAMED_CONDITIONS.format().replace(
        'audio = "s1.wav"', 'audio = "s1.wav"\nground_truth = "openface.csv"'
    )
    text = text.replace(
        'name = "lively"\nmodel = "random"', 'name = "truth"\nmodel = "ground_truth"'
    )
    spec = loads_study(text, base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        truth = next(t for t in db.session.scalars(sa.select(Track)) if t.condition.name == "truth")
        track = load_track(media_dir(study) / truth.path)
    assert "clip s1: ground truth imported from OpenFace 2.0 CSV ground_truth.csv" in message
    assert "3 lost, 3 frames filled by interpolation" in message
    # The head is imported relative to the take's own neutral (its median pose while tracked),
    # not the camera's axis (app.stimuli.capture.openface).
    truth = np.round(0.1 * np.sin(t), 3)
    neutral = np.median(truth[success > 0])
    np.testing.assert_allclose(track[49], -(truth - neutral) / 1e-5, atol=60)


def test_run_job_keeps_a_heartbeat(app, web, monkeypatch):
    from app.web.jobs import bodies

    beats = []

    def slow(study, progress):
        for i in range(3):
            progress(i, 3)
            beats.append(db.session.scalar(sa.select(Job.heartbeat_at)))
        return "ok"

    monkeypatch.setitem(bodies.TASKS, "render", slow)
    job_id = add_job(app, web.study(video=False))
    with app.app_context():
        assert bodies.run_job(job_id) == "done"
    assert beats[0] is not None and all(b is not None for b in beats)


def test_a_clip_longer_than_the_stale_timeout_keeps_its_job_alive(app, web, monkeypatch):
    """The renderer's per-frame progress renews the heartbeat inside one clip."""
    import time

    import renderer
    from app.web.jobs import bodies
    from app.web.jobs.sweep import sweep_stale
    from app.web.models import Clip, Condition

    app.config["JOB_STALE_AFTER_SECONDS"] = 1.0
    study_id = web.study(video=False)
    with app.app_context():
        from app.web.infra.storage import media_dir

        clip = db.session.scalar(sa.select(Clip).where(Clip.study_id == study_id))
        # a track file in place (read as nothing: load_track is stubbed below)
        media_dir(clip.study).mkdir(parents=True, exist_ok=True)
        (media_dir(clip.study) / "x.fap").write_text("# a track\n")
        for condition in db.session.scalars(
            sa.select(Condition).where(Condition.study_id == study_id)
        ):
            db.session.add(Track(condition_id=condition.id, clip_id=clip.id, path="x.fap"))
        db.session.commit()
    swept = []

    def slow_clip(left, right, audio, out, *, settings, cache_dir, progress=None, webm_path):
        for frame in range(15):  # 1.5 s for one clip: past the 1 s timeout
            time.sleep(0.1)
            if progress is not None:
                progress(frame, 15)
        swept.append(sweep_stale(study_id, stale_after=1.0))
        out.write_bytes(b"video")
        webm_path.write_bytes(b"webm")
        return out

    monkeypatch.setattr(renderer, "render_pair", slow_clip)
    monkeypatch.setattr("app.stimuli.io.load_track", lambda path: None)
    job_id = add_job(app, study_id)
    with app.app_context():
        assert bodies.run_job(job_id) == "done"
    assert swept and not any(swept)
    assert job_row(app, job_id)[0] == "done"


def test_a_progress_report_the_database_cannot_take_is_skipped(app, web, monkeypatch):
    """A database restart during a render loses a progress report, not the job."""
    from contextlib import contextmanager

    from sqlalchemy.exc import OperationalError

    from app.web.jobs import bodies

    @contextmanager
    def away():
        raise OperationalError("UPDATE job", {}, Exception("connection refused"))
        yield  # pragma: no cover

    job_id = add_job(app, web.study(video=False), status="running")
    with app.app_context():
        report = bodies._progress(job_id, min_interval=0.0)
        monkeypatch.setattr(bodies, "transaction", away)
        report(1, 4)  # no exception: the work goes on
        monkeypatch.undo()
        report(2, 4)
        job = db.session.get(Job, job_id)
        assert (job.done, job.total) == (2, 4) and job.heartbeat_at is not None


MISMATCHED_TOML = """
title = "Appropriateness"
question = "Which face belongs to the speech?"
design = "all_ordered"
seed = 5
practice = false
mismatched = true

[catch]
trials = 1
kind = "onscreen"

[[conditions]]
name = "calm"
model = "random"

[[conditions]]
name = "lively"
model = "random"

[[clips]]
name = "long"
audio = "long.wav"

[[clips]]
name = "short"
audio = "short.wav"
"""


def test_render_job_lends_the_other_clips_motion_and_draws_the_instruction(
    app, tmp_path, monkeypatch
):
    """An appropriateness clip shows, on its foreign side, the motion made for the next clip,
    cut or held to this clip's length; an on-screen check gets its caption."""
    import renderer
    from app.web.jobs.bodies import generate_tracks, render_clips
    from app.web.models import Stimulus

    write_tone_wav(tmp_path / "long.wav", seconds=1.0)
    write_tone_wav(tmp_path / "short.wav", seconds=0.6)
    calls = {}

    def record(
        left, right, audio, out, *, settings, cache_dir, progress=None, caption=None, webm_path
    ):
        calls[out.name] = (left, right, audio.name, caption)
        out.write_bytes(b"video")
        webm_path.write_bytes(b"webm")  # the same frames' WebM, beside the MP4
        return out

    monkeypatch.setattr(renderer, "render_pair", record)
    with app.app_context():
        study = create_study(create_test_user(), loads_study(MISMATCHED_TOML, base_dir=tmp_path))
        db.session.commit()
        generate_tracks(study, lambda done, total: None)
        render_clips(study, lambda done, total: None)
        own = {
            (t.condition.name, t.clip.name): load_track(media_dir(study) / t.path)
            for t in db.session.scalars(sa.select(Track))
        }
        stimuli = db.session.scalars(sa.select(Stimulus)).all()
        assert all(s.video_path for s in stimuli)
        assert all(s.webm_path == s.video_path.replace(".mp4", ".webm") for s in stimuli)
        foreign = {
            (s.clip.name, s.foreign_side): Path(s.video_path).name
            for s in stimuli
            if s.foreign_side and s.left.name == "calm"
        }
    left, right, audio, caption = calls[foreign[("long", "left")]]
    assert audio == "audio.wav" and caption is None
    assert right.equals(own[("calm", "long")])
    assert left.n_frames == right.n_frames  # the short clip's motion, held to length
    assert np.array_equal(
        left.values[: own[("calm", "short")].n_frames], own[("calm", "short")].values
    )
    # on the short clip, the long clip's motion is cut to the short clip's length
    left, right, _audio, _caption = calls[foreign[("short", "right")]]
    assert left.equals(own[("calm", "short")])
    assert np.array_equal(right.values, own[("calm", "long")].values[: left.n_frames])
    captions = sorted(c for _l, _r, _a, c in calls.values() if c)
    assert captions == ["press left", "press left", "press right", "press right"]


def test_a_teams_own_system_output_is_a_condition_with_its_import_said(app, tmp_path):
    """A study-file condition that reads a track file per clip: Audio2Face-3D's CSV export,
    converted from ARKit weights to FAPs and reported in the job's message."""
    from app.web.jobs.bodies import generate_tracks
    from tests.stimuli.capture.files import write_a2f3d_csv

    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    t = np.arange(30) / 30.0
    write_a2f3d_csv(
        tmp_path / "ours_s1.csv",
        t,
        {"BrowInnerUp": np.where(t > 0.5, 0.4, 0.0), "JawOpen": 0.3 + 0 * t},
    )
    text = NAMED_CONDITIONS.format().replace(
        'name = "lively"\nmodel = "random"', 'name = "ours"\ntracks = { s1 = "ours_s1.csv" }'
    )
    spec = loads_study(text, base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        rows = {t.condition.name: t for t in db.session.scalars(sa.select(Track))}
        track = load_track(media_dir(study) / rows["ours"].path)
        other = load_track(media_dir(study) / rows["calm"].path)
    # the file the team uploaded is the one named, not the copy's clip name
    assert message.startswith(
        "2 tracks generated; clip s1: condition ours imported from ours_s1.csv"
    ), message
    # the export has no head rotation and all-zero columns: said, not imported as a still face
    assert "48, 49, 50 absent from the file" in message, message
    assert "their columns are 0 in every frame" in message
    assert track[31].max() == 40 and track[31][:10].max() == 0  # the inner brow raise, in FAP units
    # its zero eye columns do not make a staring face: both faces have the same eyes
    assert 19 in track.channels and 23 in track.channels
    assert differing_channels({"ours": track, "calm": other}) == []


def _upload_study(tmp_path, seconds: float, extra: str = "") -> str:
    """The study of :data:`NAMED_CONDITIONS` with a condition uploaded as a FAP track of
    ``seconds``, jaw moving."""
    from app.stimuli.fapfile import write_fap
    from app.stimuli.track import MotionTrack

    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    n = round(seconds * 30)
    jaw = 400 * np.sin(np.linspace(0, 6, n)) ** 2
    write_fap(MotionTrack.from_channels(30.0, {3: jaw, 48: 100 * jaw}), tmp_path / "Our Take.fap")
    return extra + NAMED_CONDITIONS.format().replace(
        'name = "lively"\nmodel = "random"', 'name = "ours"\ntracks = { s1 = "Our Take.fap" }'
    )


def test_an_upload_off_its_audio_is_refused_at_upload_unless_the_study_pads(app, tmp_path):
    from app.web.jobs.bodies import generate_tracks
    from app.web.study.inputs import check_study_inputs

    spec = loads_study(_upload_study(tmp_path, 0.5), base_dir=tmp_path)
    with pytest.raises(InputError) as err:
        check_study_inputs(spec)
    line = str(err.value)
    assert line.startswith("Our Take.fap: condition ours, clip s1: track: 0.50 s of motion"), line
    assert "0.50 s short, beyond the 0.2 s tolerance" in line and "pad = true" in line
    spec = loads_study(_upload_study(tmp_path, 0.5, "pad = true\n"), base_dir=tmp_path)
    check_study_inputs(spec)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
    assert (
        "clip s1: Our_Take.fap: condition ours: 0.50 s of motion for 1.00 s of speech: " in message
    )
    assert "the last 0.50 s hold its last frame" in message


@pytest.mark.parametrize(("mosaic", "shared"), [(16, True), (0, False)])
def test_the_lower_face_is_shared_under_the_mosaic_and_own_without(app, tmp_path, mosaic, shared):
    from app.web.jobs.bodies import generate_tracks

    text = _upload_study(tmp_path, 1.0).replace("mosaic_block = 16", f"mosaic_block = {mosaic}")
    spec = loads_study(text, base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        rows = {t.condition.name: t for t in db.session.scalars(sa.select(Track))}
        tracks = {n: load_track(media_dir(study) / r.path) for n, r in rows.items()}
    # the uploaded jaw is the only one moving: under the mosaic both faces carry it
    assert tracks["ours"][3].max() > 0
    assert (differing_channels(tracks) == []) is shared
    assert ("each condition keeps its own jaw and lip motion" in message) is not shared
    if not shared:
        assert differing_channels(tracks) == [3]


def test_render_job_renders_one_face_per_condition_and_clip_in_the_rating_design(
    app, tmp_path, monkeypatch
):
    """A rating study's stimuli are single faces (``renderer.render_single``), one per
    condition and clip, each the condition's own track; no side-by-side clip is rendered."""
    import renderer
    from app.web.jobs.bodies import generate_tracks, render_clips
    from app.web.models import Stimulus

    write_tone_wav(tmp_path / "long.wav", seconds=0.6)
    write_tone_wav(tmp_path / "short.wav", seconds=0.4)
    singles: dict[str, object] = {}

    def single(track, audio, out, *, settings, cache_dir, progress=None, webm_path):
        singles[out.name] = track
        out.write_bytes(b"video")
        webm_path.write_bytes(b"webm")
        return out

    def pair(*args, **kwargs):
        raise AssertionError("a rating study renders no pair")

    monkeypatch.setattr(renderer, "render_single", single)
    monkeypatch.setattr(renderer, "render_pair", pair)
    text = (
        MISMATCHED_TOML.replace("mismatched = true\n", "")
        .replace("practice = false\n", "")
        .replace('design = "all_ordered"', 'design = "rating"')
        .replace('kind = "onscreen"', 'kind = "instructed"')
    )
    with app.app_context():
        study = create_study(create_test_user(), loads_study(text, base_dir=tmp_path))
        db.session.commit()
        generate_tracks(study, lambda done, total: None)
        render_clips(study, lambda done, total: None)
        own = {
            (t.condition.name, t.clip.name): load_track(media_dir(study) / t.path)
            for t in db.session.scalars(sa.select(Track))
        }
        stimuli = db.session.scalars(sa.select(Stimulus)).all()
        assert len(stimuli) == 4 and all(s.left_id == s.right_id for s in stimuli)
        for s in stimuli:
            assert singles[Path(s.video_path).name].equals(own[(s.left.name, s.clip.name)])


@pytest.mark.gl
@pytest.mark.parametrize("kind", ["facecap", "rpm", "vroid", "vrm1", "mixamo", "exported"])
def test_a_study_renders_its_pairs_with_an_avatar_of_each_structure(app, tmp_path, kind):
    """[render] face names an avatar uploaded with the study file; the render job draws every
    clip with it (tests/renderer/avatar_fixtures.py: the structures other tools write)."""
    import imageio.v3 as iio

    from app.web.jobs.bodies import generate_tracks, render_clips
    from app.web.models import Stimulus
    from tests.renderer.avatar_fixtures import build_avatar

    if kind == "exported":  # facepair face export, loaded back as an avatar
        from renderer.faceexport import export_builtin_head

        avatar = export_builtin_head(tmp_path / "exported.glb")
    else:
        avatar = build_avatar(kind, tmp_path)
    write_tone_wav(tmp_path / "s1.wav", seconds=0.3)
    text = NAMED_CONDITIONS.format().replace(
        "[render]\nsize = 128\nmosaic_block = 16",
        f'[render]\nsize = 64\nmosaic_block = 8\nface = "{avatar.name}"',
    )
    spec = loads_study(text, base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        study = db.session.get(Study, study.id)
        assert study.settings["render"]["face"] == f"render/{avatar.name}"
        generate_tracks(study, lambda done, total: None)
        render_clips(study, lambda done, total: None)
        videos = [
            media_dir(study) / s.video_path
            for s in db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id))
        ]
    assert videos and all(v.is_file() for v in videos)
    frame = iio.imread(videos[0], index=3)
    assert frame.shape == (64, 128, 3) and frame.mean() > 60  # lit faces, not black
