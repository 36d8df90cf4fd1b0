"""Recruiting on Prolific: the study URL with its placeholders, the completion URL on the study
page, and the finished participant sent there (the code shown as a fallback)."""

import re

from app.web.extensions import db
from app.web.models import Study
from app.web.study.recruitment import prolific_study_url


def test_prolific_study_url_keeps_the_link_and_adds_the_placeholders():
    assert prolific_study_url("https://x.org/s/abc") == (
        "https://x.org/s/abc?PROLIFIC_PID={{%PROLIFIC_PID%}}&STUDY_ID={{%STUDY_ID%}}"
        "&SESSION_ID={{%SESSION_ID%}}"
    )
    assert prolific_study_url("https://x.org/s/abc?lang=en").startswith(
        "https://x.org/s/abc?lang=en&PROLIFIC_PID="
    )


def _code_only(app, study_id):
    """The study without its redirect URL, with the code C0DE."""
    with app.app_context():
        study = db.session.get(Study, study_id)
        study.redirect_url, study.completion_code = "", "C0DE"
        db.session.commit()
    return study_id


def _finish(app, participant, study_id, query=""):
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug, query)
    while (trial := participant.current_trial()) is not None:
        participant.vote(trial, "left")
    return participant.client.get(f"/p/{participant.token}/done").get_data(as_text=True)


def test_study_page_shows_both_urls(app, client, web):
    study_id = _code_only(app, web.study())
    web.login(client)
    page = client.get(f"/experimenter/studies/{study_id}").get_data(as_text=True)
    found = re.search(r'id="prolific-url" value="([^"]+)"', page).group(1)
    assert found.endswith(
        "?PROLIFIC_PID={{%PROLIFIC_PID%}}&amp;STUDY_ID={{%STUDY_ID%}}"
        "&amp;SESSION_ID={{%SESSION_ID%}}"
    )
    assert "/s/" in found
    assert (
        'id="completion-url" value="https://app.prolific.com/submissions/complete?cc=C0DE"' in page
    )


def test_a_prolific_participant_is_sent_back_with_the_code(app, web, participant):
    study_id = _code_only(app, web.study(design="all_ordered"))
    done = _finish(app, participant, study_id, "PROLIFIC_PID=5f01&STUDY_ID=s&SESSION_ID=x")
    assert (
        'id="redirect" href="https://app.prolific.com/submissions/complete?cc=C0DE" '
        'data-redirect-after="5"'
    ) in done
    assert 'http-equiv="refresh"' not in done
    assert 'id="completion-code">C0DE<' in done


def test_without_prolific_nor_redirect_only_the_code_is_shown(app, web, participant):
    study_id = _code_only(app, web.study(design="all_ordered"))
    done = _finish(app, participant, study_id)
    assert 'id="redirect"' not in done and "C0DE" in done


def test_the_study_redirect_url_goes_first(app, web, participant):
    done = _finish(app, participant, web.study(design="all_ordered"))
    assert 'href="https://example.org/complete?cc=DONE-123" data-redirect-after="5"' in done
