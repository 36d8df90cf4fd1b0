"""The report section on the answer details (``app.analysis.report.answer_document``), on
votes whose answers are known (those of ``tests/support/answer_votes.py``)."""

import pandas as pd

from app.analysis import analyze
from app.analysis.report.answer_document import answer_detail_blocks
from app.analysis.report.blocks import Heading, Plot, Table
from app.analysis.report.document import build_document
from tests.support.answer_votes import answer_frame


def test_the_report_has_the_tables_and_figures_only_when_asked():
    frame = pd.concat([answer_frame(participant="p1"), answer_frame(participant="p2")])
    results = analyze(frame, conditions=["a", "b", "c"], bootstrap=20, mixed_model=False)
    assert results["strengths"]["pooled"] == [4, 2, 2, 2, 2]
    assert results["reasons"]["tags"]["lips"]["total"] == 6
    blocks = answer_detail_blocks(results)
    assert isinstance(blocks[0], Heading) and blocks[0].text == "Answer details"
    tables = [b for b in blocks if isinstance(b, Table)]
    assert tables[0].rows[0] == ["a vs b", "4", "2", "2", "2", "0", "10", "0.80"]
    assert tables[0].rows[-1][0] == "all pairs" and tables[1].rows[0][:2] == ["lips", "6"]
    assert sum(isinstance(b, Plot) for b in blocks) == 2
    headings = [b.text for b in build_document(results) if isinstance(b, Heading)]
    assert "Answer details" in headings
    plain = analyze(
        frame.drop(columns=["strength", "reasons"]),
        conditions=["a", "b", "c"],
        bootstrap=20,
        mixed_model=False,
    )
    assert answer_detail_blocks(plain) == []
