"""The web form takes a mesh condition: ``<condition>__<clip>.npy`` with its template beside it
under its name, and the frame rate of mesh tracks."""

import io
import re
import shutil

import numpy as np
import sqlalchemy as sa

from app.web.extensions import db
from app.web.infra.storage import media_dir
from app.web.models import Study
from tests.stimuli.meshes.synthetic import head_mesh, talking, write_layout

DEMO = "app/data/demo/speech.wav"


def _form(client, tmp_path, mesh_fps):
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    token = re.search(r'name="web-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    head = head_mesh(12, 16, eyes=False)
    npy = write_layout(
        tmp_path, "faceformer__clip_a", head, talking(head, np.zeros(120)), flat=True
    )
    # float32, as the projects save it: the request stays under the 500 kB that the test
    # client would spool to a temporary file it never closes
    np.save(npy, np.load(npy).astype(np.float32))
    wav = tmp_path / "clip_a.wav"
    shutil.copyfile(DEMO, wav)
    data = {
        "web-csrf_token": token,
        "web-submit": "1",
        "web-title": "Mesh study",
        "web-question": "Which one?",
        "web-models": ["none"],
        "web-audio": [(io.BytesIO(wav.read_bytes()), "clip_a.wav")],
        "web-tracks": [
            (io.BytesIO(npy.read_bytes()), "faceformer__clip_a.npy"),
            (io.BytesIO(npy.with_suffix(".obj").read_bytes()), "faceformer__clip_a.obj"),
        ],
        "web-design": "all_ordered",
        "web-replay": "unlimited",
        "web-catch_trials": "0",
        "web-target_participants": "4",
        "web-undecided_allowed": "y",
        "web-undecided_label": "Same",
        "web-rejoin": "refuse",
    }
    if mesh_fps:
        data["web-mesh_fps"] = mesh_fps
    return client.post("/experimenter/studies/new", content_type="multipart/form-data", data=data)


def test_a_mesh_track_and_its_template_make_a_condition(app, client, web, tmp_path):
    web.user()
    web.login(client)
    response = _form(client, tmp_path, "30")
    assert response.status_code == 302, response.get_data(as_text=True)
    with app.app_context():
        study = db.session.scalar(sa.select(Study).where(Study.title == "Mesh study"))
        assert [c.name for c in study.conditions] == ["none", "faceformer"]
        assert study.settings["meshes"]["fps"] == 30.0
        folder = media_dir(study) / "uploads" / "faceformer" / "clip_a"
        assert sorted(p.name for p in folder.iterdir()) == [
            "faceformer__clip_a.npy",
            "faceformer__clip_a.obj",
        ]


def test_without_the_frame_rate_the_mesh_is_refused_in_one_line(app, client, web, tmp_path):
    web.user()
    web.login(client)
    response = _form(client, tmp_path, None)
    assert response.status_code == 400
    page = response.get_data(as_text=True).replace("&#39;", "'")
    assert "faceformer__clip_a.npy" in page and "give the sequence's frame rate" in page
