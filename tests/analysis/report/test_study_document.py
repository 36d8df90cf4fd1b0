from app.analysis import analyze
from app.analysis.report.blocks import Heading, Paragraph, Table
from app.analysis.report.document import build_document
from app.analysis.report.study_document import study_blocks
from app.analysis.simulate import simulate_votes


def test_a_study_head_names_the_study_and_the_command():
    votes = simulate_votes({"a": 0.0, "b": 1.0}, participants=3, clips=("x",))
    results = analyze(votes, bootstrap=0)
    results["study"] = {
        "title": "Eyebrows",
        "date": "2026-12-01 10:00 UTC",
        "design": "Design: all_ordered.",
        "participants": "3 included.",
        "command": "facepair analyze votes.csv --report report.html",
    }
    blocks = build_document(results)
    assert isinstance(blocks[0], Heading) and blocks[0].text == "Eyebrows"
    texts = [b.text for b in blocks if isinstance(b, Paragraph)]
    assert any("facepair analyze votes.csv --report report.html" in t for t in texts)


def test_the_questionnaire_counts_options_summarises_numbers_and_lists_texts():
    study = {
        "title": "Eyebrows",
        "date": "2026-12-01 10:00 UTC",
        "questionnaire": [
            {"kind": "choice", "text": "Hand", "answered": 3, "asked": 4,
             "counts": {"left": 1, "right": 2, "both": 0}},
            {"kind": "number", "text": "Age", "answered": 3, "asked": 4, "median": 31.0,
             "min": 22.0, "max": 60.5},
            {"kind": "number", "text": "Hours", "answered": 0, "asked": 4},
            {"kind": "text", "text": "Remarks", "answered": 2, "asked": 4, "texts": ["ok", "no"]},
        ],
    }  # fmt: skip
    blocks = study_blocks(study)
    assert [type(b) for b in blocks] == [Heading, Paragraph, Heading, Table]
    assert blocks[1].text == "Report written 2026-12-01 10:00 UTC. "
    assert blocks[3].rows == [
        ["Hand", "3 of 4", "left: 1; right: 2"],
        ["Age", "3 of 4", "median 31, range 22-60.5"],
        ["Hours", "0 of 4", "-"],
        ["Remarks", "2 of 4", "ok | no"],
    ]
