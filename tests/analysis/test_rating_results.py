"""The ratings table and its analysis: known MOS on constructed ratings, checks and excluded
participants left out with their reason, one-line errors, and ``facepair analyze`` on a
ratings.csv writing JSON, HTML and PDF."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from app.analysis.rating_results import (
    analyze_ratings,
    is_ratings_file,
    ratings_text,
    read_ratings,
)
from app.cli import main
from app.errors import InputError
from tests.support.rating_rows import TRUE_MOS, acr_rows, parallel_rows


def test_known_means_are_recovered_and_the_left_out_named(tmp_path):
    path = tmp_path / "ratings.csv"
    path.write_text(ratings_text(acr_rows()))
    assert is_ratings_file(path)
    results = analyze_ratings(read_ratings(path), source=str(path))
    mos = results["mos"]
    assert results["input"]["left_out"] == {"PX": "failed a catch trial"}
    assert results["input"]["participants"] == 12 and results["input"]["ratings"] == 72
    assert results["input"]["catch"] == {"trials": 12, "failed": 1}
    for c, mu in TRUE_MOS.items():
        low, high = mos["ci"][c]
        assert low < mu < high and abs(mos["mos"][c] - mu) < 0.35
    contrasts = {(r["a"], r["b"]): r for r in mos["contrasts"]}
    assert contrasts[("ground_truth", "none")]["p_holm"] < 0.001
    json.dumps(results, allow_nan=False)


def test_analyze_command_on_a_ratings_file(tmp_path):
    (tmp_path / "ratings.csv").write_text(ratings_text(acr_rows()))
    out = CliRunner().invoke(
        main,
        [
            "analyze",
            str(tmp_path / "ratings.csv"),
            "--json",
            str(tmp_path / "r.json"),
            "--report",
            str(tmp_path / "r.html"),
            "--pdf",
            str(tmp_path / "r.pdf"),
        ],
    )
    assert out.exit_code == 0, out.output
    assert "72 ratings, 12 participants, 2 clips; scale acr5; left out: PX" in out.output
    page = (tmp_path / "r.html").read_text()
    assert "Mean opinion scores" in page and "data:image/png;base64," in page
    assert "failed a catch trial" in page and "Holm" in page
    assert (tmp_path / "r.pdf").read_bytes().startswith(b"%PDF")
    assert json.loads((tmp_path / "r.json").read_text())["kind"] == "rating"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("participant,clip,score\np,s,3\n", "header: missing column(s): condition"),
        ("participant,clip,condition,score\np,s,a,4.5\n", ":2: score: expected a whole number"),
        ("participant,clip,condition,score\np,s,a,\n", ":2: score: expected a whole number"),
        ("participant,clip,condition,score,kind\np,s,a,3,practice\n", ":2: kind: expected"),
        ("participant,clip,condition,score\n,s,a,3\n", ":2: participant: empty"),
        # a field more than the header names: refused, not its last field dropped
        ("participant,clip,condition,score\np,s,a,3\np,s,b,4,9\n", "Expected 4 fields in line 3"),
    ],
)
def test_a_bad_file_is_one_line(tmp_path, text, message):
    (tmp_path / "r.csv").write_text(text)
    with pytest.raises(InputError) as caught:
        read_ratings(tmp_path / "r.csv")
    assert message in str(caught.value) and "\n" not in str(caught.value)
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "r.csv")])
    assert out.exit_code == 2 and "Traceback" not in out.output


@settings(max_examples=80, deadline=None)
@given(
    cells=st.lists(
        st.tuples(
            st.text(max_size=4),
            st.text(max_size=4),
            st.text(max_size=4),
            st.one_of(st.text(max_size=5), st.integers(-5, 200).map(str)),
        ),
        min_size=1,
        max_size=6,
    )
)
def test_any_table_is_read_or_refused_in_one_line(cells):
    frame = pd.DataFrame(cells, columns=["participant", "clip", "condition", "score"])
    try:
        table = read_ratings(frame)
    except InputError as exc:
        assert "\n" not in str(exc) and exc.field in {"participant", "clip", "condition", "score"}
    else:
        assert table["score"].between(0, 100).all()


def test_parallel_post_screening_leaves_out_who_misses_the_hidden_reference(tmp_path):
    path = tmp_path / "ratings.csv"
    path.write_text(ratings_text(parallel_rows()))
    results = analyze_ratings(read_ratings(path))
    assert list(results["input"]["left_out"]) == ["P03"]
    assert "below 90 on 1 of 4 clips" in results["input"]["left_out"]["P03"]
    assert results["input"]["participants"] == 3
    # the thresholds are parameters: one clip in four is allowed at 25 %
    lenient = analyze_ratings(read_ratings(path), reference_share=0.25)
    assert lenient["input"]["left_out"] == {} and lenient["screening"]["share"] == 0.25
    out = CliRunner().invoke(
        main,
        ["analyze", str(path), "--reference-below", "50", "--report", str(tmp_path / "r.html")],
    )
    assert out.exit_code == 0, out.output
    assert "left out: nobody" in out.output
    assert "Post-screening (ITU-R BS.1534-3" in (tmp_path / "r.html").read_text()


def test_a_ratings_file_without_its_scores_is_named_as_ratings(tmp_path):
    """A ratings export whose score column was renamed is still read as ratings, so its
    one line names the ratings' missing column, not the votes format's."""
    (tmp_path / "r.csv").write_text("participant,clip,condition,rating\np,s,a,3\n")
    assert is_ratings_file(tmp_path / "r.csv")
    out = CliRunner().invoke(main, ["analyze", str(tmp_path / "r.csv")])
    assert out.exit_code != 0
    assert "header: missing column(s): score" in out.output and "choice" not in out.output
    (tmp_path / "v.csv").write_text("participant,clip,left,right,choice\np,s,a,b,left\n")
    assert not is_ratings_file(tmp_path / "v.csv")


def test_a_test_whose_post_screening_leaves_out_everyone_says_so(tmp_path):
    """Every participant misses the hidden reference: the one line begins as any ratings
    table without a rating does, and names the screening, how many it left out and its rule."""
    rows = [{**row, "score": 50} if row["reference"] else row for row in parallel_rows()]
    path = tmp_path / "ratings.csv"
    path.write_text(ratings_text(rows))
    with pytest.raises(InputError) as caught:
        analyze_ratings(read_ratings(path))
    message = caught.value.message
    assert message.startswith("no ratings to analyse")
    assert "the hidden-reference post-screening (ITU-R BS.1534-3 sec. 4.1.2) left out all 4 " in (
        message
    )
    assert "below 90 on more than 15 %" in message and "\n" not in message
    out = CliRunner().invoke(main, ["analyze", str(path)])
    assert out.exit_code == 2 and "left out all 4 participants" in out.output
    assert "Traceback" not in out.output


def test_the_screened_column_is_for_people(tmp_path):
    """``screened`` (the export's record of the post-screening) is not read back: the analysis
    decides the screening from the scores, and a file without the column reads the same."""
    rows = parallel_rows()
    with_column = tmp_path / "new.csv"
    with_column.write_text(
        ratings_text([{**row, "screened": "a note" if row["participant"] == "P00" else ""}
                      for row in rows])
    )  # fmt: skip
    old = tmp_path / "old.csv"  # as written before the column was added
    table = pd.read_csv(with_column, dtype=str, keep_default_na=False)
    table.drop(columns="screened").to_csv(old, index=False)
    assert "screened" in with_column.read_text().splitlines()[0]
    assert "screened" not in old.read_text().splitlines()[0]
    new_frame, old_frame = read_ratings(with_column), read_ratings(old)
    assert "screened" not in new_frame.columns
    pd.testing.assert_frame_equal(new_frame, old_frame)
    assert list(analyze_ratings(new_frame)["input"]["left_out"]) == ["P03"]
