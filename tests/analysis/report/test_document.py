from app.analysis import analyze
from app.analysis.report.blocks import Heading, Paragraph, Plot, Table
from app.analysis.report.document import build_document
from app.analysis.simulate import simulate_votes


def test_document_order_and_tables():
    votes = simulate_votes({"a": 0.0, "b": 1.0, "c": 2.0}, participants=6, clips=("x",))
    blocks = build_document(analyze(votes, bootstrap=20))
    headings = [b.text for b in blocks if isinstance(b, Heading)]
    assert headings[:3] == ["Results", "Ballots", "Pairwise preferences"]
    tables = [b for b in blocks if isinstance(b, Table)]
    assert all(len(row) == len(t.header) for t in tables for row in t.rows)
    assert sum(isinstance(b, Plot) for b in blocks) == 6


def test_any_small_study_builds_a_document():
    import pandas as pd
    from hypothesis import given, settings
    from hypothesis import strategies as st

    rows = st.lists(
        st.tuples(
            st.sampled_from(["p", "q", "r"]),
            st.sampled_from(["s2", "s7"]),
            st.sampled_from("ABC"),
            st.sampled_from("ABC"),
            st.sampled_from(["left", "right", "undecided"]),
        ),
        min_size=1,
        max_size=25,
    )

    @settings(max_examples=15, deadline=None)
    @given(rows, st.sampled_from(["exclude", "split"]))
    def check(votes, undecided):
        frame = pd.DataFrame(votes, columns=["participant", "clip", "left", "right", "choice"])
        blocks = build_document(analyze(frame, undecided=undecided, bootstrap=10))
        for block in blocks:
            if isinstance(block, Plot):
                block.figure.canvas.draw()

    check()


def test_one_participant_is_one_participant_and_no_folder_is_printed(tmp_path):
    import pandas as pd

    frame = pd.DataFrame(
        [("p", "x", "A", "B", "left"), ("p", "x", "B", "A", "right")],
        columns=["participant", "clip", "left", "right", "choice"],
    )
    path = tmp_path / "server" / "study-7" / "votes.csv"
    path.parent.mkdir(parents=True)
    frame.to_csv(path, index=False)
    text = " ".join(
        b.text for b in build_document(analyze(path, bootstrap=0)) if isinstance(b, Paragraph)
    )
    assert "1 participant cast 2 votes on 1 clip " in text
    assert "1 participants" not in text
    assert "Source: votes.csv." in text and str(tmp_path) not in text


def test_catch_rows_and_excluded_participants_stay_out(tmp_path):
    """The export's ``kind`` and ``excluded`` columns: the statistics are those of the
    included participants' real trials, and the report lists who was left out and why."""
    import pandas as pd

    base = [
        ("p", "x", "A", "B", "left", "trial", ""),
        ("p", "x", "B", "A", "right", "trial", ""),
        ("q", "x", "A", "B", "left", "trial", ""),
    ]
    noise = [
        ("p", "x", "A", "A", "left", "catch", ""),
        ("r", "x", "A", "B", "right", "trial", "did not finish"),
        ("s", "x", "B", "A", "left", "trial", "failed a catch trial (0 of 1 passed)"),
    ]
    columns = ["participant", "clip", "left", "right", "choice", "kind", "excluded"]
    clean = analyze(pd.DataFrame(base, columns=columns), bootstrap=0)
    mixed = analyze(pd.DataFrame(base + noise, columns=columns), bootstrap=0)
    assert mixed["pooled"]["ballots"] == clean["pooled"]["ballots"] == {"A": 3, "B": 0}
    assert mixed["input"]["participants"] == 2 and mixed["input"]["catch_votes"] == 1
    assert mixed["input"]["left_out"] == {
        "r": "did not finish",
        "s": "failed a catch trial (0 of 1 passed)",
    }
    tables = [b for b in build_document(mixed) if isinstance(b, Table)]
    assert tables[0].rows == [
        ["r", "did not finish"],
        ["s", "failed a catch trial (0 of 1 passed)"],
    ]


def test_the_appropriateness_test_has_its_section_when_the_study_had_it():
    import pandas as pd

    rows = [
        ("p", "x", "A", "B", "left", ""),
        ("p", "x", "B", "A", "right", ""),
        ("p", "x", "A", "A", "left", "right"),
        ("q", "x", "A", "A", "right", "left"),
        ("q", "x", "A", "A", "undecided", "left"),
        ("q", "x", "B", "A", "left", ""),
    ]
    frame = pd.DataFrame(
        rows, columns=["participant", "clip", "left", "right", "choice", "mismatched"]
    )
    blocks = build_document(analyze(frame, bootstrap=0))
    headings = [b.text for b in blocks if isinstance(b, Heading)]
    assert "Appropriateness" in headings
    table = next(
        b for b in blocks if isinstance(b, Table) and b.caption.startswith("Appropriateness")
    )
    assert table.rows == [["A", "2", "0", "1", "1.00", ".500"]]  # 2 of 2 decided: p = 1/2
    plain = pd.DataFrame(
        rows[:2], columns=["participant", "clip", "left", "right", "choice", "mismatched"]
    )
    assert "Appropriateness" not in [
        b.text for b in build_document(analyze(plain, bootstrap=0)) if isinstance(b, Heading)
    ]


def test_what_participants_saw_is_reported_when_the_votes_have_a_media_log():
    import pandas as pd

    cols = [
        "participant",
        "clip",
        "left",
        "right",
        "choice",
        "played_to_end",
        "stall_ms",
        "focus_lost",
    ]
    rows = [
        ("p", "x", "A", "B", "left", True, 0, 0),
        ("p", "x", "A", "A", "left", False, 900, 1),
        ("q", "x", "B", "A", "right", True, 0, 2),
        ("q", "x", "B", "B", "undecided", True, 0, 0),
    ]
    blocks = build_document(analyze(pd.DataFrame(rows, columns=cols), bootstrap=0))
    table = next(b for b in blocks if isinstance(b, Table) and b.caption.startswith("Table 11"))
    assert table.rows == [["p", "1.00", "0.50", "900", "1"], ["q", "-", "0.00", "0", "2"]]
    plain = pd.DataFrame([rows[0][:5], rows[2][:5]], columns=cols[:5])  # no log, no identical
    assert not any(
        isinstance(b, Table) and b.caption.startswith("Table 11")
        for b in build_document(analyze(plain, bootstrap=0))
    )


def test_a_pair_judged_in_both_orders_is_judged_twice():
    """One participant judges A|B and B|A once each: the pair has 2 judgements (too few for
    the agreement test, whose statistics stay "-"), not 0."""
    import pandas as pd

    frame = pd.DataFrame(
        [("p", "x", "A", "B", "left"), ("p", "x", "B", "A", "right")],
        columns=["participant", "clip", "left", "right", "choice"],
    )
    blocks = build_document(analyze(frame, bootstrap=0))
    table = next(b for b in blocks if isinstance(b, Table) and b.caption.startswith("Table 4"))
    assert [row[:3] for row in table.rows] == [["x", "2", "-"], ["pooled", "2", "-"]]
    assert "judged fewer than 3 times" in table.note
    text = " ".join(b.text for b in blocks if isinstance(b, Paragraph))
    assert "(2 judgements per pair from 1 participant" in text
    assert "0 judgements per pair" not in text
