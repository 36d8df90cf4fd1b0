"""What the participant reads that does not sit in a template: the answer buttons' labels,
the side names, the reasons a session or study ends, and what the page's script says.

The pages' scripts take their strings from a JSON blob in the page (``<script
type="application/json" id="i18n">``, :func:`script_strings`, read by ``static/participant.js``),
in the study's language; they format ``%(name)s`` placeholders themselves, so every language
orders them freely.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from flask_babel import gettext as _
from flask_babel import lazy_gettext, ngettext, pgettext

from app.trials import rules
from app.trials.questions import DEMOGRAPHICS, QuestionSpec
from app.trials.rating import ACR_LEVELS
from app.web.study.enrolment import SESSION_ENDED
from app.web.study.votes import SCREENED_OUT

#: The labels of :func:`app.trials.rules.answers`, by their English text (the undecided
#: label only when the study keeps the default).
ANSWER_LABELS = {
    "Left": lazy_gettext("Left"),
    "Right": lazy_gettext("Right"),
    "Undecided": lazy_gettext("Undecided"),
    "Clearly left": lazy_gettext("Clearly left"),
    "Slightly left": lazy_gettext("Slightly left"),
    "Slightly right": lazy_gettext("Slightly right"),
    "Clearly right": lazy_gettext("Clearly right"),
}

#: The ACR levels of :data:`app.trials.rating.ACR_LEVELS`, by their English text.
LEVEL_LABELS = {
    "Excellent": lazy_gettext("Excellent"),
    "Good": lazy_gettext("Good"),
    "Fair": lazy_gettext("Fair"),
    "Poor": lazy_gettext("Poor"),
    "Bad": lazy_gettext("Bad"),
}

#: A choice as a word in a sentence ("For this pair, please choose left.").
SIDE_NAMES = {
    "left": lazy_gettext("left"),
    "right": lazy_gettext("right"),
    "undecided": lazy_gettext("undecided"),
}


def demographic_words() -> dict[str, str]:
    """The built-in demographic questions (:data:`app.trials.questions.DEMOGRAPHICS`) and their
    options with words in them, by their English text, in the page's language: facepair's own
    words. The answer stored and exported stays the option as written there.

    Each is looked up in the catalogue's context ``demographics`` (gettext's ``msgctxt``):
    short words such as "none", "no" or "other" are translated as answers to these questions
    ("none": no experience with animation), which would be wrong anywhere else.
    """
    return {
        "Your age": pgettext("demographics", "Your age"),
        "65 or over": pgettext("demographics", "65 or over"),
        "prefer not to say": pgettext("demographics", "prefer not to say"),
        "Your gender": pgettext("demographics", "Your gender"),
        "female": pgettext("demographics", "female"),
        "male": pgettext("demographics", "male"),
        "non-binary": pgettext("demographics", "non-binary"),
        "other": pgettext("demographics", "other"),
        "Your native language": pgettext("demographics", "Your native language"),
        "Do you wear glasses or contact lenses to see a screen?": pgettext(
            "demographics", "Do you wear glasses or contact lenses to see a screen?"
        ),
        "no": pgettext("demographics", "no"),
        "yes, and I am wearing them now": pgettext(
            "demographics", "yes, and I am wearing them now"
        ),
        "yes, but I am not wearing them now": pgettext(
            "demographics", "yes, but I am not wearing them now"
        ),
        "Your experience with computer animation": pgettext(
            "demographics", "Your experience with computer animation"
        ),
        "none": pgettext("demographics", "none"),
        "I watch animated films or play games": pgettext(
            "demographics", "I watch animated films or play games"
        ),
        "I have made animations": pgettext("demographics", "I have made animations"),
        "I work in animation": pgettext("demographics", "I work in animation"),
    }


class QuestionWords(NamedTuple):
    """A questionnaire question as its page shows it."""

    #: The question.
    text: str
    #: Each option as (the answer stored and exported, the label shown).
    options: tuple[tuple[str, str], ...]
    #: facepair's own words (a built-in demographic question, translated), not the study
    #: file's (shown as written, in the study's language).
    builtin: bool


def question_words(question: QuestionSpec) -> QuestionWords:
    """``question``'s text and options in the page's language: a built-in demographic
    question (as the study file's ``demographics = true`` added it) through the catalogue,
    the study's own questions as written. Options keep their stored value either way, so
    ``answers.csv`` reads the same in every language."""
    if question not in DEMOGRAPHICS:
        return QuestionWords(question.text, tuple((c, c) for c in question.choices), False)

    words = demographic_words()

    def word(text: str) -> str:
        return words.get(text, text)

    options = tuple((choice, word(choice)) for choice in question.choices)
    return QuestionWords(word(question.text), options, True)


#: Why a session or study takes no more answers, as the services say it (English, in the API's
#: ``error``), and as the participant reads it (one or two whole sentences).
ENDED = {
    SCREENED_OUT: lazy_gettext(
        "Your session has ended because several attention checks were missed. "
        "Thank you for your time."
    ),
    SESSION_ENDED: lazy_gettext(
        "Your session ended after a long pause, and your place was given to another "
        "participant. Thank you for your time."
    ),
    "this study is closed": lazy_gettext("This study is closed. Thank you for taking part."),
}


def translated_answers(answers: tuple[rules.Answer, ...]) -> tuple[rules.Answer, ...]:
    """The answer buttons with their labels in the page's language (a study's own undecided
    label stays as written)."""
    return tuple(a._replace(label=str(ANSWER_LABELS.get(a.label, a.label))) for a in answers)


def rating_levels() -> list[dict[str, Any]]:
    """The ACR levels, best first, with their labels in the page's language."""
    return [{"score": score, "label": str(LEVEL_LABELS[label])} for score, label in ACR_LEVELS]


def ended_reason(message: str) -> str:
    """The participant's words for a service's reason (:data:`ENDED`), else the message."""
    found = ENDED.get(message)
    return str(found) if found is not None else message


def script_strings(max_plays: int | None = None, *, rating: bool = False) -> dict[str, Any]:
    """What the participant pages' scripts (``static/*.js``) say, in the page's language.
    ``plays_left[n]`` is the text for ``n`` plays left (``n`` up to ``max_plays``: each language
    has its own plural forms); ``rating``: a page of the rating designs, where a trial is a
    clip, not a pair."""
    return {
        "play": _("Play"),
        "play_again": _("Play again"),
        "plays_left": [
            ngettext("%(num)d play left", "%(num)d plays left", n)
            for n in range((max_plays or 0) + 1)
        ],
        "hint_tap": _("Tap Play to watch both faces."),
        "hint_press": _("Press Play (or Space) to watch both faces."),
        "hint_to_end": _("Watch the video to the end, then answer."),
        "hint_used": _("You have watched this pair as often as allowed: please answer."),
        "hint_choose": _("Choose the left or the right face."),
        "hint_choose_undecided": _("Choose the left or the right face, or that you cannot decide."),
        "hint_reasons": _("Tick what made the difference (optional), then press Next."),
        "ready_tap": _("Ready: tap Play"),
        "ready_press": _("Ready: press Play"),
        "start_tap": _("Please tap Play to start"),
        "start_press": _("Please press Play to start"),
        "again_tap": _("To watch again, tap Play"),
        "again_press": _("To watch again, press Play"),
        "please_answer": _("Please answer"),
        # Python's format: %% is one percent sign.
        "loading_percent": _("Loading… %(percent)s%%"),
        "load_retry": _("Could not load the video, retrying…"),
        "no_more_plays": (
            _("No more plays of this clip.") if rating else _("No more plays of this pair.")
        ),
        "offline": _(
            "No connection to the server. Your answer (%(choice)s) is kept on this page and "
            "will be sent automatically; please keep this page open. Retrying in "
            "%(seconds)s s…"
        ),
        "saving": _("Saving your answer…"),
        "saved": _("Saved."),
        "sending_kept": _("Sending the answer you gave before…"),
        "closed": _("This answer could not be recorded. %(reason)s"),
        "study_closed": str(ENDED["this study is closed"]),
        "refused": _("Your answer was not accepted. Please play the pair, then answer again."),
        "practice_answer": _(
            "Practice answer: %(choice)s. That is all there is to it; start when ready."
        ),
        "pair_of": _("Pair %(number)s of %(total)s"),
        "instructed": _("For this pair, please choose %(side)s."),
        "viewing_small": _(
            "The faces are shown %(shown)s pixels wide, but this study needs at least "
            "%(needed)s. Please use a larger window or screen (or turn your phone sideways), "
            "then press Start again."
        ),
        "choices": {choice: str(name) for choice, name in SIDE_NAMES.items()},
        "audio_playing": _("Playing…"),
        "audio_choose": _("Now choose one of the three sounds."),
        # the rating design (static/rating.js)
        "hint_watch_tap": _("Tap Play to watch the face."),
        "hint_watch_press": _("Press Play (or Space) to watch the face."),
        "hint_rate": _("Rate the face you saw."),
        "hint_slider": _("Move the slider to your rating, then press Next."),
        # the parallel design: no Play button, the reference and each version have their own
        "hint_parallel": _(
            "Play every version and move its slider; Next is enabled once each version was "
            "played and rated."
        ),
        "hint_parallel_start_tap": _("Tap “Reference” or a version's number to watch it."),
        "hint_parallel_start_press": _("Click “Reference” or a version's number to watch it."),
        "hint_parallel_done": _(
            "Every version is played and rated: press Next, or change a rating first."
        ),
        "parallel_start_tap": _("Please tap the button again to start"),
        "parallel_start_press": _("Please press the button again to start"),
        "refused_parallel": _(
            "Your ratings were not accepted. Please play every version, then rate them again."
        ),
        "offline_rating": _(
            "No connection to the server. Your rating is kept on this page and will be sent "
            "automatically; please keep this page open. Retrying in %(seconds)s s…"
        ),
        "refused_rating": _(
            "Your rating was not accepted. Please play the clip, then rate it again."
        ),
        # the next clip shown in place (static/rating.js), as its page would show it
        "clip_of": _("Clip %(number)s of %(total)s"),
        "catch_rating": _("For this clip, please answer %(level)s."),
        "catch_level": rating_levels()[-1]["label"],
    }
