"""What the participant reads that the design decides (``app.web.study.wording``, the participant
templates): each design's consent, instructions and script words in the study's language, and
the built-in demographic questions through the catalogue."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import pytest

from app.trials.questions import DEMOGRAPHICS
from app.web.extensions import db
from app.web.infra.i18n import use_language
from app.web.models import Study
from app.web.study.wording import question_words
from tests.conftest import ParticipantActions

#: The three kinds of page: the pair designs, the rating design (one face), the parallel design
#: (several versions of a clip beside a reference).
STUDIES = {
    "pair": dict(design="unordered_counterbalanced"),
    "rating": dict(design="rating", catch_kind="instructed"),
    "parallel": dict(design="parallel", extra='reference = "none"\n'),
}

#: Per language, words of each design's consent sentence (no other design's page has them),
#: the instructions' Play button (the parallel page has none) and the parallel design's own
#: play buttons, and the script's "no more plays" of a pair and of a clip.
WORDS = {
    "en": {
        "pair": "two animated faces side by side",
        "rating": "an animated face, one at a time",
        "parallel": "each in several versions",
        "play button": "(or the Play button)",
        "version buttons": "Click “Reference” or a version's number to play it",
        "no more plays": {
            "pair": "No more plays of this pair.",
            "clip": "No more plays of this clip.",
        },
    },
    "de": {
        "pair": "zwei animierten Gesichtern nebeneinander",
        "rating": "eines nach dem anderen",
        "parallel": "jedes in mehreren Versionen",
        "play button": "(oder die Schaltfläche Abspielen)",
        "version buttons": "Klicken Sie auf „Referenz“ oder auf die Nummer einer Version",
        "no more plays": {
            "pair": "Dieses Paar kann nicht mehr abgespielt werden.",
            "clip": "Dieser Clip kann nicht mehr abgespielt werden.",
        },
    },
    "ar": {
        "pair": "لوجهين متحركين جنبًا إلى جنب",
        "rating": "واحدًا تلو الآخر",
        "parallel": "كل مقطع في عدة نسخ",
        "play button": "(أو زر التشغيل)",
        "version buttons": "انقر على «المرجع» أو على رقم نسخة لتشغيلها",
        "no more plays": {
            "pair": "لم يعد بالإمكان تشغيل هذا الزوج.",
            "clip": "لم يعد بالإمكان تشغيل هذا المقطع.",
        },
    },
}


def _script_strings(html: str) -> dict:
    blob = re.search(r'<script type="application/json" id="i18n">(.*?)</script>', html, re.S)
    assert blob is not None
    return json.loads(blob.group(1))


@pytest.mark.parametrize("language", WORDS)
def test_each_design_describes_its_own_pages(app, web, language):
    """The consent page says what taking part in this design is (two faces to choose from,
    one face to rate, several versions to rate against a reference); the parallel design's
    instructions name its own buttons, not a Play button it does not have; a rating page's
    script speaks of a clip, a pair page's of a pair."""
    words = WORDS[language]
    for kind, toml in STUDIES.items():
        extra = f'language = "{language}"\n' + toml.get("extra", "")
        study_id = web.study(**(toml | {"extra": extra}))
        with app.app_context():
            slug = db.session.get(Study, study_id).slug
        person = ParticipantActions(app.test_client(), app)
        consent = person.client.get(f"/s/{slug}").get_data(as_text=True)
        for design in STUDIES:
            assert (words[design] in consent) == (design == kind), (kind, design)
        token = person.join(slug)
        instructions = person.client.get(f"/p/{token}/instructions").get_data(as_text=True)
        assert (words["play button"] in instructions) == (kind != "parallel"), kind
        assert (words["version buttons"] in instructions) == (kind == "parallel"), kind
        trial = person.client.get(f"/p/{token}/trial").get_data(as_text=True)
        said = _script_strings(trial)
        assert said["no_more_plays"] == words["no more plays"]["pair" if kind == "pair" else "clip"]


def test_only_the_built_in_demographic_questions_are_facepairs_words(app):
    """A built-in question is translated and keeps its codes; a study's own question, even one
    named like a built-in, is the study's text as written."""
    age, gender = DEMOGRAPHICS[0], DEMOGRAPHICS[1]
    own = replace(gender, text="Geschlecht", choices=("w", "m"))
    with app.test_request_context("/"):
        use_language("de")
        said = question_words(age)
        assert said.builtin and said.text == "Ihr Alter"
        assert said.options[0] == ("18-24", "18-24")
        assert said.options[-1] == ("prefer not to say", "keine Angabe")
        assert question_words(own) == ("Geschlecht", (("w", "w"), ("m", "m")), False)


#: The built-in words a language writes as English does.
SAME_WORD = {"es": {"no"}}


@pytest.mark.parametrize("language", ["de", "ar", "fr", "es", "ja"])
def test_every_built_in_word_is_translated_in_its_own_context(app, language):
    """Each built-in question and each option with a letter in it has its own entry, in the
    catalogue's ``demographics`` context: translated in every language but English, and the
    short answers ("none", "no", "other") never taken for the same words elsewhere."""
    from flask_babel import gettext

    worded = {q.text for q in DEMOGRAPHICS}
    worded |= {c for q in DEMOGRAPHICS for c in q.choices if re.search(r"[a-z]", c)}
    with app.test_request_context("/"):
        use_language(language)
        for question in DEMOGRAPHICS:
            said = question_words(question)
            shown = {said.text} | {label for _, label in said.options}
            codes = [code for code, _ in said.options]
            assert codes == list(question.choices), question.name
            untranslated = shown & worded - SAME_WORD.get(language, set())
            assert not untranslated, (language, question.name, untranslated)
        # the same English outside the context is another message (left as it is)
        assert gettext("none") == "none" and gettext("other") == "other"
