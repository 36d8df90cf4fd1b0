"""Reading a study package back (``app.analysis.package``): the manifest's checks, one line
for every problem, and ``facepair analyze`` on a package."""

import json
import zipfile

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.analysis.package import PACKAGE_FORMAT, read_package, sha256_bytes
from app.cli import main
from app.errors import InputError

VOTES = (
    "participant,clip,left,right,choice\n"
    + "".join(f"p{i},s1,a,b,{'left' if i % 3 else 'right'}\n" for i in range(6))
    + "".join(f"p{i},s1,b,a,right\n" for i in range(6))
)


def _package(path, votes=VOTES, manifest=None, **analysis):
    manifest = manifest or {
        "format": PACKAGE_FORMAT,
        "files": {"votes.csv": sha256_bytes(votes.encode())},
        "analysis": {"conditions": ["b", "a"], "exclude": None, **analysis},
    }
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("manifest.json", json.dumps(manifest))
        archive.writestr("votes.csv", votes)
    return path


def test_the_votes_and_the_report_options_come_back(tmp_path):
    package = read_package(_package(tmp_path / "p.zip"))
    assert package.table_text == VOTES and package.conditions == ["b", "a"]
    assert package.exclude is None


@pytest.mark.parametrize(
    ("manifest", "message"),
    [
        ({"format": "other"}, "manifest.json: not a facepair-study-package/1 manifest"),
        ({"format": PACKAGE_FORMAT, "files": {}}, "votes.csv: its SHA-256 is not the manifest's"),
        (
            {
                "format": PACKAGE_FORMAT,
                "files": {"votes.csv": sha256_bytes(VOTES.encode())},
                "analysis": {"conditions": "a,b"},
            },
            "manifest.json: analysis.conditions is not a list of names",
        ),
    ],
)
def test_a_bad_manifest_is_one_line(tmp_path, manifest, message):
    with pytest.raises(InputError) as caught:
        read_package(_package(tmp_path / "p.zip", manifest=manifest))
    assert message in str(caught.value) and "\n" not in str(caught.value)
    assert str(caught.value).startswith(str(tmp_path / "p.zip"))


def test_changed_votes_are_refused(tmp_path):
    path = _package(tmp_path / "p.zip")
    changed = tmp_path / "changed.zip"
    with zipfile.ZipFile(path) as source, zipfile.ZipFile(changed, "w") as target:
        target.writestr("manifest.json", source.read("manifest.json"))
        target.writestr("votes.csv", VOTES.replace("right", "left", 1))
    with pytest.raises(InputError, match="votes.csv: its SHA-256 is not the manifest's"):
        read_package(changed)


def test_analyze_takes_a_package_and_its_conditions(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _package(tmp_path / "p.zip", exclude="undecided>0.9")
    result = CliRunner().invoke(main, ["analyze", "p.zip", "--json", "r.json", "--bootstrap", "0"])
    assert result.exit_code == 0, result.output
    results = json.loads((tmp_path / "r.json").read_text())
    assert results["conditions"] == ["b", "a"] and results["quality"]["rules"] == ["undecided>0.9"]
    assert results["input"]["source"] == "p.zip/votes.csv"
    plain = tmp_path / "not.zip"
    plain.write_bytes(b"PK\x03\x04 not really")
    broken = CliRunner().invoke(main, ["analyze", str(plain)])
    assert broken.exit_code == 2 and len(broken.output.strip().splitlines()) == 1


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    manifest=st.recursive(
        st.none() | st.booleans() | st.integers() | st.text(max_size=20),
        lambda inner: (
            st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=10), inner, max_size=4)
        ),
        max_leaves=12,
    ),
    votes=st.binary(max_size=200),
)
def test_any_manifest_or_votes_is_read_or_refused_in_one_line(tmp_path, manifest, votes):
    path = tmp_path / "any.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("manifest.json", json.dumps(manifest))
        archive.writestr("votes.csv", votes)
    try:
        read_package(path)
    except InputError as exc:
        assert "\n" not in str(exc)
