"""Experimenter forms (Flask-WTF: every form carries a CSRF token)."""

from __future__ import annotations

from flask_wtf import FlaskForm
from flask_wtf.file import FileAllowed, FileField
from wtforms import (
    BooleanField,
    EmailField,
    HiddenField,
    IntegerField,
    MultipleFileField,
    PasswordField,
    SelectChoice,
    SelectField,
    SelectMultipleField,
    StringField,
    SubmitField,
    TextAreaField,
)
from wtforms.validators import URL, DataRequired, Length, NumberRange, Optional
from wtforms.widgets import CheckboxInput, ListWidget

DESIGN_CHOICES = [
    SelectChoice("all_ordered", "All ordered pairs, same-condition pairs included (thesis)"),
    SelectChoice("reference", "Every condition against one reference (Le et al. 2012)"),
    SelectChoice("unordered_counterbalanced", "Unordered pairs, sides counterbalanced"),
]
REPLAY_CHOICES = [SelectChoice("unlimited", "Unlimited replays"),
                  SelectChoice("max_plays", "At most N plays"),
                  SelectChoice("play_to_end", "Must play to the end before voting")]


class LoginForm(FlaskForm):
    email = EmailField("E-mail", validators=[DataRequired()])
    password = PasswordField("Password", validators=[DataRequired()])
    submit = SubmitField("Log in")


class ActionForm(FlaskForm):
    """A bare form for buttons that change state (only the CSRF token)."""


class DeleteParticipantForm(FlaskForm):
    participant = StringField("Participant: P0007, a Prolific ID or its pseudonym",
                              validators=[DataRequired(), Length(max=200)])
    confirm = BooleanField("Delete this participant's votes and records for good",
                           validators=[DataRequired()])
    submit = SubmitField("Delete participant's data")


class StudyFileForm(FlaskForm):
    # Not FileRequired: after a failed attempt the kept study file stands in (``uploads``).
    study_file = FileField("Study file (.toml)", validators=[
        FileAllowed(["toml"], "a .toml study file")])
    media = MultipleFileField("Audio and track files it names (.wav, .fap, ...)")
    #: Token of the files kept from a failed attempt (``app.experimenter.uploads``).
    kept = HiddenField(validators=[Optional(), Length(max=64)])
    submit = SubmitField("Create study from file")


class StudyWebForm(FlaskForm):
    title = StringField("Title", validators=[DataRequired()])
    question = StringField("Question", validators=[DataRequired()],
                           default="Which animation looks more natural?")
    instructions = TextAreaField("Instructions")
    consent = TextAreaField("Consent text")
    models = SelectMultipleField("Conditions from models", choices=[],
                                 widget=ListWidget(prefix_label=False),
                                 option_widget=CheckboxInput())
    tracks = MultipleFileField("Uploaded tracks, named <condition>__<clip>.fap")
    # Required, but checked in the view: kept files of a failed attempt count.
    audio = MultipleFileField("Clips: audio files (the file name is the clip name)")
    ground_truth = MultipleFileField("Ground truth: <clip>.fap (optional)")
    design = SelectField("Pair design", choices=DESIGN_CHOICES, default="all_ordered")
    reference = StringField("Reference condition (design 'reference')")
    undecided_allowed = BooleanField("Allow an undecided answer", default=True)
    undecided_label = StringField("Label of the undecided answer", default="Undecided")
    replay = SelectField("Replay policy", choices=REPLAY_CHOICES, default="unlimited")
    max_plays = IntegerField("Maximum plays", validators=[Optional(), NumberRange(min=1)])
    catch_trials = IntegerField("Catch trials", default=0, validators=[NumberRange(min=0)])
    target_participants = IntegerField("Target participants", default=20,
                                       validators=[NumberRange(min=1)])
    completion_code = StringField("Completion code")
    redirect_url = StringField("Redirect URL after completion",
                               validators=[Optional(), URL(require_tld=False)])
    seed = IntegerField("Seed", default=0, validators=[NumberRange(min=0)])
    kept = HiddenField(validators=[Optional(), Length(max=64)])
    submit = SubmitField("Create study")


class ConfirmForm(FlaskForm):
    """A state change that needs a tick first (reopening a closed study)."""

    confirm = BooleanField("I understand", validators=[DataRequired()])


class DuplicateForm(FlaskForm):
    with_clips = BooleanField("Copy the generated tracks and rendered clips too")


class DeleteStudyForm(FlaskForm):
    #: The study's title, typed again: deleting a study cannot be undone.
    title = StringField("Type the study's title to delete it with all its data",
                        validators=[DataRequired(), Length(max=200)])


class ShareForm(FlaskForm):
    email = EmailField("Collaborator's e-mail", validators=[DataRequired(), Length(max=200)])
    access = SelectField("Access", choices=[
        SelectChoice("read", "read-only: monitor, exports, report"),
        SelectChoice("full", "full: also render, open, close, exclude")], default="read")


class ExcludeForm(FlaskForm):
    participant = HiddenField(validators=[DataRequired(), Length(max=20)])
    how = SelectField("", choices=[SelectChoice("excluded", "exclude"),
                                   SelectChoice("returned", "returned on Prolific")],
                      default="excluded")
    reason = StringField("Reason", validators=[Optional(), Length(max=300)])
