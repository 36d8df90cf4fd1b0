"""The ratings report's content: the MOS figure, the tables in reading order, the
post-screening paragraph of a parallel test, and the terminal summary."""

from __future__ import annotations

from app.analysis.rating_results import analyze_ratings, ratings_text, read_ratings
from app.analysis.report.blocks import Heading, Paragraph, Plot, Table
from app.analysis.report.rating_document import mos_figure, rating_blocks, summary_text
from tests.support.rating_rows import acr_rows, parallel_rows


def _results(rows, tmp_path, **options):
    path = tmp_path / "ratings.csv"
    path.write_text(ratings_text(rows))
    return analyze_ratings(read_ratings(path), source=str(path), **options)


def test_the_blocks_of_a_rating_report(tmp_path):
    results = _results(acr_rows(), tmp_path)
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
    blocks = rating_blocks(_results(parallel_rows(), tmp_path))
    said = " ".join(b.text for b in blocks if isinstance(b, Paragraph))
    assert "Post-screening (ITU-R BS.1534-3, sec. 4.1.2" in said and "left out by it: P03" in said


def _one_participant(flat: bool) -> list[dict]:
    """One participant's ratings of three conditions on three clips: the same score on every
    clip (``flat``), or scores that vary from clip to clip."""
    rows = []
    for k, clip in enumerate(("s2", "s7", "s9")):
        for c, mu in (("none", 2), ("random", 3), ("ground_truth", 4)):
            score = mu if flat else min(5, mu + (k + len(c)) % 2)
            rows.append(
                {"participant": "P0000", "clip": clip, "condition": c, "score": score,
                 "scale": "acr5", "kind": "trial"}
            )  # fmt: skip
    return rows


def test_one_participant_gives_means_and_no_interval(tmp_path):
    """The participants are the sampled unit: with one, the report prints each condition's
    mean and "-" for every interval, test and spread, and says why; the JSON holds null."""
    import json
    import re

    for flat in (True, False):
        results = _results(_one_participant(flat), tmp_path)
        mos = results["mos"]
        assert all(mos["ci"][c] == [None, None] for c in mos["conditions"])
        assert all(c["ci"] == [None, None] and c["p"] is None for c in mos["contrasts"])
        assert mos["sd_participant"] is None and mos["sd_residual"] is None
        json.dumps(results, allow_nan=False)
        mos_figure(results).canvas.draw()  # the means without error bars
        blocks = rating_blocks(results)
        said = " ".join(b.text for b in blocks if isinstance(b, Paragraph))
        assert "one participant: no interval (the participants are the sampled unit)" in said
        table1, table2 = (b for b in blocks if isinstance(b, Table) and b.caption[:6] == "Table ")
        assert [row[2] for row in table1.rows] == ["[-, -]"] * 3
        assert "sd residual -" in table1.note and "converged" not in table1.note
        assert {tuple(row[2:]) for row in table2.rows} == {("[-, -]", "-", "-", "-")}
        cells = " ".join(" ".join(row) for t in (table1, table2) for row in t.rows)
        assert not re.search(r"\[(-?\d+\.\d+), \1\]", cells)  # no zero-width interval
        text = summary_text(results)
        assert "1 participant, 3 clips" in text and "[-, -]" in text
        assert "no interval with one participant" in text
