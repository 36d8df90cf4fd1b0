import base64
import re

import pytest

from app.analysis import analyze
from app.analysis.example import EXAMPLE, TRUE_SCALE
from app.analysis.report.writer import write_report
from app.analysis.simulate import simulate_votes
from app.errors import InputError


@pytest.fixture(scope="module")
def results():
    votes = simulate_votes(TRUE_SCALE, **EXAMPLE)
    return analyze(votes, conditions=list(TRUE_SCALE), bootstrap=200)


def test_html_is_self_contained_and_complete(tmp_path, results):
    html_path, pdf_path = tmp_path / "r.html", tmp_path / "r.pdf"
    write_report(results, html_path, pdf_path)
    text = html_path.read_text(encoding="utf-8")
    assert "<script" not in text and not re.search(r'(src|href)="(?!data:)', text)
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', text)
    assert len(images) == 6
    assert all(base64.b64decode(i).startswith(b"\x89PNG") for i in images)
    for heading in (
        "Ballots",
        "Pairwise preferences",
        "Per-participant scores",
        "Agreement and consistence",
        "Scale",
        "Method",
    ):
        assert f"<h2>{heading}</h2>" in text
    u = results["pooled"]["agreement"]["u"]
    assert f"u = {u:.3f}" in text
    assert "Skipped bad rows: 0" in text and "undecided votes excluded" in text
    for c in TRUE_SCALE:
        assert f"{c} ({results['pooled']['ballots'][c]})" in text
    pdf = pdf_path.read_bytes()
    assert pdf.startswith(b"%PDF") and pdf.count(b"/Type /Page\n") + pdf.count(b"/Type /Page ") >= 4


def test_skipped_rows_and_split_are_stated(tmp_path, results):
    changed = dict(results)
    changed["input"] = dict(results["input"], skipped_rows=3)
    changed["options"] = dict(results["options"], undecided="split")
    write_report(changed, tmp_path / "r.html")
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "3 bad rows of the votes file were skipped" in text
    assert "Undecided votes: split" in text
    assert not (tmp_path / "r.pdf").exists()


def test_missing_folder_is_an_input_error(tmp_path, results):
    with pytest.raises(InputError, match="folder does not exist"):
        write_report(results, tmp_path / "no" / "r.html")


@pytest.mark.parametrize(
    ("rows", "note"),
    [
        ([("p", "c", "A", "A", "left")], "fewer than two conditions"),
        (
            [("p", "c", "A", "B", "undecided"), ("q", "c", "B", "A", "undecided")],
            "fewer than two conditions",
        ),
        ([("p", "c", "A", "B", "left")], None),
        ([("p", "c", "A", "B", "left"), ("p", "c", "C", "D", "left")], "do not link"),
    ],
)
def test_degenerate_studies_still_report(tmp_path, rows, note):
    import pandas as pd

    frame = pd.DataFrame(rows, columns=["participant", "clip", "left", "right", "choice"])
    r = analyze(frame, bootstrap=20)
    assert (r["pooled"]["scale_note"] is None) == (note is None)
    if note:
        assert note in r["pooled"]["scale_note"]
    write_report(r, tmp_path / "r.html", tmp_path / "r.pdf")
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "<h2>Scale</h2>" in text and (tmp_path / "r.pdf").stat().st_size > 1000


@pytest.mark.slow
def test_reviewer_sections_say_which_to_cite(tmp_path):
    votes = simulate_votes(TRUE_SCALE, **EXAMPLE)
    r = analyze(votes, conditions=list(TRUE_SCALE), bootstrap=100, exclude="outlier>1.0")
    write_report(r, tmp_path / "r.html")
    text = (tmp_path / "r.html").read_text(encoding="utf-8")
    for heading in (
        "Participant-level inference",
        "Bradley-Terry-Davidson model with ties and side",
        "Participant quality",
    ):
        assert f"<h2>{heading}</h2>" in text
    assert "Which is which" in text and "Cite the participant-level tests" in text
    assert "Table 7. Participant-level Wilcoxon" in text and "Table 9. Bradley-Terry" in text
    excluded = r["quality"]["excluded"]
    assert excluded and all(f"{pid}: outlier&gt;1" in text for pid in excluded)
    one = r["pooled"]["one_per_participant"]["agreement"]
    assert f"u = {one['u']:.3f}" in text
