"""The generate job hands each condition its model and settings, and the study its settings."""

import numpy as np
import sqlalchemy as sa

from app.extensions import db
from app.models import Study, Track
from app.stimuli.generate import generate_conditions
from app.stimuli.io import load_track
from app.storage import media_dir
from app.studies import create_study
from app.trials.studyfile import loads_study
from tests.conftest import create_test_user, write_tone_wav

TOML = """
title = "Named conditions"
question = "Which face moves more naturally?"
design = "unordered_counterbalanced"
seed = 5
eyes = "still"
practice = false

[render]
size = 128
mosaic_block = 16

[[conditions]]
name = "calm"
model = "random"
settings = {{ octaves = 1, persistence = 0.5 }}

[[conditions]]
name = "lively"
model = "random"

[[clips]]
name = "s1"
audio = "s1.wav"
"""


def test_named_conditions_keep_their_model_settings_and_render_settings(app, tmp_path):
    from app.jobs.tasks import generate_tracks

    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    spec = loads_study(TOML.format(), base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        assert study.settings["render"] == {"size": 128, "mosaic_block": 16}
        assert study.settings["eyes"] == "still"
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        assert message == "2 tracks generated"
        paths = {t.condition.name: media_dir(study) / t.path
                 for t in db.session.scalars(sa.select(Track))}
    calm, lively = load_track(paths["calm"]), load_track(paths["lively"])
    direct = generate_conditions(tmp_path / "s1.wav", seed=5, conditions={
        "calm": {"model": "random", "octaves": 1, "persistence": 0.5}}).tracks["calm"]
    np.testing.assert_allclose(calm[48], direct[48], atol=1.0)  # .fap stores integers
    assert not np.allclose(calm[48], lively[48])


def test_a_trackers_ground_truth_is_converted_and_its_gaps_reported(app, tmp_path):
    from app.jobs.tasks import generate_tracks
    from tests.stimuli.capture.files import write_openface

    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    t = np.arange(30) / 30.0
    success = np.ones(30, int)
    success[10:13] = 0
    write_openface(tmp_path / "openface.csv", t, {"pose_Ry": 0.1 * np.sin(t)}, success=success)
    text = TOML.format().replace('audio = "s1.wav"', 'audio = "s1.wav"\nground_truth = '
                                                      '"openface.csv"')
    text = text.replace('name = "lively"\nmodel = "random"', 'name = "truth"\nmodel = '
                                                               '"ground_truth"')
    spec = loads_study(text, base_dir=tmp_path)
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        truth = next(t for t in db.session.scalars(sa.select(Track))
                     if t.condition.name == "truth")
        track = load_track(media_dir(study) / truth.path)
    assert "clip s1: ground truth imported from OpenFace 2.0 CSV ground_truth.csv" in message
    assert "3 lost, 3 frames filled by interpolation" in message
    np.testing.assert_allclose(track[49], -0.1 * np.sin(np.arange(30) / 30.0) / 1e-5, atol=60)
