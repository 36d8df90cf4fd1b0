"""A study file whose conditions are a FaceFormer-layout vertex sequence, a BIWI-layout one and a
FLAME parameter sequence, and whose ground truth is a vertex sequence: created, generated and
rendered by the jobs, each mesh beside the built-in head under the mosaic."""

import shutil

import imageio.v3 as iio
import numpy as np
import pytest
import sqlalchemy as sa

from app.errors import InputError
from app.stimuli.io import load_track
from app.stimuli.meshes.regions import speech_energy
from app.stimuli.meshes.source import mesh_of
from app.trials.studyfile import loads_study
from app.web.extensions import db
from app.web.infra.storage import media_dir
from app.web.models import Stimulus, Study, Track
from app.web.study.studies import create_study
from tests.conftest import create_test_user
from tests.stimuli.meshes.synthetic import (
    flame_like_model,
    head_mesh,
    opening_from_energy,
    talking,
    write_flame_pkl,
    write_layout,
)

DEMO = "app/data/demo/speech.wav"

TOML = """
title = "Mesh conditions"
question = "Which face moves more naturally?"
design = "reference"
reference = "none"
practice = false
eyes = "generated"

[render]
size = 96
mosaic_block = 12

[meshes]
fps = 30
flame_model = "model/generic_model.pkl"

[[conditions]]
name = "none"

[[conditions]]
name = "faceformer"
tracks = { s1 = "ff/s1.npy" }

[[conditions]]
name = "codetalker_biwi"
tracks = { s1 = "biwi/s1.npy" }
mesh = { fps = 25, units = "biwi" }

[[conditions]]
name = "diffposetalk"
tracks = { s1 = "dpt/s1.npz" }
mesh = { fps = 25 }

[[clips]]
name = "s1"
audio = "s1.wav"
ground_truth = "gt/s1.npy"
"""


@pytest.fixture
def study_folder(tmp_path):
    shutil.copyfile(DEMO, tmp_path / "s1.wav")
    head = head_mesh(24, 30)
    at30 = opening_from_energy(speech_energy(DEMO, 30.0, 120))
    at25 = opening_from_energy(speech_energy(DEMO, 25.0, 100))
    write_layout(tmp_path / "gt", "s1", head, talking(head, at30), flat=True)
    write_layout(tmp_path / "ff", "s1", head, talking(head, np.roll(at30, 2)), flat=True)
    scan = head_mesh(24, 30, eyes=False)
    write_layout(tmp_path / "biwi", "s1", scan, talking(scan, at25), flat=True, scale=0.2)
    (tmp_path / "model").mkdir()
    write_flame_pkl(tmp_path / "model" / "generic_model.pkl", flame_like_model(head))
    pose = np.zeros((100, 6))
    pose[:, 3] = at25
    (tmp_path / "dpt").mkdir()
    np.savez(tmp_path / "dpt" / "s1.npz", exp=np.zeros((100, 50)), pose=pose, shape=np.zeros(100))
    return tmp_path


@pytest.mark.gl
def test_a_study_of_mesh_conditions_generates_and_renders(app, study_folder):
    from app.web.jobs.bodies import generate_tracks, render_clips

    spec = loads_study(TOML, base_dir=study_folder)
    assert spec.meshes["fps"] == 30.0 and spec.conditions[2].mesh == {"fps": 25.0, "units": "biwi"}
    with app.app_context():
        study = create_study(create_test_user(), spec)
        db.session.commit()
        root = media_dir(study)
        # the templates went with their vertex files, the model with [meshes]
        assert (root / "uploads" / "faceformer" / "s1" / "s1.obj").is_file()
        assert (root / "clips" / "s1" / "ground_truth.obj").is_file()
        assert study.settings["meshes"]["flame_model"] == "meshes/flame_model.pkl"
        message = generate_tracks(db.session.get(Study, study.id), lambda done, total: None)
        assert message.startswith("4 tracks generated")
        tracks = {t.condition.name: t for t in db.session.scalars(sa.select(Track))}
        for name in ("faceformer", "codetalker_biwi", "diffposetalk"):
            track = load_track(root / tracks[name].path)
            seq = mesh_of(track)
            assert seq is not None and seq.n_frames == track.n_frames, name
        built_in = load_track(root / tracks["none"].path)
        assert not any(built_in.get(c).any() for c in (19, 20, 21, 22))  # no blinks: match
        render_clips(db.session.get(Study, study.id), lambda done, total: None)
        stimuli = db.session.scalars(sa.select(Stimulus)).all()
        assert len(stimuli) == 6 and all(s.video_path for s in stimuli)
        frame = iio.imread(root / stimuli[0].video_path, index=60)
    assert frame.shape[:2] == (96, 192)
    for side in (frame[:, :96], frame[:, 96:]):  # a face on each side
        assert np.abs(side.astype(int) - frame[0, 0].astype(int)).sum(axis=2).max() > 60


def test_mesh_tables_are_checked_in_one_line(study_folder):
    bad = TOML.replace('mesh = { fps = 25, units = "biwi" }', 'mesh = { fps = 25, units = "feet" }')
    with pytest.raises(InputError) as err:
        loads_study(bad, base_dir=study_folder)
    assert str(err.value) == (
        "study.toml: conditions[2].mesh.units: expected one of auto, m, cm, mm, biwi, got 'feet'"
    )
    bad = TOML.replace("fps = 30\n", "fps = -1\n")
    with pytest.raises(InputError, match="meshes.fps: must be a frame rate above 0"):
        loads_study(bad, base_dir=study_folder)
    bad = TOML.replace('flame_model = "model/generic_model.pkl"', 'flame_model = "nope.pkl"')
    with pytest.raises(InputError, match="meshes.flame_model: no such file"):
        loads_study(bad, base_dir=study_folder)
    again = loads_study(loads_study(TOML, base_dir=study_folder).to_toml(), base_dir=study_folder)
    assert again.conditions[3].mesh == {"fps": 25.0}
