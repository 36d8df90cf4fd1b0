"""The report's content - headings, generated text, tables, plots - independent of its format.

:func:`build_document` turns an :func:`app.analysis.analyze` result into a list of blocks
(:mod:`app.analysis.report.blocks`) that :mod:`app.analysis.report.writer` writes as HTML and as
PDF, so both say the same.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from app.analysis.report import figures
from app.analysis.report.answer_document import answer_detail_blocks
from app.analysis.report.blocks import (
    MAX_LISTED_PARTICIPANTS,
    Block,
    Heading,
    Paragraph,
    Plot,
    Table,
    fmt,
    fmt_p,
    judgements_per_pair,
    pair_judgements,
)
from app.analysis.report.inference_document import METHOD_TEXT as MODEL_TEXT
from app.analysis.report.inference_document import inference_blocks
from app.analysis.report.rating_document import rating_blocks
from app.analysis.report.results_text import results_paragraphs
from app.analysis.report.study_document import study_blocks

METHOD_TEXT = (
    "Ballots are the collapsed ballots of the thesis (sec. 5.2): the times a condition was "
    "chosen, on either side; a vote on a same-condition pair counts for that condition.",
    "Agreement (Kendall & Babington Smith 1940; Le, Ma & Deng 2012, sec. 8.1.1): with a_ij the "
    "judgements preferring i to j, m judgements per pair and n conditions, "
    "Σ = Σ_(i≠j) C(a_ij, 2), u = 2Σ / (C(m,2) C(n,2)) − 1, "
    "χ² = 4/(m−2) · (Σ − ½ C(n,2) C(m,2) (m−3)/(m−2)), df = C(n,2) m(m−1)/(m−2)². Each "
    "presentation is one judgement; same-condition pairs are left out; when pairs were judged "
    "unequally often the sums run pair by pair with each pair's own m.",
    "Consistence (Kendall & Babington Smith 1940): with s_i a participant's wins, "
    "d = n(n−1)(2n−1)/12 − ½ Σ s_i² circular triads, ζ = 1 − d/d_max; the test gives "
    "P(d ≤ observed) under random choice, exact by enumeration for n ≤ 7 and by the χ² "
    "approximation otherwise. A pair without a majority preference is resolved both ways and "
    "d and P are averaged over the resolutions.",
    "Sign tests: exact two-sided binomial test of wins against losses (Le, Ma & Deng 2012, "
    "Fig. 9 counts). Paired t-tests: differences of per-participant ballots, reported as SPSS "
    "does. Holm (1979) step-down adjustment over the pairs of each table.",
    "Scale: Thurstone Case V by weighted least squares on σ·Φ⁻¹(P_ij), σ = 1.4826 so that "
    "1 JOD = 75 % preference; percentile intervals from {boot} bootstrap resamples of "
    "participants (seed {seed}).",
)


def _ballot_table(r: dict[str, Any]) -> Table:
    names = r["conditions"]
    rows = []
    for label, s in [*r["clips"].items(), ("pooled", r["pooled"])]:
        rows.append(
            [label, str(s["votes"])] + [str(s["ballots"][c]) for c in names] + [str(s["undecided"])]
        )
    return Table(
        "Table 1. Ballots: times each condition was chosen, whichever side it was on "
        "(same-condition pairs count for that condition), and undecided votes.",
        ["clip", "votes", *names, "undecided"],
        rows,
        numeric=[False] + [True] * (len(names) + 2),
    )


def _sign_table(section: dict[str, Any], caption: str, clip: str | None = None) -> Table:
    rows = [
        ([clip] if clip else [])
        + [
            f"{s['a']} vs {s['b']}",
            str(s["wins"]),
            str(s["undecided"]),
            str(s["losses"]),
            fmt_p(s["p"]),
            fmt_p(s["p_holm"]),
            fmt_p(s["p_split"]),
            fmt_p(s["p_undecided_as_losses"]),
        ]
        for s in section["sign_tests"]
    ]
    head = ["pair (a vs b)", "for a", "undecided", "for b", "p", "p Holm", "p split", "p und.=loss"]
    return Table(
        caption,
        (["clip"] if clip else []) + head,
        rows,
        note="Exact two-sided binomial sign test on decisive votes; 'p split' gives "
        "half of the undecided votes to each side, 'p und.=loss' counts them "
        "against a.",
        numeric=([False] if clip else []) + [False] + [True] * 7,
    )


def _t_table(section: dict[str, Any], caption: str) -> Table:
    rows = [
        [
            f"{t['a']} − {t['b']}",
            fmt(t["mean"], 3),
            fmt(t["sd"], 3),
            fmt(t["sem"], 3),
            fmt(t["ci_low"], 3),
            fmt(t["ci_high"], 3),
            fmt(t["t"], 3),
            fmt(t["df"], 0),
            fmt_p(t["p"]),
            fmt_p(t["p_holm"]),
        ]
        for t in section["paired_t"]
    ]
    return Table(
        caption,
        [
            "pair",
            "mean",
            "SD",
            "SEM",
            "95% CI lower",
            "95% CI upper",
            "t",
            "df",
            "p (2-tailed)",
            "p Holm",
        ],
        rows,
        numeric=[False] + [True] * 9,
    )


def _agreement_table(r: dict[str, Any]) -> Table:
    rule = r["options"]["undecided"]
    rows = []
    few = False  # a pair judged too few times for the test, in a clip or pooled
    for label, s in [*r["clips"].items(), ("pooled", r["pooled"])]:
        a = s["agreement"]
        few = few or any(pair_judgements(t, rule) < 3 for t in s["sign_tests"])
        rows.append(
            [
                label,
                judgements_per_pair(s, rule),
                fmt(a["u"], 3),
                fmt(a["chi2"]),
                fmt(a["df"]),
                fmt_p(a["p"]),
                fmt(a["chi2_corrected"]),
                fmt_p(a["p_corrected"]),
            ]
        )
    return Table(
        "Table 4. Coefficient of agreement u (Kendall & Babington Smith 1940) with its "
        f"chi-square test; undecided votes: {rule}.",
        ["clip", "judgements per pair", "u", "χ²", "df", "p", "χ² corr.", "p corr."],
        rows,
        note="Each presentation is one judgement (a pair shown in "
        "both side orders counts twice"
        + ("" if rule == "split" else "; undecided votes are not counted")
        + "); same-condition pairs are left out; 'corr.' "
        "subtracts 1 from Σ (continuity correction)."
        + (
            " A pair judged fewer than 3 times tells the test nothing and is left out of u "
            "('-' where no pair was judged 3 times)."
            if few
            else ""
        ),
        numeric=[False] + [True] * 7,
    )


def _scale_table(r: dict[str, Any]) -> Table:
    ci = int(round(100 * r["options"]["confidence"]))
    clips = list(r["clips"])
    rows = []
    for q, s in enumerate(r["pooled"]["scale"]):
        per_clip = [fmt(r["clips"][c]["scale"][q]["score"]) for c in clips]
        rows.append(
            [s["condition"], fmt(s["score"]), fmt(s["ci_low"]), fmt(s["ci_high"]), *per_clip]
        )
    return Table(
        f"Table 6. Thurstone Case V scale (JOD) with {ci} % bootstrap intervals over "
        "participants, pooled, and the scale of each clip.",
        ["condition", "pooled", f"{ci}% low", f"{ci}% high", *clips],
        rows,
        note=r["pooled"].get("scale_note") or "",
        numeric=[False] + [True] * (3 + len(clips)),
    )


def _participant_table(r: dict[str, Any]) -> Table:
    rows = []
    for pid, p in list(r["participants"].items())[:MAX_LISTED_PARTICIPANTS]:
        c = p["consistence"]
        rows.append(
            [
                pid,
                str(p["votes"]),
                str(p["undecided"]),
                fmt(c["d"]),
                fmt(c["zeta"]),
                fmt_p(c["p"]),
                c["method"],
            ]
        )
    more = len(r["participants"]) - len(rows)
    return Table(
        "Table 5. Coefficient of consistence ζ per participant (circular triads d "
        "of the preference tournament pooled over clips; P = P(d <= observed) under "
        "random choice).",
        ["participant", "votes", "undecided", "d", "ζ", "P", "test"],
        rows,
        note=(f"{more} more participants are in the JSON output." if more > 0 else "")
        + " A tied pair (no majority preference) is resolved both ways and d and P "
        "are averaged; with more than 10 tied pairs the test is not run ('incomplete').",
        numeric=[False] + [True] * 5 + [False],
    )


def _left_out_table(left_out: dict[str, str]) -> Table:
    rows = [[pid, why] for pid, why in sorted(left_out.items())]
    return Table(
        f"Table 0. Participants left out of every statistic ({len(rows)}).",
        ["Participant", "Reason"],
        rows,
        note="Catch trials are attention checks and are never part of a statistic.",
        numeric=[False, False],
    )


def _appropriateness_blocks(appropriate: dict[str, dict[str, Any]]) -> list[Block]:
    """The appropriateness test (``app.analysis.appropriateness``), when the study had it."""
    if not appropriate:
        return []
    rows = [
        [
            name,
            str(a["matched"]),
            str(a["mismatched"]),
            str(a["undecided"]),
            fmt(a["matched_share"]),
            fmt_p(a["p"]),
        ]
        for name, a in appropriate.items()
    ]
    return [
        Heading("Appropriateness"),
        Paragraph(
            "Appropriateness pairs show one condition twice under one clip's speech: "
            "one face moves with the motion made for this speech, the other with the "
            "motion made for another clip. A matched share above 1/2 says "
            "participants could tell which motion belongs to the speech; these votes "
            "are kept out of every other statistic."
        ),
        Table(
            "Appropriateness per condition: votes for the face moving with its own "
            "speech, for the mismatched face, undecided; the matched share of decided "
            "votes and its exact two-sided sign test against 1/2.",
            ["Condition", "Matched", "Mismatched", "Undecided", "Share", "p"],
            rows,
            numeric=[False, True, True, True, True, True],
        ),
    ]


def build_document(r: dict[str, Any]) -> list[Block]:
    """Every block of the report, in reading order (a rating study's:
    :func:`app.analysis.report.rating_document.rating_blocks`)."""
    if r.get("kind") == "rating":
        return (study_blocks(r["study"]) if r.get("study") else []) + rating_blocks(r)
    pooled = r["pooled"]
    doc: list[Block] = study_blocks(r["study"]) if r.get("study") else []
    doc.append(Heading("Results", 1))
    # the file's name only: a report shared from a server never shows the server's folders
    source = Path(r["input"]["source"]).name if r["input"]["source"] else "in-memory votes"
    doc.append(
        Paragraph(
            f"Source: {source}. Conditions: {', '.join(r['conditions'])}. "
            f"Undecided votes: {r['options']['undecided']}. Skipped bad rows: "
            f"{r['input']['skipped_rows']}."
        )
    )
    doc += [Paragraph(t) for t in results_paragraphs(r)]
    if r["input"].get("left_out"):
        doc.append(_left_out_table(r["input"]["left_out"]))
    doc.append(Heading("Ballots"))
    doc.append(
        Plot(
            "Figure 1. Ballots per condition pooled over clips (hatched: undecided), "
            "and each clip's share of votes.",
            figures.ballots_figure(r),
        )
    )
    doc.append(_ballot_table(r))
    doc.append(Heading("Pairwise preferences"))
    doc.append(
        Plot(
            "Figure 2. Votes on each pair of different conditions, pooled over clips: "
            "black for the first condition, grey undecided, white for the second "
            "(after Le, Ma & Deng 2012, Fig. 9); * Holm-adjusted sign test p < .05.",
            figures.preference_bars_figure(pooled),
        )
    )
    doc.append(_sign_table(pooled, "Table 2. Sign tests per pair, pooled over clips."))
    doc.append(
        Plot(
            "Figure 3. Confusion matrix pooled over clips: rows are the condition on "
            "the left panel, columns the one on the right; each cell gives votes "
            "left / undecided / right, coloured by the share of decisive votes for the "
            "left panel (blue: left preferred).",
            figures.confusion_figure(pooled),
        )
    )
    doc.append(Heading("Per-participant scores"))
    doc.append(
        Paragraph(
            "A participant's score for a condition is the number of ballots they "
            "gave it"
            + (
                " (each undecided vote adds 1/2 to both conditions)"
                if r["options"]["undecided"] == "split"
                else ""
            )
            + ". Conditions are compared by paired t-tests across participants, "
            "reported as SPSS reports them, with Holm's adjustment over all pairs."
        )
    )
    doc.append(
        _t_table(pooled, "Table 3. Paired samples test, pooled over clips (mean = a minus b).")
    )
    doc.append(Heading("Agreement and consistence"))
    doc.append(_agreement_table(r))
    if any(p["consistence"]["zeta"] is not None for p in r["participants"].values()):
        doc.append(
            Plot(
                "Figure 4. Coefficients of consistence of the participants.",
                figures.consistence_figure(r),
            )
        )
    doc.append(_participant_table(r))
    doc.append(Heading("Scale"))
    doc.append(
        Plot(
            "Figure 5. Thurstone Case V scale with bootstrap intervals: pooled (black) "
            "and per clip (coloured).",
            figures.scale_figure(r),
        )
    )
    doc.append(_scale_table(r))
    doc += inference_blocks(r)
    doc += _appropriateness_blocks(r.get("appropriateness") or {})
    doc += answer_detail_blocks(r)
    doc.append(Heading("Per clip"))
    for clip, section in r["clips"].items():
        doc.append(_sign_table(section, f"Sign tests, clip {clip}."))
        doc.append(_t_table(section, f"Paired samples test, clip {clip} (mean = a minus b)."))
    doc.append(Heading("Method"))
    for text in (*METHOD_TEXT, *MODEL_TEXT):
        doc.append(
            Paragraph(text.format(seed=r["options"]["seed"], boot=r["options"]["bootstrap"]))
        )
    return doc
