import re

import pytest
import sqlalchemy as sa

from app.web.extensions import db
from app.web.models import Participant, Study, Trial, Vote
from tests.conftest import csrf_token
from tests.support.studies import EIGHT_CONDITIONS, study_slug


def _status(client, url):
    """GET ``url`` and close the response (file responses hold the file open)."""
    response = client.get(url)
    response.close()
    return response.status_code


def test_whole_study_with_reload_and_resume(app, client, participant, web):
    slug = study_slug(app, web.study())
    token = participant.join(slug, "PROLIFIC_PID=pp1&STUDY_ID=st1&SESSION_ID=se1")
    assert client.get(f"/p/{token}/instructions").status_code == 200
    assert _status(client, f"/p/{token}/practice.mp4") == 200
    seen = []
    while (trial_id := participant.current_trial()) is not None:
        # A reload shows the same unanswered trial.
        assert participant.current_trial() == trial_id
        assert _status(client, f"/p/{token}/video/{trial_id}") == 200
        assert participant.vote(trial_id, "right").status_code == 201
        seen.append(trial_id)
    assert len(seen) == len(set(seen)) > 0
    done = client.get(f"/p/{token}/done")
    assert b"DONE-123" in done.data and b"https://example.org/complete" in done.data
    # Reopening the study link resumes (here: the completion page) through the cookie.
    again = client.get(f"/s/{slug}")
    assert again.status_code == 302 and again.headers["Location"].endswith(f"/p/{token}")
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert (person.prolific_pid, person.prolific_study_id, person.prolific_session_id) == (
            "pp1",
            "st1",
            "se1",
        )
        assert person.finished_at is not None
        votes = db.session.scalars(sa.select(Vote)).all()
        assert sorted(v.trial_id for v in votes) == sorted(seen)
        assert {v.choice for v in votes} == {"right"}


def test_consent_needs_csrf_and_an_open_study(app, client, web):
    slug = study_slug(app, web.study())
    assert client.post(f"/s/{slug}", data={"agree": "1"}).status_code == 400  # no CSRF token
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 0
    paused = study_slug(app, web.study(status="paused"))
    assert client.get(f"/s/{paused}").status_code == 503
    draft = study_slug(app, web.study(video=False))
    assert client.get(f"/s/{draft}").status_code == 404
    assert client.get("/s/not-a-study").status_code == 404


def test_tokens_are_private(app, client, participant, web):
    slug = study_slug(app, web.study())
    token = participant.join(slug)
    other = ParticipantLike(app)
    other_token = other.join(slug)
    assert token != other_token and len(token) >= 30
    with app.app_context():
        theirs = db.session.scalar(
            sa.select(Trial)
            .join(Participant)
            .where(Participant.token == other_token, Trial.kind == "trial")
        )
    # My token cannot fetch or answer their trial.
    assert _status(participant.client, f"/p/{token}/video/{theirs.id}") == 404
    assert participant.vote(theirs.id).status_code == 404
    assert participant.client.get("/p/guessed-token/trial").status_code == 404


class ParticipantLike:
    def __init__(self, app):
        self.client = app.test_client()

    def join(self, slug):
        page = self.client.get(f"/s/{slug}").get_data(as_text=True)
        token = re.search(r'name="csrf_token"[^>]*value="([^"]+)"', page).group(1)
        response = self.client.post(f"/s/{slug}", data={"csrf_token": token, "agree": "1"})
        return response.headers["Location"].split("/p/")[1].split("/")[0]


def test_closed_study_stops_trials(app, client, participant, web):
    study_id = web.study()
    token = participant.join(study_slug(app, study_id))
    with app.app_context():
        db.session.get(Study, study_id).status = "closed"
        db.session.commit()
    assert client.get(f"/p/{token}/trial").status_code == 410
    assert client.get(f"/p/{token}").status_code == 302


# --- the participant's side: integrity of the trial page ------------------------------------


def _play(client, token, trial_id):
    return client.post("/api/v1/plays", json={"token": token, "trial_id": trial_id})


def test_plays_are_counted_by_the_server_and_a_reload_gives_none_back(
    app, client, participant, web
):
    token = participant.join(study_slug(app, web.study(replay="max_plays", max_plays=2)))
    trial_id = participant.current_trial()
    assert _play(client, token, trial_id).get_json() == {"plays": 1, "plays_left": 1}
    assert _play(client, token, trial_id).get_json() == {"plays": 2, "plays_left": 0}
    # A reload: the page starts from the server's count, and the server refuses a third play.
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    assert 'data-plays="2"' in page
    refused = _play(client, token, trial_id)
    assert refused.status_code == 409 and refused.get_json()["plays_left"] == 0
    # The page claims one play (its own count after the reload); the server's count is kept.
    assert participant.vote(trial_id, plays=1).status_code == 201
    with app.app_context():
        assert db.session.scalar(sa.select(Vote.plays)) == 2


def test_a_prolific_id_enrols_once_and_resumes_with_its_session_id(app, client, participant, web):
    slug = study_slug(app, web.study())
    token = participant.join(slug, "PROLIFIC_PID=same&STUDY_ID=s&SESSION_ID=a")
    client.delete_cookie(f"fp-{web_study_id(app, slug)}")  # another device: no cookie
    again = client.get(f"/s/{slug}?PROLIFIC_PID=same&STUDY_ID=s&SESSION_ID=a")
    assert again.status_code == 302 and again.headers["Location"].endswith(f"/p/{token}")
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 1


@pytest.mark.parametrize(
    "query",
    [
        "PROLIFIC_PID=victim",  # the ID alone
        "PROLIFIC_PID=victim&STUDY_ID=s&SESSION_ID=other",  # another attempt's session
        "PROLIFIC_PID=victim&STUDY_ID=s&SESSION_ID=",
    ],
)
def test_a_prolific_id_alone_takes_over_nobody(app, participant, web, query):
    """Another browser with the victim's Prolific ID (and no or another SESSION_ID) gets a
    page saying the study was started, with what to do, and nothing of the victim's: no
    participant link, no cookie; GET and the consent POST alike."""
    slug = study_slug(app, web.study())
    token = participant.join(slug, "PROLIFIC_PID=victim&STUDY_ID=s&SESSION_ID=a")
    stranger = app.test_client()
    for answer in (
        stranger.get(f"/s/{slug}?{query}"),
        stranger.post(
            f"/s/{slug}",
            data={"csrf_token": csrf_token(stranger, f"/s/{slug}"), **_fields(query)},
        ),
    ):
        body = answer.get_data(as_text=True)
        assert answer.status_code == 409 and "already started this study" in body
        assert token not in body and token not in answer.headers.get("Location", "")
        assert "Set-Cookie" not in answer.headers or token not in answer.headers["Set-Cookie"]
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 1
    # The victim's own browser still resumes by its cookie.
    assert participant.client.get(f"/s/{slug}").headers["Location"].endswith(f"/p/{token}")


def _fields(query: str) -> dict[str, str]:
    return dict(part.split("=", 1) for part in query.split("&"))


def test_session_id_rule():
    from types import SimpleNamespace

    from app.web.participant.views import resumes

    stored = SimpleNamespace(prolific_session_id="a")
    assert resumes(stored, "a")
    assert not resumes(stored, "b") and not resumes(stored, None) and not resumes(stored, "")
    assert not resumes(SimpleNamespace(prolific_session_id=None), None)


def web_study_id(app, slug):
    with app.app_context():
        return db.session.scalar(sa.select(Study.id).where(Study.slug == slug))


def test_back_after_a_vote_never_shows_the_practice_again(app, client, participant, web):
    token = participant.join(study_slug(app, web.study()))
    assert client.get(f"/p/{token}/instructions").status_code == 200
    trial = client.get(f"/p/{token}/trial")
    assert trial.headers["Cache-Control"] == "no-store"
    back = client.get(f"/p/{token}/instructions")
    assert back.status_code == 302 and back.headers["Location"].endswith(f"/p/{token}")


#: What each design's test study adds to the file (a reference, eight conditions).
DESIGN_EXTRA = {
    "all_ordered": "",
    "reference": 'reference = "none"\n',
    "unordered_counterbalanced": "",
    "adaptive": EIGHT_CONDITIONS,
    "rating": "",
    "parallel": 'reference = "none"\n',
}


@pytest.mark.parametrize("design", DESIGN_EXTRA)
def test_practice_false_means_no_practice_in_every_design(app, client, participant, web, design):
    """``practice = false``: no practice on the instructions page, no practice clip and no
    practice trial, whatever the design; a pair design's default practice pair is still
    shown (the rating designs have none)."""
    catch_kind = "instructed" if design == "rating" else "identical"
    for practice in (False, True):
        settings = "practice = false\n" if not practice else ""
        extra = settings + DESIGN_EXTRA[design]
        study_id = web.study(design=design, catch_kind=catch_kind, extra=extra)
        token = participant.join(study_slug(app, study_id))
        page = client.get(f"/p/{token}/instructions").get_data(as_text=True)
        shown = practice and design not in ("rating", "parallel")
        assert ("Practice pair" in page) == shown, (design, practice)
        assert ("practice.mp4" in page) == shown
        assert _status(client, f"/p/{token}/practice.mp4") == (200 if shown else 404)
        with app.app_context():
            kinds = db.session.scalars(
                sa.select(Trial.kind).join(Participant).where(Participant.token == token)
            ).all()
        assert ("practice" in kinds) == shown


def test_study_text_is_paragraphs_not_ragged_lines(app, client, participant, web):
    from app.web.participant.views import paragraphs

    assert str(paragraphs("one\ntwo <b>\n\n  three\n")) == "<p>one two &lt;b&gt;</p><p>three</p>"
    token = participant.join(study_slug(app, web.study()))
    assert "<p>Watch both faces.</p>" in client.get(f"/p/{token}/instructions").get_data(
        as_text=True
    )


def test_answer_buttons_are_mirror_images(app, client, participant, web):
    """Equal grid columns whatever the number of buttons (no `1fr auto 1fr` side bias)."""
    from pathlib import Path

    css = (Path(app.static_folder) / "style.css").read_text()
    votes = re.search(r"\n\.votes \{([^}]*)\}", css).group(1)
    assert "grid-auto-columns: minmax(0, 1fr)" in votes and "auto 1fr" not in votes
    for undecided in (True, False):
        token = participant.join(study_slug(app, web.study(undecided=undecided)))
        page = client.get(f"/p/{token}/trial").get_data(as_text=True)
        labels = re.findall(r'class="vote" data-choice="(\w+)"', page)
        assert labels == (["left", "undecided", "right"] if undecided else ["left", "right"])


FIVE = """
[answer]
scale = 5
reasons = ["lips", "head"]

[attention]
max_failed = 2
screened_out_code = "SCREENED-9"
"""


def test_five_levels_reasons_and_the_stop_rule(app, client, participant, web):
    token = participant.join(
        study_slug(
            app,
            web.study(design="all_ordered", catch=2, extra=FIVE.replace("[answer]", "\n[answer]")),
        )
    )
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    assert page.count('class="vote"') == 5 and "Clearly left" in page and 'value="lips"' in page
    with app.app_context():
        catches = db.session.scalars(sa.select(Trial).where(Trial.kind == "catch")).all()
        catch_ids = [t.id for t in catches]
    first = participant.current_trial()
    assert participant.vote(first, "left").get_json()["error"].startswith("strength:")
    assert participant.vote(first, "left", strength=2, reasons=["eyes"]).status_code == 400
    assert participant.vote(first, "left", strength=2, reasons=["lips"]).status_code == 201
    # Two failed attention checks end the session with the separate code.
    for trial_id in catch_ids:
        assert participant.vote(trial_id, "left", strength=1).status_code == 201
    done = client.get(f"/p/{token}/done")
    assert done.status_code == 200 and b"SCREENED-9" in done.data and b"DONE-123" not in done.data
    assert client.get(f"/p/{token}/trial").status_code == 302
    with app.app_context():
        vote = db.session.scalar(sa.select(Vote).where(Vote.trial_id == first))
        assert (vote.strength, vote.reasons) == (2, ["lips"])
        person = db.session.scalar(sa.select(Participant))
        assert person.screened_out_at is not None and person.finished_at is None


def test_the_completion_code_waits_for_the_last_vote(app, client, participant, web):
    token = participant.join(study_slug(app, web.study()))
    early = client.get(f"/p/{token}/done")
    assert early.status_code == 302 and b"DONE-123" not in early.data
    while (trial_id := participant.current_trial()) is not None:
        assert b"DONE-123" not in client.get(f"/p/{token}/done").data
        participant.vote(trial_id, "left")
    assert b"DONE-123" in client.get(f"/p/{token}/done").data


def test_clips_answer_ranges_with_a_long_private_cache(app, client, participant, web):
    token = participant.join(study_slug(app, web.study()))
    trial_id = participant.current_trial()
    part = client.get(f"/p/{token}/video/{trial_id}", headers={"Range": "bytes=0-99"})
    assert part.status_code == 206 and len(part.data) == 100
    assert part.headers["Cache-Control"] == "private, max-age=604800"
    part.close()


def test_the_page_takes_its_answers_keys_and_replay_rule_from_the_rules(
    app, client, participant, web
):
    import html
    import json

    from app.trials.rules import answers, key_map

    token = participant.join(
        study_slug(app, web.study(undecided=False, replay="max_plays", max_plays=2))
    )
    guide = client.get(f"/p/{token}/instructions").get_data(as_text=True)
    assert "<kbd>←</kbd>/<kbd>1</kbd> for “Left”" in guide and "↓" not in guide
    page = client.get(f"/p/{token}/trial").get_data(as_text=True)
    keys = json.loads(html.unescape(re.search(r"data-keys='([^']*)'", page).group(1)))
    assert keys == key_map(3)
    buttons = re.findall(r'data-choice="(\w+)" data-key="(\w+)"', page)
    assert buttons == [(a.choice, a.key) for a in answers(scale=3, undecided_allowed=False)]
    assert 'data-max-plays="2"' in page and 'data-needs-end="no"' in page


def _consent(client, slug, **fields):
    return client.post(
        f"/s/{slug}", data={"csrf_token": csrf_token(client, f"/s/{slug}"), **fields}
    )


def test_one_address_cannot_flood_a_study_with_consents(app, web):
    """200 consents from one address took 255 list slots against a target of 20; now the
    address gets 10 a minute, then a page asking it to wait (429, Retry-After), while another
    address still enrols and a returning participant still resumes."""
    slug = study_slug(app, web.study())
    flood = app.test_client()
    codes = []
    for _ in range(14):
        flood.delete_cookie(f"fp-{web_study_id(app, slug)}")  # a fresh browser each time
        codes.append(_consent(flood, slug).status_code)
    assert codes[:10] == [302] * 10 and set(codes[10:]) == {429}
    refused = _consent(flood, slug)
    assert "Please wait a moment" in refused.get_data(as_text=True)
    assert int(refused.headers["Retry-After"]) > 0
    other = app.test_client()
    other.environ_base["REMOTE_ADDR"] = "10.9.8.7"
    assert _consent(other, slug).status_code == 302
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 11


def test_resumes_and_refused_forms_do_not_count_against_the_address(app, participant, web):
    slug = study_slug(app, web.study())
    participant.join(slug)
    for _ in range(15):  # the same browser coming back: resumed, not enrolled
        assert participant.client.post(f"/s/{slug}").status_code in (302, 400)
    other_study = study_slug(app, web.study())
    assert _consent(participant.client, other_study).status_code == 302


def test_the_consent_limits_are_configurable_and_can_be_switched_off(app, web):
    app.config["CONSENT_LIMIT_PER_ADDRESS"] = ""
    app.config["CONSENT_LIMIT_PER_STUDY"] = "3 per minute"
    slug = study_slug(app, web.study())
    codes = []
    for i in range(5):
        client = app.test_client()
        client.environ_base["REMOTE_ADDR"] = f"10.0.0.{i + 1}"
        codes.append(_consent(client, slug).status_code)
    assert codes == [302, 302, 302, 429, 429]
