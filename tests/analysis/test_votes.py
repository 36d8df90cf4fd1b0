import io

import pandas as pd
import pytest

from app.analysis.votes import (
    CHOICES,
    OPTIONAL_COLUMNS,
    REQUIRED_COLUMNS,
    VOTE_COLUMNS,
    read_votes,
    write_votes_csv,
)
from app.errors import InputError

GOOD = """participant,clip,left,right,choice
p1,s2,random,speech_driven,left
p1,s2,speech_driven,random,Undecided
p2,s2,random,random,right
"""


def _write(tmp_path, text, name="votes.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_schema_is_the_interface():
    assert REQUIRED_COLUMNS == ("participant", "clip", "left", "right", "choice")
    assert OPTIONAL_COLUMNS == (
        "study",
        "trial",
        "response_ms",
        "plays",
        "presented_at",
        "voted_at",
        "strength",
        "reasons",
        "mismatched",
        "watched_ms",
        "played_to_end",
        "stalls",
        "stall_ms",
        "focus_lost",
        "kind",
        "status",
        "excluded",
        "prolific_id",
    )
    assert VOTE_COLUMNS == REQUIRED_COLUMNS + OPTIONAL_COLUMNS
    assert CHOICES == ("left", "right", "undecided")


def test_reads_and_normalises(tmp_path):
    t = read_votes(_write(tmp_path, GOOD))
    assert len(t) == 3 and t.skipped == 0 and t.problems == []
    assert t.frame["choice"].tolist() == ["left", "undecided", "right"]
    assert list(t.frame.columns) == list(VOTE_COLUMNS)
    assert t.frame["trial"].isna().all()


@pytest.mark.parametrize(
    ("row", "where", "what"),
    [
        ("p1,s2,a,b,maybe", ":3: choice:", "unknown choice 'maybe'"),
        (",s2,a,b,left", ":3: participant:", "missing value"),
        ("p1,s2,,b,left", ":3: left:", "missing value"),
        ("p1,s2,a,b", ":3:", "expected 5 fields like the header, got 4"),
        ("p1,s2,a,b,left,extra", ":3:", "expected 5 fields like the header, got 6"),
    ],
)
def test_bad_row_is_one_line_with_its_number(tmp_path, row, where, what):
    path = _write(tmp_path, "participant,clip,left,right,choice\np0,s2,a,b,left\n" + row + "\n")
    with pytest.raises(InputError) as err:
        read_votes(path)
    message = str(err.value)
    assert "\n" not in message and str(path) + where in message and what in message
    assert err.value.line == 3


@pytest.mark.parametrize(
    ("header", "what"),
    [
        ("participant,clip,left,right", "missing choice"),
        ("participant,clip,left,right,choice,clip", "repeated clip"),
        ("Participant,clip,left,right,choice", "missing participant"),
    ],
)
def test_header_that_does_not_match(tmp_path, header, what):
    path = _write(tmp_path, header + "\np,c,a,b,left\n")
    with pytest.raises(InputError, match=what) as err:
        read_votes(path, skip_bad_rows=True)  # a header cannot be skipped
    assert err.value.line == 1


def test_skip_bad_rows_counts_every_one(tmp_path):
    text = GOOD + "p3,s2,a,b,maybe\n,s2,a,b,left\n\np4,s2,a,b,left,1\n"
    with pytest.raises(InputError, match=r"and 2 more bad rows"):
        read_votes(_write(tmp_path, text))
    t = read_votes(_write(tmp_path, text), skip_bad_rows=True)
    assert len(t) == 3 and t.skipped == 3
    assert [p.split(":")[1] for p in t.problems] == ["5", "6", "8"]  # blank line 7 is no vote


def test_unknown_condition_against_a_given_list(tmp_path):
    with pytest.raises(InputError, match="unknown condition 'speech_driven'") as err:
        read_votes(_write(tmp_path, GOOD), conditions=["random"])
    assert err.value.field == "right" and err.value.line == 2


def test_empty_and_missing_files(tmp_path):
    with pytest.raises(InputError, match="empty file"):
        read_votes(_write(tmp_path, ""))
    with pytest.raises(InputError, match="cannot read"):
        read_votes(tmp_path / "nope.csv")
    assert len(read_votes(_write(tmp_path, "participant,clip,left,right,choice\n"))) == 0


def test_write_then_read_round_trip(tmp_path):
    rows = [
        {
            "participant": "p1",
            "clip": "s2",
            "left": "a",
            "right": "b",
            "choice": "left",
            "trial": 1,
            "response_ms": 1234.5,
            "plays": 2,
            "presented_at": "2026-03-02T09:00:00Z",
            "voted_at": "2026-03-02T09:00:01.2345Z",
        },
        {"participant": "p,2", "clip": "s7", "left": "b", "right": "a", "choice": "undecided"},
    ]
    path = tmp_path / "out.csv"
    assert write_votes_csv(rows, path) == 2
    back = read_votes(path)
    assert back.frame["participant"].tolist() == ["p1", "p,2"]
    assert back.frame.loc[0, "response_ms"] == 1234.5 and back.frame.loc[0, "plays"] == 2
    assert back.frame.loc[0, "voted_at"] == pd.Timestamp("2026-03-02T09:00:01.2345Z")
    buffer = io.StringIO()
    write_votes_csv(back, buffer)
    assert buffer.getvalue() == path.read_text()


def test_extra_columns_are_ignored_on_reading(tmp_path):
    path = _write(
        tmp_path, "participant,clip,left,right,choice,watched_ms,colour\np,c,a,b,left,3000,red\n"
    )
    table = read_votes(path)
    assert len(table.frame) == 1 and "colour" not in table.frame.columns


def test_write_refuses_invalid_votes(tmp_path):
    with pytest.raises(InputError, match="unknown choice"):
        write_votes_csv(
            [{"participant": "p", "clip": "c", "left": "a", "right": "b", "choice": "both"}],
            tmp_path / "x.csv",
        )
    with pytest.raises(InputError, match="unknown 'colour'"):
        write_votes_csv(
            [
                {
                    "participant": "p",
                    "clip": "c",
                    "left": "a",
                    "right": "b",
                    "choice": "left",
                    "colour": "red",
                }
            ],
            tmp_path / "x.csv",
        )


def test_frame_input_with_missing_values():
    frame = pd.DataFrame(
        {
            "participant": ["p", None],
            "clip": ["c", "c"],
            "left": ["a", "a"],
            "right": ["b", "b"],
            "choice": ["left", "right"],
        }
    )
    t = read_votes(frame, skip_bad_rows=True)
    assert len(t) == 1 and t.skipped == 1 and "participant: missing value" in t.problems[0]


def test_plain_and_quoted_files_read_alike(tmp_path):
    plain = read_votes(_write(tmp_path, GOOD, "plain.csv")).frame
    quoted = GOOD.replace("p1,s2,random", '"p1",s2,random')
    exact = read_votes(_write(tmp_path, quoted, "quoted.csv")).frame
    pd.testing.assert_frame_equal(plain, exact)


def test_times_are_written_in_utc_with_seconds(tmp_path):
    import datetime as dt

    rows = [
        {
            "participant": "p",
            "clip": "c",
            "left": "a",
            "right": "b",
            "choice": "left",
            "presented_at": dt.datetime(
                2026, 3, 2, 10, 0, tzinfo=dt.timezone(dt.timedelta(hours=1))
            ),
            "voted_at": "2026-03-02T09:00:10.120Z",
        }
    ]
    buffer = io.StringIO()
    write_votes_csv(rows, buffer)
    assert ",2026-03-02T09:00:00Z,2026-03-02T09:00:10.12Z," in buffer.getvalue().splitlines()[1]


def test_media_log_columns_read_write_and_refuse_nonsense(tmp_path):
    text = (
        "participant,clip,left,right,choice,strength,watched_ms,played_to_end,stalls,"
        "stall_ms,focus_lost\n"
        "p1,s2,a,b,left,2,4000,TRUE,1,850,0\n"
        "p1,s2,b,a,undecided,0,1200,no,0,0,2\n"
        "p2,s2,a,b,right,,,,,,\n"
    )
    t = read_votes(_write(tmp_path, text))
    assert t.frame["played_to_end"].tolist()[:2] == [True, False]
    assert t.frame["played_to_end"].isna().tolist() == [False, False, True]
    assert t.frame["stall_ms"].tolist()[:2] == [850, 0]
    out = tmp_path / "out.csv"
    write_votes_csv(t, out)
    again = read_votes(out)
    assert again.frame["played_to_end"].isna().tolist() == [False, False, True]
    assert "true" in out.read_text() and "false" in out.read_text()
    bad = text.replace("TRUE", "maybe")
    with pytest.raises(InputError, match="played_to_end.*expected true or false"):
        read_votes(_write(tmp_path, bad, "bad.csv"))


# --- the block reader: plain files in blocks, every other file through the csv module ---

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from app.analysis import csv_blocks  # noqa: E402

_HEADER = "participant,clip,left,right,choice,trial,response_ms,voted_at,played_to_end,extra"
_CELLS = {
    "participant": st.sampled_from(["p1", " p1", "p2 ", "", "P 3", "é"]),
    "clip": st.sampled_from(["s1", "s2", ""]),
    "left": st.sampled_from(["a", "b", " a"]),
    "right": st.sampled_from(["a", "b", "c"]),
    "choice": st.sampled_from(["left", "Right", " undecided ", "maybe", ""]),
    "trial": st.sampled_from(["1", "2.0", "1.5", "-1", "x", "", "inf", "1e3", "1e300"]),
    "response_ms": st.sampled_from(["100", "0.5", "-3", "nan", "", " 7 ", "fast"]),
    "voted_at": st.sampled_from(
        ["2026-03-02T09:00:00Z", "2026-03-02T10:00:00+01:00", "", "yesterday", "2026-13-40"]
    ),
    "played_to_end": st.sampled_from(["true", "NO", "1", "", "maybe"]),
    "extra": st.sampled_from(["", "x", " "]),
}
_ROW = st.tuples(*_CELLS.values()).map(",".join)
_LINE = st.one_of(_ROW, _ROW, _ROW, st.just(""), st.just(",,,,,,,,,"))


def _outcome(path, **kw):
    try:
        t = read_votes(path, **kw)
    except InputError as err:
        return str(err).replace(str(path), "FILE")
    return t.frame, t.skipped, [p.replace(str(path), "FILE") for p in t.problems]


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    lines=st.lists(_LINE, max_size=12),
    crlf=st.booleans(),
    block=st.sampled_from([16, 64, 1 << 20]),
    skip=st.booleans(),
)
def test_block_reader_and_csv_module_agree(tmp_path, monkeypatch, lines, crlf, block, skip):
    """A plain file read in blocks gives what the csv module gives for the same rows (there
    forced by quoting the header): same frame, same skipped rows, same messages and lines."""
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", block)
    end = "\r\n" if crlf else "\n"
    body = end.join(lines) + (end if lines else "")
    plain = tmp_path / "plain.csv"
    quoted = tmp_path / "quoted.csv"
    plain.write_bytes((_HEADER + end + body).encode())
    quoted.write_bytes(('"participant"' + _HEADER[11:] + end + body).encode())
    fast, exact = _outcome(plain, skip_bad_rows=skip), _outcome(quoted, skip_bad_rows=skip)
    if isinstance(fast, str) or isinstance(exact, str):
        assert fast == exact
        return
    pd.testing.assert_frame_equal(fast[0], exact[0])
    assert fast[1:] == exact[1:]


def test_a_plain_file_never_reaches_the_csv_module(tmp_path, monkeypatch):
    def refuse(path):
        raise AssertionError("the exact reader was used")

    monkeypatch.setattr("app.analysis.votes.exact_rows", refuse)
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", 40)
    rows = "".join(f"p{k % 7},s{k % 3},a,b,{('left', 'right')[k % 2]}\n" for k in range(50))
    t = read_votes(_write(tmp_path, "participant,clip,left,right,choice\n" + rows))
    assert len(t) == 50 and t.frame["participant"].cat.categories.tolist() == [
        f"p{k}" for k in range(7)
    ]
    assert t.frame["choice"].tolist()[:3] == ["left", "right", "left"]


def test_bad_row_in_a_late_block_keeps_its_line_number(tmp_path, monkeypatch):
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", 32)
    rows = ["p,s,a,b,left"] * 40
    rows[36] = "p,s,a,b,sideways"
    rows[10] = ""  # a blank line is no vote but still a line
    path = _write(tmp_path, "participant,clip,left,right,choice\n" + "\n".join(rows) + "\n")
    with pytest.raises(InputError, match="unknown choice 'sideways'") as err:
        read_votes(path)
    assert err.value.line == 38 and err.value.field == "choice"
    t = read_votes(path, skip_bad_rows=True)
    assert len(t) == 38 and t.skipped == 1 and t.problems[0].startswith(f"{path}:38: choice:")


def test_a_quote_after_the_first_block_restarts_with_the_exact_reader(tmp_path, monkeypatch):
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", 32)
    rows = ["p,s,a,b,left"] * 30 + ['"p,2",s,a,b,right', "p,s,a,b,maybe"]
    path = _write(tmp_path, "participant,clip,left,right,choice\n" + "\n".join(rows) + "\n")
    with pytest.raises(InputError, match="unknown choice 'maybe'") as err:
        read_votes(path)
    assert err.value.line == 33
    t = read_votes(path, skip_bad_rows=True)
    assert len(t) == 31 and set(t.frame["participant"]) == {"p", "p,2"} and t.skipped == 1


def test_text_columns_are_categoricals_of_the_values_kept(tmp_path):
    t = read_votes(_write(tmp_path, GOOD + ",s2,a,b,left\n"), skip_bad_rows=True)
    assert isinstance(t.frame["participant"].dtype, pd.CategoricalDtype)
    assert t.frame["participant"].cat.categories.tolist() == ["p1", "p2"]
    assert t.frame["choice"].cat.categories.tolist() == ["left", "right", "undecided"]


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    body=st.lists(st.sampled_from(list('ab1-.:TZ ,"\r\n\x00\ufeffé\xa0') + ["left"])).map("".join),
    raw=st.binary(max_size=40),
    block=st.sampled_from([8, 1 << 20]),
)
def test_any_bytes_read_or_fail_with_one_line(tmp_path, monkeypatch, body, raw, block):
    monkeypatch.setattr(csv_blocks, "BLOCK_BYTES", block)
    for data in (("participant,clip,left,right,choice,trial\n" + body).encode(), raw):
        path = tmp_path / "any.csv"
        path.write_bytes(data)
        for skip in (False, True):
            try:
                read_votes(path, skip_bad_rows=skip)
            except InputError as err:
                assert "\n" not in str(err)
