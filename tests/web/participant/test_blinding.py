"""Blinding, tested as an attacker would: a participant walks a whole study (the pair designs,
and the rating designs: one face a trial, or versions beside a reference) and keeps every byte
their browser receives (headers, pages, scripts, JSON answers, redirects, the first and last
256 KB of every clip, in both its renditions, MP4 and WebM); none of it may name a condition, a
model, a side assignment, an attention check's expected answer or a mismatched side. Run for
every media backend, with the clips made by the real render job's naming and the real encoder
(only the drawing is left out)."""

import re
import secrets
import urllib.request

import numpy as np
import pytest
import sqlalchemy as sa

from app.trials.studyfile import loads_study
from app.web.extensions import db
from app.web.models import Stimulus, Study
from app.web.study.studies import create_study
from tests.conftest import create_test_user, csrf_token, write_tone_wav
from tests.support.s3 import s3_env, s3_server, use_backend  # noqa: F401 (fixtures)

CONDITIONS = {"zebraface": "none", "quokkamotion": "random", "ibexprosody": "speech_driven"}
#: What a leak would look like besides the condition names: the model names a participant
#: could recognise, the old file names' markers of an attention check and a mismatched side.
#: (Not the old names' "__" separator on its own: random tokens in every page, URL-safe
#: base64, hold one now and then; a name it joined is one of the markers above.)
MARKERS = (
    *CONDITIONS,
    "speech_driven",
    "speech-driven",
    "ground_truth",
    "live_gmm",
    "press_left",
    "press_right",
    "foreign",
    "mismatch",
)
CHUNK = 256 * 1024

TOML = """
title = "Which face?"
question = "Which face moves more naturally?"
instructions = "Watch both faces."
consent = "You agree to take part."
design = "unordered_counterbalanced"
seed = 3
mismatched = true

[undecided]
allowed = true

[catch]
trials = 2
kind = "onscreen"
"""
#: Every study of the walks: small clips, the three conditions, two clips.
TAIL = """
[render]
size = 64
mosaic_block = 8
{conditions}
[[clips]]
name = "c1"
audio = "c1.wav"

[[clips]]
name = "c2"
audio = "c2.wav"
"""


def _fake_draw(left, right, audio, out, **kwargs):
    """The renderer's drawing left out, its encoder kept: a few frames of the pair's length
    and the clip's own audio, through renderer.encode.ClipWriter (the WebM beside the MP4)."""
    from renderer.encode import ClipWriter

    frames = 6
    webm = kwargs.get("webm_path")
    with ClipWriter(out, 64, 32, 25.0, frames, audio, webm_path=webm) as writer:
        for k in range(frames):
            writer.write(np.full((32, 64, 3), 30 * k, np.uint8))


def _open_study(app, tmp_path, monkeypatch, head: str):
    """The study of ``head`` (then :data:`TAIL`) with its tracks generated and its clips
    rendered by the jobs (the drawing left out, the encoder kept), opened; the study, in an
    application context the caller holds."""
    import renderer
    from app.web.jobs.bodies import generate_tracks, render_clips

    monkeypatch.setattr(renderer, "render_pair", _fake_draw)
    monkeypatch.setattr(
        renderer, "render_single", lambda track, *a, **k: _fake_draw(track, track, *a, **k)
    )
    for clip in ("c1", "c2"):
        write_tone_wav(tmp_path / f"{clip}.wav", seconds=1.2)
    conditions = "".join(
        f'\n[[conditions]]\nname = "{name}"\nmodel = "{model}"\n'
        for name, model in CONDITIONS.items()
    )
    text = head + TAIL.format(conditions=conditions)
    study = create_study(create_test_user(), loads_study(text, base_dir=tmp_path), source_toml=text)
    db.session.commit()
    generate_tracks(study, lambda done, total: None)
    render_clips(db.session.get(Study, study.id), lambda done, total: None)
    study = db.session.get(Study, study.id)
    study.status = "open"
    db.session.commit()
    return study


def _rendered_study(app, tmp_path, monkeypatch) -> str:
    """A pair study with every kind of stimulus; returns its slug."""
    with app.app_context():
        study = _open_study(app, tmp_path, monkeypatch, TOML)
        kinds = {
            (bool(s.instruction), bool(s.foreign_side))
            for s in db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id))
        }
        assert kinds == {(False, False), (True, False), (False, True)}
        return study.slug


class Browser:
    """A participant's browser that keeps everything it receives."""

    def __init__(self, client) -> None:
        self.client = client
        self.received: list[bytes] = []

    def keep(self, response, body: bytes | None = None) -> None:
        head = f"{response.status}\n" + "".join(f"{k}: {v}\n" for k, v in response.headers)
        self.received.append(head.encode() + (response.get_data() if body is None else body))
        response.close()

    def get(self, url: str, **kwargs):
        response = self.client.get(url, **kwargs)
        self.keep(response)
        return response

    def post(self, url: str, **kwargs):
        response = self.client.post(url, **kwargs)
        self.keep(response)
        return response

    def clip(self, url: str) -> None:
        """The first and last 256 KB of a clip, as a player's range requests ask for them,
        following a redirect to a bucket as the browser does."""
        spans = [f"bytes=0-{CHUNK - 1}"]
        while spans:
            span = spans.pop()
            response = self.get(url, headers={"Range": span})
            if response.status_code == 302:
                request = urllib.request.Request(response.headers["Location"])
                request.add_header("Range", span)
                with urllib.request.urlopen(request, timeout=10) as remote:
                    head = "".join(f"{k}: {v}\n" for k, v in remote.headers.items())
                    self.received.append(head.encode() + remote.read())
                    total = remote.headers.get("Content-Range", "/0").rsplit("/", 1)[1]
            else:
                assert response.status_code in (200, 206), (url, response.status_code)
                total = response.headers.get("Content-Range", "/0").rsplit("/", 1)[1]
            if span.startswith("bytes=0-") and int(total) > CHUNK:
                spans.append(f"bytes={int(total) - CHUNK}-")

    def join(self, slug: str) -> str:
        """Consent, then the instructions (their practice clips and the page's assets); the
        participant's token."""
        page = self.get(f"/s/{slug}")
        assert page.status_code == 200
        token = csrf_token(self.client, f"/s/{slug}")
        joined = self.post(f"/s/{slug}", data={"csrf_token": token, "agree": "1"})
        assert joined.status_code == 302
        who = joined.headers["Location"].split("/p/")[1].split("/")[0]
        text = self.get(f"/p/{who}/instructions").get_data(as_text=True)
        for url in re.findall(r'data-(?:video|webm)-url="([^"]+)"', text):
            self.clip(url)
        for asset in set(re.findall(r'(?:src|href)="(/static/[^"?]+)', text)):
            self.get(asset)
        return who

    def clip_names(self) -> list[bytes]:
        """The file names the clips received were sent under (Content-Disposition)."""
        return [
            re.search(rb'filename="?([^";\r\n]+)', chunk).group(1)
            for chunk in self.received
            if re.search(rb"content-type: video/(mp4|webm)", chunk[:2048].lower())
        ]

    def trials(self, who: str):
        """Each trial page in turn, until the session ends: (trial id, page text)."""
        while True:
            trial = self.get(f"/p/{who}/trial")
            if trial.status_code == 302:
                return
            text = trial.get_data(as_text=True)
            yield int(re.search(r'data-trial-id="(\d+)"', text).group(1)), text

    def walk(self, slug: str) -> int:
        """Consent, instructions, practice, every pair (a play, then a vote), the end;
        returns how many pairs were voted on."""
        who = self.join(slug)
        voted = 0
        for trial_id, text in self.trials(who):
            for url in re.findall(r'data-(?:video|preload|webm|preload-webm)-url="([^"]+)"', text):
                self.clip(url)
            played = self.post("/api/v1/plays", json={"token": who, "trial_id": trial_id})
            assert played.status_code == 200, played.get_data(as_text=True)
            vote = self.post(
                "/api/v1/votes",
                json={
                    "token": who,
                    "trial_id": trial_id,
                    "choice": "left",
                    "plays": 1,
                    "watched_to_end": True,
                    "response_ms": 900,
                    "presented_at": "2026-01-01T10:00:00.000Z",
                    "idempotency_key": secrets.token_hex(8),
                },
            )
            assert vote.status_code == 201, vote.get_data(as_text=True)
            answer = vote.get_json()
            upcoming = answer.get("next_trial") or {}
            for url in (upcoming.get("video_url"), upcoming.get("webm_url")):
                if url:
                    self.clip(url)
            voted += 1
        done = self.get(f"/p/{who}/done")
        assert done.status_code == 200
        return voted


def _leaks(received: list[bytes]) -> list[str]:
    found = []
    for number, chunk in enumerate(received):
        lowered = chunk.lower()
        found += [f"{m!r} in response {number}" for m in MARKERS if m.encode() in lowered]
    return found


@pytest.mark.parametrize("backend", ["local", "accel", "s3"])
def test_nothing_a_participant_receives_names_what_a_clip_shows(
    app, client, tmp_path, monkeypatch, request, backend
):
    slug = _rendered_study(app, tmp_path, monkeypatch)
    use_backend(app, backend, request)
    browser = Browser(client)
    voted = browser.walk(slug)
    assert voted >= 6
    names = browser.clip_names()
    assert names and all(re.fullmatch(rb"(pair-\d\d|practice)\.(mp4|webm)", n) for n in names)
    assert any(n.endswith(b".webm") for n in names), names
    assert _leaks(browser.received) == []


def test_the_walk_would_see_a_name_if_one_were_sent(app, client, tmp_path, monkeypatch, request):
    """The attacker's check itself: a clip stored under the names the conditions had is read
    from the walk's bytes (so the test above cannot pass by receiving nothing)."""
    from app.web.jobs import rendering

    monkeypatch.setattr(
        rendering,
        "clip_file",
        lambda study, stim: f"videos/{stim.left.name}__{stim.right.name}.mp4",
    )
    slug = _rendered_study(app, tmp_path, monkeypatch)
    use_backend(app, "accel", request)
    browser = Browser(client)
    browser.walk(slug)
    assert any("zebraface" in leak for leak in _leaks(browser.received))


# --- the rating designs: one face a trial (ACR), or versions side by side with a reference ---

RATING_TOML = """
title = "How natural?"
question = "How natural is the motion of this face?"
instructions = "Watch the face."
consent = "You agree to take part."
design = "{design}"
seed = 5
{reference}
[catch]
trials = {catch}
"""


def _rated_study(app, tmp_path, monkeypatch, design: str) -> str:
    """A rating or parallel study of the three conditions; returns its slug."""
    head = RATING_TOML.format(
        design=design,
        reference='reference = "zebraface"' if design == "parallel" else "",
        catch=1 if design == "rating" else 0,
    )
    with app.app_context():
        return _open_study(app, tmp_path, monkeypatch, head).slug


def _walk_ratings(browser: Browser, slug: str) -> int:
    """Consent, instructions, every trial (its clips, a play per clip, a rating), the end;
    returns how many trials were rated."""
    who = browser.join(slug)
    rated = 0
    for trial_id, text in browser.trials(who):
        items = re.search(r'data-items="(\d+)"', text)
        urls = re.findall(r'data-(?:video|reference)-url="([^"]+)"', text)
        webms = re.findall(r'data-(?:webm|reference-webm)-url="([^"]+)"', text)
        if items:
            base = re.search(r'data-item-url="([^"]+)"', text).group(1)
            urls += [f"{base}{k}" for k in range(int(items.group(1)))]
            base = re.search(r'data-item-webm-url="([^"]+)"', text).group(1)
            webms += [f"{base}{k}" for k in range(int(items.group(1)))]
        for url in webms:
            browser.clip(url)
        for url in urls:
            browser.clip(url)
            played = browser.post("/api/v1/plays", json={"token": who, "trial_id": trial_id})
            assert played.status_code == 200, played.get_data(as_text=True)
        answer = {"scores": [50] * int(items.group(1))} if items else {"score": 3}
        rating = browser.post(
            "/api/v1/ratings",
            json={
                "token": who,
                "trial_id": trial_id,
                "plays": len(urls),
                "watched_to_end": True,
                "response_ms": 900,
                "presented_at": "2026-01-01T10:00:00.000Z",
                "idempotency_key": secrets.token_hex(8),
                **answer,
            },
        )
        assert rating.status_code == 201, rating.get_data(as_text=True)
        rated += 1
    assert browser.get(f"/p/{who}/done").status_code == 200
    return rated


@pytest.mark.parametrize("design", ["rating", "parallel"])
@pytest.mark.parametrize("backend", ["local", "accel", "s3"])
def test_nothing_a_rater_receives_names_what_a_clip_shows(
    app, client, tmp_path, monkeypatch, request, design, backend
):
    slug = _rated_study(app, tmp_path, monkeypatch, design)
    use_backend(app, backend, request)
    browser = Browser(client)
    rated = _walk_ratings(browser, slug)
    assert rated >= (2 if design == "parallel" else 6)
    names = browser.clip_names()
    # a clip by its place in the schedule; a parallel trial's versions by their place on the page
    assert names and all(re.fullmatch(rb"clip-\d\d(-\d+)?\.(mp4|webm)", n) for n in names)
    assert any(n.endswith(b".webm") for n in names), names
    assert _leaks(browser.received) == []


def test_the_rater_walk_would_see_a_name_if_one_were_sent(
    app, client, tmp_path, monkeypatch, request
):
    """As for the pairs: clips stored under their condition's name are seen by the walk."""
    from app.web.jobs import rendering

    monkeypatch.setattr(rendering, "clip_file", lambda study, stim: f"videos/{stim.left.name}.mp4")
    slug = _rated_study(app, tmp_path, monkeypatch, "parallel")
    use_backend(app, "accel", request)
    browser = Browser(client)
    _walk_ratings(browser, slug)
    assert any("zebraface" in leak for leak in _leaks(browser.received))
