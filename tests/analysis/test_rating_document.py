"""The ratings report's content: the MOS figure, the tables in reading order, the
post-screening paragraph of a parallel test, and the terminal summary."""

from __future__ import annotations

from app.analysis.document import Heading, Paragraph, Plot, Table
from app.analysis.rating_document import mos_figure, rating_blocks, summary_text
from app.analysis.rating_results import analyze_ratings, ratings_text, read_ratings
from tests.analysis.test_rating_results import _parallel_rows, _rows


def _results(rows, tmp_path, **options):
    path = tmp_path / "ratings.csv"
    path.write_text(ratings_text(rows))
    return analyze_ratings(read_ratings(path), source=str(path), **options)


def test_the_blocks_of_a_rating_report(tmp_path):
    results = _results(_rows(), tmp_path)
    blocks = rating_blocks(results)
    kinds = [type(b).__name__ for b in blocks]
    assert kinds[:2] == ["Heading", "Paragraph"] and "Plot" in kinds
    captions = [b.caption for b in blocks if isinstance(b, Table | Plot)]
    assert captions[0] == "Participants left out of the analysis."
    assert any(c.startswith("Table 1. MOS") for c in captions)
    assert any(c.startswith("Table 2. Pairwise contrasts") for c in captions)
    assert isinstance(blocks[-1], Paragraph) and "REML" in blocks[-1].text
    assert any(isinstance(b, Heading) and b.text == "Method" for b in blocks)
    figure = mos_figure(results)
    assert [t.get_text() for t in figure.axes[0].get_yticklabels()] == [
        "none",
        "random",
        "ground_truth",
    ]  # best on top
    text = summary_text(results)
    assert text.splitlines()[0].startswith("72 ratings, 12 participants, 2 clips; scale acr5")
    assert "contrasts: 3 of 3 pairs differ (Holm p < .05)" in text


def test_a_parallel_report_says_its_post_screening(tmp_path):
    blocks = rating_blocks(_results(_parallel_rows(), tmp_path))
    said = " ".join(b.text for b in blocks if isinstance(b, Paragraph))
    assert "Post-screening (ITU-R BS.1534-3, sec. 4.1.2" in said and "left out by it: P03" in said
