"""The questionnaire pages on a participant's path, the answers export and the report summary."""

import csv
import io
import re

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.web.extensions import db
from app.web.models import Participant
from tests.support.questionnaire import BEFORE, QUESTIONS, answer_page
from tests.support.studies import study_slug


def test_the_path_passes_through_both_pages(app, client, web, participant):
    study_id = web.study(design="all_ordered", extra=QUESTIONS)
    token = participant.join(study_slug(app, study_id))
    page = participant.client.get(f"/p/{token}/instructions")
    assert page.headers["Location"] == f"/p/{token}/questions/before"
    assert participant.client.get(f"/p/{token}/trial").headers["Location"].endswith("/before")
    before = participant.client.get(f"/p/{token}/questions/before").get_data(as_text=True)
    assert 'class="required-mark"' in before and "(required)" in before
    assert "<fieldset" in before and 'class="option"' in before
    missing = answer_page(participant.client, token, "before", **(BEFORE | {"gender": ""}))
    assert missing.status_code == 400
    text = missing.get_data(as_text=True)
    assert "an answer is required" in text and 'value="Welsh"' in text  # the rest kept
    assert answer_page(participant.client, token, "before", **BEFORE).headers["Location"] == (
        f"/p/{token}/instructions"
    )
    while (trial := participant.current_trial()) is not None:
        participant.vote(trial, "left")
    done = participant.client.get(f"/p/{token}/done")
    assert done.headers["Location"] == f"/p/{token}/questions/after"
    after = participant.client.get(f"/p/{token}/questions/after").get_data(as_text=True)
    assert 'id="hint-hours">A number from 0 to 24.</small>' in after
    assert 'aria-describedby="hint-hours"' in after and "(optional)" in after
    bad = answer_page(participant.client, token, "after", hours="25")
    assert "must be at most 24, got 25" in bad.get_data(as_text=True)
    ok = answer_page(participant.client, token, "after", hours="3.5", comments="Nice faces")
    assert ok.headers["Location"] == f"/p/{token}/done"
    assert participant.client.get(f"/p/{token}/done").status_code == 200
    # A page is answered once.
    assert participant.client.get(f"/p/{token}/questions/before").status_code == 302
    web.login(client)
    answers = list(
        csv.DictReader(
            io.StringIO(
                client.get(f"/experimenter/studies/{study_id}/answers.csv").get_data(as_text=True)
            )
        )
    )
    assert answers == [
        {
            "participant": "P0000",
            "status": "finished",
            "excluded": "",
            "prolific_id": "",
            **BEFORE,
            "comments": "Nice faces",
            "hours": "3.5",
        }
    ]


#: Each language's words for the built-in questions the test reads (the catalogues').
DEMOGRAPHIC_WORDS = {
    "de": {
        "Your age": "Ihr Alter",
        "prefer not to say": "keine Angabe",
        "I work in animation": "Ich arbeite im Animationsbereich",
        "Your native language": "Ihre Muttersprache",
    },
    "ar": {
        "Your age": "عمرك",
        "prefer not to say": "أفضّل عدم الإجابة",
        "I work in animation": "أعمل في مجال الرسوم المتحركة",
        "Your native language": "لغتك الأم",
    },
}


@pytest.mark.parametrize("language", DEMOGRAPHIC_WORDS)
def test_the_demographic_questions_speak_the_study_language_and_store_codes(
    app, client, web, participant, language
):
    """``demographics = true`` asks facepair's own questions in the study's language; an
    option's value, what is stored and what answers.csv holds stay the same code in every
    language. The study's own questions stay as the study file wrote them."""
    own = '[[questions]]\nname = "fav"\ntext = "Lieblingsfarbe"\ntype = "choice"\n'
    own += 'choices = ["rot", "blau"]\n'
    extra = f'language = "{language}"\ndemographics = true\n' + own
    study_id = web.study(design="all_ordered", extra=extra)
    token = participant.join(study_slug(app, study_id))
    page = participant.client.get(f"/p/{token}/questions/before").get_data(as_text=True)
    shown = set(re.findall(r">([^<>]+)<", page))
    for english, translated in DEMOGRAPHIC_WORDS[language].items():
        assert translated in shown and english not in shown, (english, translated)
    assert not shown & {"female", "male", "none", "Your gender", "65 or over"}
    assert {"Lieblingsfarbe", "rot", "blau"} <= shown
    values = set(re.findall(r'type="radio" name="\w+" value="([^"]+)"', page))
    assert {"prefer not to say", "I work in animation", "65 or over", "rot"} <= values
    # The label shown is not an answer: the option's code is.
    label = DEMOGRAPHIC_WORDS[language]["prefer not to say"]
    refused = answer_page(participant.client, token, "before", **(BEFORE | {"gender": label}))
    assert refused.status_code == 400
    kept = refused.get_data(as_text=True)
    assert 'id="error-gender"' in kept and 'value="Welsh"' in kept
    answers = BEFORE | {"age_band": "prefer not to say", "gender": "non-binary", "fav": "rot"}
    assert answer_page(participant.client, token, "before", **answers).status_code == 302
    with app.app_context():
        person = db.session.scalar(sa.select(Participant).where(Participant.token == token))
        assert person.answers == {"before": answers}
    web.login(client)
    url = f"/experimenter/studies/{study_id}/answers.csv"
    rows = list(csv.DictReader(io.StringIO(client.get(url).get_data(as_text=True))))
    assert [{k: rows[0][k] for k in answers}] == [answers]


def test_the_report_summarises_the_answers(app, client, web, participant):
    study_id = web.study(design="all_ordered", extra=QUESTIONS)
    for hours in ("2", "6"):
        participant.client = app.test_client()
        token = participant.join(study_slug(app, study_id))
        answer_page(participant.client, token, "before", **BEFORE)
        while (trial := participant.current_trial()) is not None:
            participant.vote(trial, "left")
        answer_page(participant.client, token, "after", hours=hours)
    web.login(client)
    token = web.csrf(client, f"/experimenter/studies/{study_id}")
    client.post(f"/experimenter/studies/{study_id}/status/close", data={"csrf_token": token})
    response = client.get(f"/experimenter/studies/{study_id}/report/")
    html = response.get_data(as_text=True)
    response.close()
    assert "<h2>Questionnaire</h2>" in html
    assert "median 4, range 2-6" in html and "25-34: 2" in html


def test_a_study_without_questions_goes_straight_on(app, web, participant):
    token = participant.join(study_slug(app, web.study()))
    assert participant.client.get(f"/p/{token}/instructions").status_code == 200
    assert participant.client.get(f"/p/{token}/questions/before").status_code == 302


def test_hostile_answers_never_give_a_5xx(app, web, participant):
    study_id = web.study(design="all_ordered", extra=QUESTIONS)
    token = participant.join(study_slug(app, study_id))
    url = f"/p/{token}/questions/before"
    form = participant.client.get(url).get_data(as_text=True)
    csrf = re.search(r'name="csrf_token" type="hidden" value="([^"]+)"', form).group(1)
    text = st.text(st.characters(blacklist_categories=("Cs",)), max_size=200)

    @settings(
        max_examples=80,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
    @given(st.dictionaries(st.sampled_from([*BEFORE, "x"]), text))
    def hostile(values):
        response = participant.client.post(url, data={"csrf_token": csrf, **values})
        assert response.status_code in (302, 400), response.status_code

    hostile()
    with app.app_context():
        answers = db.session.scalar(sa.select(Participant.answers)) or {}
        assert set(answers.get("before", BEFORE)) == set(BEFORE)
