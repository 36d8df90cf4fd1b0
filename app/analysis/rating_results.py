"""The ratings table (the ``rating`` design's answers) and its analysis and report.

One row per rating: a participant's score of one condition's single-face clip (ITU-T P.910
ACR: 5 Excellent ... 1 Bad; or a 0-100 slider; in the ``parallel`` design every condition of
a clip on its own slider, the hidden reference marked ``reference = true``). The web app
writes it as ``ratings.csv`` (:func:`write_ratings_csv`); ``facepair analyze ratings.csv``
reads it back
(:func:`read_ratings`) and analyses it (:func:`analyze_ratings`): the attention checks (rows
of ``kind = catch``) and the participants the export marks ``excluded`` are left out, with
the reason printed, in the ``parallel`` design also those the post-screening of ITU-R
BS.1534-3 catches (:func:`reference_screening`), and the rest go to the linear mixed model of
:func:`app.analysis.ratings.mixed_mos` (MOS with confidence intervals, pairwise contrasts with
Holm). The report's content is :mod:`app.analysis.report.rating_document`.

>>> [c for c, _ in RATING_COLUMNS if c in REQUIRED]
['participant', 'clip', 'condition', 'score']
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from pathlib import Path
from typing import IO, Any

import pandas as pd

from app.analysis.ratings import mixed_mos
from app.analysis.vote_frame import system_allocator
from app.analysis.vote_values import FLAGS
from app.errors import InputError
from app.trials.rating import SCALE_RANGE, catch_ceiling

#: The columns of ``ratings.csv`` and their meaning, in the order they are written.
RATING_COLUMNS: tuple[tuple[str, str], ...] = (
    ("participant", "participant identifier (a pseudonym from the web app)"),
    ("clip", "clip (audio segment) the face was rendered for"),
    ("condition", "the condition rated"),
    ("item", "parallel design: the item's place on the page (1, 2, ...); empty otherwise"),
    ("reference", "parallel design: true where the row rates the hidden reference"),
    ("score", "the rating: 1 (Bad) to 5 (Excellent) on ACR, 0-100 on the slider"),
    ("scale", "acr5 or slider"),
    ("trial", "0-based place of the trial in the participant's schedule"),
    ("kind", "trial, or catch (an attention check: rate it Bad)"),
    ("response_ms", "milliseconds from the first play to the rating"),
    ("plays", "plays of the clip before rating"),
    ("presented_at", "browser time the clip was shown (ISO 8601, UTC)"),
    ("rated_at", "server time the rating was stored (ISO 8601, UTC)"),
    ("watched_ms", "milliseconds of the clip seen playing"),
    ("played_to_end", "whether a play reached the end"),
    ("stalls", "times playback ran dry"),
    ("stall_ms", "milliseconds spent stalled"),
    ("focus_lost", "times the window lost focus during the trial"),
    ("status", "the participant's status (started, finished, dropped, ...)"),
    ("excluded", "why the analysis leaves the participant out; empty to include"),
    (
        "screened",
        "parallel design: why the hidden-reference post-screening leaves the participant "
        "out (ITU-R BS.1534-3 sec. 4.1.2); empty otherwise. For people: the analysis "
        "decides it again from the scores",
    ),
    ("prolific_id", "pseudonymised Prolific ID"),
    ("study", "study title"),
)
REQUIRED = ("participant", "clip", "condition", "score")
#: The columns :func:`read_ratings` keeps from a file (the others are for people and tools).
ANALYSED = (*REQUIRED, "kind", "excluded", "reference", "scale")
KINDS = ("trial", "catch")
READ_ROWS = 8192  # rows :func:`read_ratings` parses at a time
#: How :func:`analyze_ratings`' error begins when no rating is left to analyse (the web
#: report then writes its page saying so: ``app.web.study.exports``).
NO_RATINGS = "no ratings to analyse"


def is_ratings_file(path: str | Path) -> bool:
    """Whether the CSV at ``path`` is a ratings table: no ``choice`` column (a vote's), and a
    ``score`` or a ``condition`` column (a ratings table missing its scores is still one, and
    its error names the ratings' columns, not the votes')."""
    try:
        with open(path, encoding="utf-8-sig", newline="") as source:
            header = next(csv.reader(source), [])
    except (OSError, UnicodeDecodeError):
        return False
    names = {h.strip() for h in header}
    return "choice" not in names and bool(names & {"score", "condition"})


def _refuse_first(
    frame: pd.DataFrame, bad: pd.Series, column: str, expected: str, path: Any
) -> None:
    """Raise the one-line error for the first row ``bad`` marks (line 1 is the header)."""
    if bad.any():
        row = int(bad.idxmax())
        raise InputError(
            f"{expected}, got {frame.loc[row, column]!r}", path=path, line=row + 2, field=column
        )


@system_allocator()
def read_ratings(source: str | Path | pd.DataFrame) -> pd.DataFrame:
    """Read and check a ratings table; every problem is one :class:`~app.errors.InputError`
    naming the file, line (the header is line 1) and column.

    >>> read_ratings(pd.DataFrame({"participant": ["p1"], "clip": ["s2"],
    ...     "condition": ["a"], "score": ["4"]})).loc[0, "score"].item()
    4
    """
    path = None if isinstance(source, pd.DataFrame) else Path(source)
    if path is None:
        frame = source.copy()  # type: ignore[union-attr]
    else:
        try:
            chunks = pd.read_csv(
                path,
                dtype=str,
                keep_default_na=False,
                encoding="utf-8-sig",
                # read a block of rows at a time: the parser holds each block's text as one
                # Python string per value until the block is stored compactly, which for a
                # whole file of 40,000 ratings was six times its size
                chunksize=READ_ROWS,
            )
            with chunks:
                # every column parsed, so a row with more fields than the header is refused
                # (a parser told to keep some columns drops the extra fields without a word),
                # and only the columns the analysis reads kept: the times and playback
                # columns of a study of thousands were two thirds of the memory
                frame = pd.concat(
                    [
                        block[[c for c in block.columns if str(c).strip() in ANALYSED]]
                        for block in chunks
                    ],
                    ignore_index=True,
                )
        except FileNotFoundError:
            raise InputError("no such file", path=path) from None
        except (OSError, UnicodeDecodeError, pd.errors.ParserError) as exc:
            raise InputError(f"cannot read the ratings: {exc}".splitlines()[0], path=path) from None
    frame.columns = [str(c).strip() for c in frame.columns]
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise InputError(f"missing column(s): {', '.join(missing)}", path=path, field="header")
    frame = frame.astype({c: str for c in REQUIRED}).reset_index(drop=True)
    for column in ("participant", "clip", "condition"):
        blank = frame[column].str.strip() == ""
        if blank.any():
            raise InputError("empty", path=path, line=int(blank.idxmax()) + 2, field=column)
    scores = pd.to_numeric(frame["score"].str.strip(), errors="coerce")
    bad = ~(scores.notna() & (scores % 1 == 0) & scores.between(0, 100))
    _refuse_first(frame, bad, "score", "expected a whole number from 0 to 100", path)
    frame["score"] = scores.astype(int)
    if "kind" not in frame.columns:
        frame["kind"] = "trial"
    frame["kind"] = frame["kind"].astype(str).str.strip().replace("", "trial")
    odd = ~frame["kind"].isin(KINDS)
    _refuse_first(frame, odd, "kind", "expected trial or catch", path)
    if "excluded" not in frame.columns:
        frame["excluded"] = ""
    frame["excluded"] = frame["excluded"].astype(str).str.strip()
    flags = {**FLAGS, "": False}  # the votes' spellings; an empty reference field is false
    if "reference" not in frame.columns:
        frame["reference"] = ""
    spelt = frame["reference"].astype(str).str.strip().str.lower()
    odd = ~spelt.isin(list(flags))
    _refuse_first(frame, odd, "reference", "expected true or false", path)
    frame["reference"] = spelt.map(flags).astype(bool)
    return frame


#: BS.1534-3 sec. 4.1.2: an assessor is left out who rates the hidden reference below this...
REFERENCE_BELOW = 90
#: ... on more than this share of the test items.
REFERENCE_SHARE = 0.15


def reference_screening(
    frame: pd.DataFrame, *, below: float = REFERENCE_BELOW, share: float = REFERENCE_SHARE
) -> dict[str, str]:
    """Post-screening of a ``parallel`` test (ITU-R BS.1534-3, sec. 4.1.2, adapted to video):
    the participants who rate the hidden reference below ``below`` on more than ``share`` of
    their trials, each with the reason; the thresholds are the Recommendation's (90, 15 %).

    >>> rows = pd.DataFrame({"participant": ["a", "a", "b", "b"], "score": [95, 70, 100, 92],
    ...                      "reference": True, "kind": "trial"})
    >>> list(reference_screening(rows)), reference_screening(rows)["a"][:45]
    (['a'], 'rated the hidden reference below 90 on 1 of 2')
    """
    hidden = frame[frame["reference"] & (frame["kind"] == "trial")]
    out: dict[str, str] = {}
    for person, rows in hidden.groupby("participant", sort=True):
        low = int((rows["score"] < below).sum())
        if low > share * len(rows):
            out[str(person)] = (
                f"rated the hidden reference below {below:g} on {low} of {len(rows)} clips "
                f"(more than {100 * share:g} %; ITU-R BS.1534-3 sec. 4.1.2)"
            )
    return out


def screening_rule(below: float = REFERENCE_BELOW, share: float = REFERENCE_SHARE) -> str:
    """The post-screening in words, as the report and the web pages give it.

    >>> screening_rule()[:40]
    'Post-screening (ITU-R BS.1534-3, sec. 4.'
    """
    return (
        "Post-screening (ITU-R BS.1534-3, sec. 4.1.2, adapted to video): a participant who "
        f"rates the hidden reference below {below:g} on more than {100 * share:g} % of the "
        "clips is left out"
    )


def post_screening(
    frame: pd.DataFrame, *, below: float = REFERENCE_BELOW, share: float = REFERENCE_SHARE
) -> dict[str, str]:
    """The participants :func:`analyze_ratings` leaves out by :func:`reference_screening`,
    each with the reason: those not ``excluded`` otherwise, in a table that rates a hidden
    reference (a ``parallel`` test); none in any other table."""
    if not frame["reference"].any():
        return {}
    return reference_screening(frame[frame["excluded"] == ""], below=below, share=share)


def _nothing_to_analyse(
    frame: pd.DataFrame, screened: dict[str, str], below: float, share: float
) -> str:
    """:data:`NO_RATINGS`, and where the post-screening left participants out, how many of
    those it screened and by which rule (one line)."""
    if not screened:
        return NO_RATINGS
    screened_from = int(frame.loc[frame["excluded"] == "", "participant"].nunique())
    if screened_from == 1:
        who = "the only participant"
    elif len(screened) == screened_from:
        who = f"all {screened_from} participants"
    else:
        who = f"{len(screened)} of {screened_from} participants"
    marked = int(frame.loc[frame["excluded"] != "", "participant"].nunique())
    return (
        f"{NO_RATINGS}: the hidden-reference post-screening (ITU-R BS.1534-3 sec. 4.1.2) "
        f"left out {who}, who rated the hidden reference below {below:g} on more than "
        f"{100 * share:g} % of their clips" + (f"; {marked} more marked excluded" if marked else "")
    )


def write_ratings_csv(rows: Sequence[dict[str, Any]], out: IO[str] | str | Path) -> None:
    """Write ratings (dicts keyed by :data:`RATING_COLUMNS`) as CSV; a key outside the
    format is refused, so what is written is what :func:`read_ratings` reads."""
    names = [c for c, _ in RATING_COLUMNS]
    for row in rows:
        unknown = set(row) - set(names)
        if unknown:
            raise ValueError(f"not columns of the ratings table: {', '.join(sorted(unknown))}")
    target = open(out, "w", encoding="utf-8", newline="") if isinstance(out, str | Path) else out
    try:
        writer = csv.DictWriter(target, fieldnames=names, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if v is None else v for k, v in row.items()})
    finally:
        if isinstance(out, str | Path):
            target.close()


@system_allocator()
def analyze_ratings(
    frame: pd.DataFrame,
    *,
    conditions: Sequence[str] | None = None,
    confidence: float = 0.95,
    source: str = "",
    reference_below: float = REFERENCE_BELOW,
    reference_share: float = REFERENCE_SHARE,
) -> dict[str, Any]:
    """MOS per condition from a :func:`read_ratings` table: the mixed model of
    :func:`app.analysis.ratings.mixed_mos` on the real trials of the included participants
    (a table with hidden-reference rows is post-screened first: :func:`reference_screening`
    with ``reference_below`` and ``reference_share``).

    Returns ``{"kind": "rating", "conditions", "mos" (mixed_mos's result), "input":
    {"source", "ratings", "participants", "clips", "left_out": {participant: why},
    "catch": {"trials", "failed"}}, "scale"}``.
    """
    left_out = {
        str(p): str(why)
        for p, why in frame.loc[frame["excluded"] != "", ["participant", "excluded"]]
        .drop_duplicates("participant")
        .itertuples(index=False)
    }
    screened = post_screening(frame, below=reference_below, share=reference_share)
    left_out |= screened
    included = frame[(frame["excluded"] == "") & ~frame["participant"].isin(list(screened))]
    checks = included[included["kind"] == "catch"]
    scale = _scale(frame)
    kept = included[included["kind"] == "trial"].rename(columns={"score": "rating"})
    if kept.empty:
        raise InputError(
            _nothing_to_analyse(frame, screened, reference_below, reference_share),
            field="ratings",
        )
    mos = mixed_mos(kept, conditions, confidence)
    if kept["participant"].nunique() < 2:
        mos = _without_intervals(mos)
    return {
        "kind": "rating",
        "conditions": mos["conditions"],
        "scale": scale,
        "mos": mos,
        "screening": None
        if not frame["reference"].any()
        else {"below": reference_below, "share": reference_share, "excluded": screened},
        "input": {
            "source": source,
            "ratings": int(len(kept)),
            "participants": int(kept["participant"].nunique()),
            "clips": sorted(kept["clip"].unique().tolist()),
            "left_out": left_out,
            "catch": {
                "trials": int(len(checks)),
                "failed": int((checks["score"] > catch_ceiling(scale)).sum()),
            },
        },
    }


#: Why a one-participant analysis has no interval (:func:`_without_intervals`).
ONE_PARTICIPANT = "one participant: no interval (the participants are the sampled unit)"


def _without_intervals(mos: dict[str, Any]) -> dict[str, Any]:
    """``mos`` (a :func:`~app.analysis.ratings.mixed_mos` result) of one participant's ratings
    as far as one participant tells: each condition's estimate, and null for every interval,
    test and variance component. With the participant random effect absent from the model,
    the Wald intervals would be conditional on that one person (zero-width where they gave a
    condition one score throughout), where the model's intervals are over participants.

    >>> one = {"ci": {"a": [2.0, 2.0]}, "contrasts": [], "note": None}
    >>> _without_intervals(one)["ci"], _without_intervals(one)["note"][:15]
    ({'a': [None, None]}, 'one participant')
    """
    return {
        **mos,
        "ci": {c: [None, None] for c in mos["ci"]},
        "contrasts": [
            {**row, "ci": [None, None], "z": None, "p": None, "p_holm": None}
            for row in mos["contrasts"]
        ],
        "sd_participant": None,
        "sd_clip": None,
        "sd_residual": None,
        "note": ONE_PARTICIPANT,
    }


def _scale(frame: pd.DataFrame) -> str:
    """The table's scale: its ``scale`` column, else ACR when every score is 1 to 5."""
    if "scale" in frame.columns:
        named = {s for s in frame["scale"].astype(str).str.strip() if s}
        if len(named) == 1 and named <= set(SCALE_RANGE):
            return named.pop()
    return "acr5" if frame["score"].between(1, 5).all() else "slider"


def ratings_text(rows: Sequence[dict[str, Any]]) -> str:
    """``rows`` as ratings CSV text (:func:`write_ratings_csv`)."""
    buffer = io.StringIO()
    write_ratings_csv(rows, buffer)
    return buffer.getvalue()
