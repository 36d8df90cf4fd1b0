from app.analysis import analyze
from app.analysis.document import Heading, Plot, Table, build_document, fmt, fmt_p
from app.analysis.simulate import simulate_votes


def test_number_formats():
    assert fmt_p(0.0004) == "< .001" and fmt_p(0.0283) == ".028" and fmt_p(1.0) == "1"
    assert fmt_p(None) == "-" and fmt(None) == "-" and fmt(0.12345, 3) == "0.123"
    assert fmt(12) == "12"


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

    rows = st.lists(st.tuples(st.sampled_from(["p", "q", "r"]), st.sampled_from(["s2", "s7"]),
                              st.sampled_from("ABC"), st.sampled_from("ABC"),
                              st.sampled_from(["left", "right", "undecided"])),
                    min_size=1, max_size=25)

    @settings(max_examples=15, deadline=None)
    @given(rows, st.sampled_from(["exclude", "split"]))
    def check(votes, undecided):
        frame = pd.DataFrame(votes, columns=["participant", "clip", "left", "right", "choice"])
        blocks = build_document(analyze(frame, undecided=undecided, bootstrap=10))
        for block in blocks:
            if isinstance(block, Plot):
                block.figure.canvas.draw()

    check()
