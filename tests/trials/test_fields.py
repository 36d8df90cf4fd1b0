"""Typed field access: each accessor's one-line errors, booleans kept apart, confined paths."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.errors import InputError
from app.trials.fields import MISSING, FieldReader, describe


@pytest.fixture
def reader(tmp_path: Path) -> FieldReader:
    (tmp_path / "a.wav").write_bytes(b"")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.wav").write_bytes(b"")
    return FieldReader("s.toml", tmp_path)


def message(call: object) -> str:
    with pytest.raises(InputError) as caught:
        call()  # type: ignore[operator]
    assert "\n" not in str(caught.value)
    return str(caught.value)


def test_values_pass_through(reader: FieldReader, tmp_path: Path) -> None:
    data = {"n": 3, "t": "x", "c": "b", "f": "sub/b.wav", "flag": False, "id": "speech_2"}
    assert reader.integer(data, "n", "n", MISSING, 0) == 3
    assert reader.integer(data, "absent", "absent", 5, 0) == 5
    assert reader.text(data, "t", "t") == "x"
    assert reader.choice(data, "c", "c", ("a", "b")) == "b"
    assert reader.file(data, "f", "f", (".wav",)) == tmp_path / "sub" / "b.wav"
    assert reader.file(data, "absent", "absent", (".wav",), None) is None
    assert reader.get(data, "flag", "flag", (bool,), "true or false") is False
    assert reader.identifier(data, "id", "id") == "speech_2"
    assert reader.table({"k": 1}, "tbl", ("k",)) == {"k": 1}


def test_each_accessor_names_source_and_field(reader: FieldReader) -> None:
    data = {"b": True, "s": "", "n": -2, "c": "z", "f": "a.mp4", "g": "gone.wav", "id": "a b"}
    assert message(lambda: reader.integer(data, "x", "p.x", MISSING, 0)) == (
        "s.toml: p.x: missing (required)"
    )
    assert message(lambda: reader.integer(data, "b", "b", MISSING, 0)) == (
        "s.toml: b: expected an integer, got true"
    )
    assert message(lambda: reader.integer(data, "n", "n", MISSING, 0)) == (
        "s.toml: n: must be >= 0, got -2"
    )
    assert message(lambda: reader.text(data, "s", "s", nonempty=True)) == (
        "s.toml: s: must not be empty"
    )
    assert message(lambda: reader.choice(data, "c", "c", ("a", "b"))) == (
        "s.toml: c: expected one of a, b, got 'z'"
    )
    assert message(lambda: reader.file(data, "f", "f", (".wav", ".flac"))) == (
        "s.toml: f: expected a .wav or .flac file, got 'a.mp4'"
    )
    assert message(lambda: reader.file(data, "g", "g", (".wav",))).startswith(
        "s.toml: g: no such file: "
    )
    assert "expected a name of letters" in message(lambda: reader.identifier(data, "id", "id"))
    assert (
        message(lambda: reader.table([], "t", ("k",)))
        == "s.toml: t: expected a table, got an array"
    )
    assert message(lambda: reader.table({"q": 1}, "t", ("k",))) == (
        "s.toml: t.q: unknown key (expected one of k)"
    )
    assert message(lambda: reader.table({"q": 1}, "", ("k",))) == (
        "s.toml: q: unknown key (expected one of k)"
    )
    assert message(lambda: reader.table({"a\nb": 1}, "t", ("k",))) == (
        's.toml: t."a\\nb": unknown key (expected one of k)'
    )
    assert message(lambda: reader.file({"f": "x\ny.wav"}, "f", "f", (".wav",))).endswith("y.wav'")


def test_confined_paths_stay_inside_the_folder(tmp_path: Path) -> None:
    (tmp_path / "up").mkdir()
    (tmp_path / "up" / "ok.wav").write_bytes(b"")
    (tmp_path / "secret.wav").write_bytes(b"")
    confined = FieldReader("upload.toml", tmp_path / "up", confine=True)
    assert confined.file({"f": "ok.wav"}, "f", "f", (".wav",)) == tmp_path / "up" / "ok.wav"
    for bad in ("../secret.wav", str(tmp_path / "secret.wav"), "./../up/../secret.wav"):
        assert message(lambda bad=bad: confined.file({"f": bad}, "f", "f", (".wav",))) == (
            f"upload.toml: f: must be a path inside the study's folder, got {bad!r}"
        )
    free = FieldReader("local.toml", tmp_path / "up")
    assert free.file({"f": "../secret.wav"}, "f", "f", (".wav",)) == tmp_path / "secret.wav"


def test_unchecked_files_may_be_absent(tmp_path: Path) -> None:
    reader = FieldReader("s.toml", tmp_path, check_files=False)
    assert reader.file({"f": "x/none.wav"}, "f", "f", (".wav",)) == tmp_path / "x" / "none.wav"


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (True, "true"),
        (False, "false"),
        ("x", "'x'"),
        (2, "2"),
        (1.5, "1.5"),
        ([], "an array"),
        ({}, "a table"),
        (None, "NoneType"),
    ],
)
def test_describe(value: object, text: str) -> None:
    assert describe(value) == text


def test_uploaded_paths_are_matched_by_file_name(tmp_path: Path) -> None:
    (tmp_path / "up").mkdir()
    (tmp_path / "up" / "speech.wav").write_bytes(b"")
    (tmp_path / "speech2.wav").write_bytes(b"")
    reader = FieldReader("study.toml", tmp_path / "up", by_name=True)
    for written in (
        "../demo/speech.wav",
        "speech.wav",
        "C:\\audio\\speech.wav",
        str(tmp_path / "elsewhere" / "speech.wav"),
    ):
        assert reader.file({"f": written}, "f", "f", (".wav",)) == tmp_path / "up" / "speech.wav"
    # A file beside the upload folder is never reached, whatever the path says.
    for bad in ("../speech2.wav", str(tmp_path / "speech2.wav"), "x/../speech2.wav"):
        assert "no uploaded file named" in message(
            lambda bad=bad: reader.file({"f": bad}, "f", "f", (".wav",))
        )
