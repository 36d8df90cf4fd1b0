"""The leaderboard's web side (``app.web.leaderboard``, ``app.web.board``): a season made from
its file, submissions through the JSON API and the form refused with one line per problem,
the private preview, the public pages before any round; no request answered with a 5xx."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.leaderboard.demo import write_benchmark, write_systems
from app.leaderboard.season import load_season_file
from tests.conftest import create_test_user

ORGANISER = "org@example.org"


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> tuple[Path, dict[str, list[Path]]]:
    folder = tmp_path_factory.mktemp("lb")
    season_file = write_benchmark(folder / "bench", organiser=ORGANISER)
    return season_file, write_systems(folder / "bench", folder / "systems")


@pytest.fixture
def season(app, inputs, monkeypatch):
    """The demo season on the test database; jobs (renders) are not started."""
    from app.web.board import seasons
    from app.web.board.seasons import create_season
    from app.web.extensions import db
    from app.web.leaderboard import submit

    started: list[int] = []
    monkeypatch.setattr(submit, "start_jobs", lambda app, jobs: started.extend(jobs))
    monkeypatch.setattr(seasons, "start_jobs", lambda app, jobs: started.extend(jobs))
    season_file, _ = inputs
    with app.app_context():
        create_test_user(ORGANISER)
        spec = load_season_file(season_file)
        made, _jobs = create_season(spec, season_file.read_text())
        db.session.commit()
        name = made.name
    return name


def _files(paths: list[Path]) -> list[tuple[io.BytesIO, str]]:
    return [(io.BytesIO(p.read_bytes()), p.name) for p in paths]


def _form(system: str = "Sys", **extra) -> dict:
    return {
        "system": system,
        "team": "Team",
        "contact": "team@example.org",
        "training_data": "our corpus",
        "licence": "1",
        **extra,
    }


def test_a_passing_submission_gets_a_private_preview(app, client, season, inputs) -> None:
    from app.web.board.models import BoardSystem
    from app.web.extensions import db

    _, systems = inputs
    answer = client.post(
        f"/leaderboard/{season}/api/submissions",
        data={**_form("ProsodyARX"), "files": _files(systems["ProsodyARX"])},
        content_type="multipart/form-data",
    )
    assert answer.status_code == 201, answer.get_json()
    body = answer.get_json()
    assert body["key"] and body["code"].startswith("sys")
    preview = body["preview"].split("localhost", 1)[1]
    page = client.get(preview)
    assert page.status_code == 200
    assert page.headers["Referrer-Policy"] == "no-referrer"
    assert "ProsodyARX" in page.get_data(as_text=True)
    assert client.get(preview[:-3] + "xyz").status_code == 404
    with app.app_context():
        system = db.session.scalar(sa.select(BoardSystem).where(BoardSystem.name == "ProsodyARX"))
        assert system is not None and system.status == "previewing"
    # nothing public yet: the board has no round, its JSON is not there
    board = client.get(f"/leaderboard/{season}/")
    assert board.status_code == 200 and "ProsodyARX" not in board.get_data(as_text=True)
    assert client.get(f"/leaderboard/{season}/leaderboard.json").status_code == 404


def test_a_stochastic_system_sends_samples_and_one_is_drawn(client, season, inputs) -> None:
    _, systems = inputs
    answer = client.post(
        f"/leaderboard/{season}/api/submissions",
        data={**_form("SkeletonLag"), "files": _files(systems["SkeletonLag"])},
        content_type="multipart/form-data",
    )
    assert answer.status_code == 201, answer.get_json()
    check = answer.get_json()["check"]
    assert sorted(check["drawn"]) == ["s01", "s02"]
    assert all("_sample" in name for name in check["drawn"].values())


def test_every_problem_is_one_line_naming_its_file_or_field(client, season, inputs) -> None:
    _, systems = inputs
    only_first = systems["ProsodyARX"][:1]
    answer = client.post(
        f"/leaderboard/{season}/api/submissions",
        data={
            **_form("Broken", licence="", paper="not a link"),
            "files": [*_files(only_first), (io.BytesIO(b"junk"), "s09.fap")],
        },
        content_type="multipart/form-data",
    )
    assert answer.status_code == 400
    errors = answer.get_json()["errors"]
    assert all("\n" not in line for line in errors)
    assert any(line.startswith("paper:") for line in errors)
    assert any(line.startswith("licence:") for line in errors)
    assert any(line.startswith("s09.fap:") for line in errors)
    assert any(line.startswith("s02:") for line in errors)


def test_the_form_shows_the_problems_and_keeps_the_fields(client, season, inputs) -> None:
    from tests.conftest import csrf_token

    url = f"/leaderboard/{season}/submit"
    page = client.get(url)
    assert page.status_code == 200 and "s01.wav" in page.get_data(as_text=True)
    answer = client.post(
        url,
        data={**_form("Formy", training_data=""), "csrf_token": csrf_token(client, url)},
        content_type="multipart/form-data",
    )
    text = answer.get_data(as_text=True)
    assert answer.status_code == 400
    assert "training_data: missing" in text and 'value="Formy"' in text
    speech = client.get(f"/leaderboard/{season}/segments/s01.wav")
    assert speech.status_code == 200 and speech.data[:4] == b"RIFF"
    speech.close()
    assert client.get(f"/leaderboard/{season}/segments/x.wav").status_code == 404


def test_unknown_seasons_and_files_are_404(client, season) -> None:
    assert client.get("/leaderboard/nope/").status_code == 404
    assert client.get(f"/leaderboard/{season}/renders/sys01/s01.mp4").status_code == 404
    assert client.get(f"/leaderboard/{season}/rounds/1/package.zip").status_code == 404
    assert client.get("/leaderboard/").status_code == 200


FIELDS = ["system", "team", "contact", "paper", "training_data", "licence"]
names = st.text(st.characters(codec="utf-8"), max_size=30)
form_values = st.one_of(st.text(max_size=40), st.sampled_from(["", "1", "true", "2026-13-40"]))


@given(
    form=st.dictionaries(
        st.sampled_from([*FIELDS, "key", "anonymous_name", "anonymous_until"]),
        form_values,
    ),
    uploads=st.lists(st.tuples(names, st.binary(max_size=200)), max_size=4),
)
@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_no_submission_is_answered_with_a_server_error(client, season, form, uploads) -> None:
    answer = client.post(
        f"/leaderboard/{season}/api/submissions",
        data={**form, "files": [(io.BytesIO(data), name) for name, data in uploads]},
        content_type="multipart/form-data",
    )
    assert answer.status_code < 500
    if answer.status_code == 400:
        assert all("\n" not in line for line in answer.get_json()["errors"])
