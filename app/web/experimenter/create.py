"""Creating a study: from an uploaded study file with its media, or from the web form.

Both go through the study-file parser (``app.trials.studyfile``), so the web accepts exactly what
``facepair study create`` accepts: an uploaded study file names its media by file name
(``by_name``), so ``app/data/examples/study.toml`` uploads as it is. A failed attempt keeps its
files (``app.web.experimenter.uploads``) and its error names the file, not a row number of the
parser."""

from __future__ import annotations

import re
import tempfile
from pathlib import Path
from typing import Any

from flask import Response, abort, flash, redirect, render_template, request, url_for
from wtforms import SelectChoice

import app.web.experimenter.uploads as uploads
from app.data import data_path
from app.errors import InputError
from app.trials.participation import LANGUAGES, PORTRAIT_MODES
from app.trials.rules import DEFAULT_UNDECIDED_LABEL
from app.trials.studyfile import MODELS, loads_study, parse_study
from app.web.experimenter.blueprint import bp
from app.web.experimenter.forms import StudyFileForm, StudyWebForm
from app.web.experimenter.studyform import add_settings, field_errors, mark_field
from app.web.extensions import db
from app.web.infra.accounts import current_user, login_required
from app.web.infra.storage import disk_full, disk_full_message
from app.web.study.inputs import check_study_inputs
from app.web.study.studies import create_study

#: How the form's parts read in an error, by the parser's field name.
_FORM_FIELDS = {
    "name": "clip name",
    "audio": "audio",
    "ground_truth": "ground truth",
    "model": "model",
    "settings": "settings",
    "tracks": "tracks",
}


def _web_form_mapping(form: StudyWebForm, folder: Path) -> dict[str, Any]:
    """The web form as a study-file mapping, validated by the same parser as a TOML file.

    The files are in ``folder``'s ``audio``, ``ground_truth``, ``tracks`` and ``face`` folders.
    """

    def names(field: str) -> list[str]:
        where = folder / field
        return sorted(p.name for p in where.iterdir()) if where.is_dir() else []

    # a mesh track's template and head pose go beside it under its name, not as tracks
    siblings = (".obj", ".ply", ".pose.npy")
    truths = [t for t in names("ground_truth") if not t.lower().endswith(siblings)]
    clips = []
    for name in names("audio"):
        clip: dict[str, Any] = {"name": Path(name).stem, "audio": f"audio/{name}"}
        truth = next((t for t in truths if Path(t).stem == Path(name).stem), None)
        if truth:
            clip["ground_truth"] = f"ground_truth/{truth}"
        clips.append(clip)
    conditions: list[dict[str, Any]] = [{"name": m, "model": m} for m in form.models.data or []]
    uploaded: dict[str, dict[str, str]] = {}
    for name in names("tracks"):
        if name.lower().endswith(siblings):
            continue
        condition, _, clip_name = Path(name).stem.partition("__")
        if not clip_name:
            raise InputError(
                "expected <condition>__<clip> with .fap, .csv, .json, .bvh, .npy, .npz or .pkl",
                path=name,
                field="tracks",
            )
        uploaded.setdefault(condition, {})[clip_name] = f"tracks/{name}"
    conditions += [{"name": c, "tracks": t} for c, t in uploaded.items()]
    data: dict[str, Any] = {
        "title": form.title.data,
        "question": form.question.data,
        "instructions": form.instructions.data or "",
        "consent": form.consent.data or "",
        "design": form.design.data,
        "seed": form.seed.data or 0,
        "target_participants": form.target_participants.data or 1,
        "completion_code": form.completion_code.data or "",
        "undecided": {
            "allowed": bool(form.undecided_allowed.data),
            "label": form.undecided_label.data or DEFAULT_UNDECIDED_LABEL,
        },
        "replay": {"policy": form.replay.data},
        "catch": {"trials": form.catch_trials.data or 0},
        "clips": clips,
        "conditions": conditions,
        "eyes": form.eyes.data,
        "normalize": bool(form.normalize.data),
        "mismatched": bool(form.mismatched.data),
        "answer": {
            "scale": int(form.scale.data),
            "reasons": [t.strip() for t in (form.reasons.data or "").split(",") if t.strip()],
        },
        "attention": {
            "max_failed": form.max_failed.data or 0,
            "screened_out_code": form.screened_out_code.data or "",
        },
        "viewing": {
            "min_face_px": form.min_face_px.data or 0,
            "portrait": form.portrait.data or PORTRAIT_MODES[0],
        },
    }
    if form.replay.data == "max_plays":
        data["replay"]["max_plays"] = form.max_plays.data or 1
    if form.lips.data:
        data["lips"] = form.lips.data
    if form.brows.data and form.brows.data != "own":
        data["brows"] = form.brows.data
    if form.pad.data:
        data["pad"] = True
    if form.mesh_fps.data:
        data["meshes"] = {"fps": float(form.mesh_fps.data)}
    faces = [n for n in names("face") if not n.lower().endswith(".avatar.json")]
    if len(faces) > 1:
        raise InputError(
            f"one avatar at most, got {', '.join(faces)} (its sidecar is <name>.avatar.json)",
            field="avatar",
        )
    if faces:
        data["render"] = {"face": f"face/{faces[0]}"}
    if form.reference.data:
        data["reference"] = form.reference.data.strip()
    if form.redirect_url.data:
        data["redirect_url"] = form.redirect_url.data.strip()
    add_settings(form, data)
    return data


def form_error(exc: InputError, data: dict[str, Any]) -> InputError:
    """``exc`` about the form's ``clips[i]``/``conditions[i]`` retold with the file it is about.

    >>> data = {"clips": [{"name": "a", "audio": "audio/a.wav"}], "conditions": []}
    >>> str(form_error(InputError("missing", path="form", field="clips[0].ground_truth"), data))
    'a.wav: ground truth: missing'
    """
    found = re.fullmatch(r"(clips|conditions)\[(\d+)\]\.([a-z_]+)(?:\.(.*))?", exc.field or "")
    if found is None or int(found[2]) >= len(data.get(found[1], [])):
        return exc
    kind, index, key, clip = found[1], int(found[2]), found[3], found[4]
    item = data[kind][index]
    if kind == "clips":
        file = (
            item["ground_truth"]
            if key == "ground_truth" and "ground_truth" in item
            else item["audio"]
        )
        return InputError(exc.message, path=Path(file).name, field=_FORM_FIELDS.get(key, key))
    tracks = item.get("tracks", {})
    if clip in tracks:
        return InputError(exc.message, path=Path(tracks[clip]).name, field="track")
    if tracks:
        files = ", ".join(Path(t).name for t in tracks.values())
        return InputError(exc.message, path=files, field=_FORM_FIELDS.get(key, key))
    return InputError(exc.message, path=f"model {item['name']}", field=_FORM_FIELDS.get(key, key))


def _create(file_form: StudyFileForm, web_form: StudyWebForm, folder: Path):  # type: ignore[no-untyped-def]
    """The study the submitted form describes (not committed), or None; raises InputError."""

    user = current_user()
    if file_form.submit.data:
        uploads.restore(file_form.kept.data, user.id, folder)  # type: ignore[union-attr]
        upload = file_form.study_file.data
        uploads.save_uploads([upload] if upload else [], folder / "study_file")
        uploads.save_uploads(file_form.media.data or [], folder / "media")
        if not file_form.validate_on_submit():
            return _refused(file_form)
        studies = sorted((folder / "study_file").glob("*"))
        if not studies:
            raise InputError("choose a study file (.toml)", field="study file")
        source = studies[0].name
        text = studies[0].read_bytes().decode("utf-8", errors="replace")
        spec = loads_study(text, source=source, base_dir=folder / "media", by_name=True)
        check_study_inputs(spec)
        try:
            return create_study(user, spec, source_toml=text)  # type: ignore[arg-type]
        except InputError as exc:
            if exc.path:
                raise
            # A value the columns cannot hold is found when the rows are written: name the file.
            raise InputError(exc.message, path=source, field=exc.field) from None
    if web_form.submit.data:
        uploads.restore(web_form.kept.data, user.id, folder)  # type: ignore[union-attr]
        for field in ("audio", "ground_truth", "tracks", "face"):
            uploads.save_uploads(getattr(web_form, field).data or [], folder / field)
        if not web_form.validate_on_submit():
            return _refused(web_form)
        if not (folder / "audio").is_dir() or not any((folder / "audio").iterdir()):
            raise InputError("choose at least one audio file", field="clips")
        data = _web_form_mapping(web_form, folder)
        try:
            spec = parse_study(data, source="form", base_dir=folder, confine=True)
        except InputError as exc:
            mark_field(web_form, exc.field, exc.message)
            raise form_error(exc, data) from None
        check_study_inputs(spec)
        try:
            # kept as the file it amounts to: the study package's study.toml
            source = spec.to_portable_toml()
            return create_study(user, spec, source_toml=source)  # type: ignore[arg-type]
        except InputError as exc:
            mark_field(web_form, exc.field, exc.message)
            raise form_error(exc, data) from None
    return None


def _refused(form: StudyFileForm | StudyWebForm) -> None:
    """A form its own validation refused: one line for each bad field, naming it."""
    for line in field_errors(form):
        flash(line, "error")


@bp.route("/studies/new", methods=["GET", "POST"])
@login_required
def new_study():  # type: ignore[no-untyped-def]

    file_form = StudyFileForm(prefix="file")
    web_form = StudyWebForm(prefix="web")
    web_form.models.choices = [SelectChoice(m) for m in MODELS]
    user = current_user()
    status = 400 if request.method == "POST" else 200
    kept: dict[str, list[str]] = {}
    with tempfile.TemporaryDirectory(prefix="facepair-upload-") as tmp:
        folder = Path(tmp)
        try:
            study = _create(file_form, web_form, folder)
        except OSError as exc:
            if not disk_full(exc):
                raise
            db.session.rollback()
            flash(disk_full_message(exc), "error")
            return _page(file_form, web_form, {}), 507
        except InputError as exc:
            db.session.rollback()
            flash(str(exc), "error")
            study = None
        if study is not None:
            db.session.commit()
            for form in (file_form, web_form):
                uploads.discard(form.kept.data, user.id)  # type: ignore[union-attr]
            flash("Study created. Generate the tracks, then render the clips.", "ok")
            return redirect(url_for(".study", study_id=study.id))
        if request.method == "POST":
            form = file_form if file_form.submit.data else web_form
            kept = uploads.kept_names(folder)
            if any(kept.values()):
                uploads.discard(form.kept.data, user.id)  # type: ignore[union-attr]
                form.kept.data = uploads.keep(folder, user.id)  # type: ignore[union-attr]
    return _page(file_form, web_form, kept), status


def _page(file_form: StudyFileForm, web_form: StudyWebForm, kept: dict[str, list[str]]) -> str:
    return render_template(
        "experimenter/new_study.html",
        file_form=file_form,
        web_form=web_form,
        kept=kept,
        languages=LANGUAGES,
    )


def study_file_reference_path() -> Path | None:
    """docs/reference/studyfile.md: the wheel carries it as ``app/data/docs/studyfile.md``
    (pyproject.toml's force-include), a checkout has it in its docs folder."""
    for path in (
        data_path("docs", "studyfile.md"),
        Path(__file__).resolve().parents[3] / "docs" / "reference" / "studyfile.md",
    ):
        if path.is_file():
            return path
    return None


@bp.get("/studies/new/studyfile.md")
@login_required
def study_file_reference():  # type: ignore[no-untyped-def]
    """Every key a study file can say (docs/reference/studyfile.md), as text."""
    path = study_file_reference_path()
    if path is None:
        abort(404)
    return Response(path.read_bytes(), mimetype="text/plain; charset=utf-8")


@bp.get("/studies/new/example.toml")
@login_required
def example_study_file():  # type: ignore[no-untyped-def]
    """The shipped example study file (the thesis's Experiment 1 on the demo speech)."""
    return Response(
        data_path("examples", "study.toml").read_bytes(),
        mimetype="text/plain; charset=utf-8",
        headers={"Content-Disposition": 'attachment; filename="study.toml"'},
    )
