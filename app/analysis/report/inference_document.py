"""Report blocks for participant-level inference, the Bradley-Terry-Davidson model and
participant quality (:mod:`app.analysis.participant_level`, :mod:`app.analysis.btd`,
:mod:`app.analysis.quality`); :func:`app.analysis.report.document.build_document` places them."""

from __future__ import annotations

from typing import Any

from app.analysis.report import figures
from app.analysis.report.blocks import (
    ALPHA,
    MAX_LISTED_PARTICIPANTS,
    Block,
    Heading,
    Paragraph,
    Plot,
    Table,
    counted,
    fmt,
    fmt_p,
    judgements_per_pair,
)
from app.analysis.report.mixed_document import MIXED_TEXT, mixed_blocks, objective_blocks

METHOD_TEXT = (
    "Participant-level tests: for each pair (a, b), each participant's net preference "
    "d_p = (wins_a − wins_b) / n_p over their votes on the pair (undecided votes count in n_p); "
    "Wilcoxon signed-rank test of the d_p (zero_method 'wilcox', two-sided; exact over the "
    "sign flips up to 13 participants, ties included, as scipy.stats.wilcoxon); effect size "
    "the matched-pairs rank-biserial r = (T+ − T−) / (T+ + T−) "
    "(Kerby 2014) with a percentile bootstrap interval over participants; Holm over the pairs "
    "of a clip. With one judgement per participant and pair (the majority of their votes, a "
    "tie 1/2 to each side) u and the sign tests are recomputed.",
    "Bradley-Terry-Davidson model (Davidson 1970; order effect Davidson & Beaver 1977): with i "
    "left and j right, P(i) = g·π_i / D, P(j) = π_j / D, P(undecided) = ν·√(π_i π_j) / D, "
    "D = g·π_i + π_j + ν·√(π_i π_j); maximum likelihood, scores log π with mean 0, percentile "
    "bootstrap intervals over participants; JOD = score / ln 3 (1 JOD = 75 % of decided votes). "
    "Identical-clip pairs are left out of the fit.",
    MIXED_TEXT,
    "Participant quality: side bias (binomial test of left against right), undecided share, "
    "Kendall's τ_b with the model's consensus ranking, identical pairs answered undecided, "
    "median response time, and pwcmp's outlier distance (Q1 − L_p) / IQR of the leave-one-out "
    "log-likelihood L_p (Perez-Ortiz & Mantiuk 2017).",
)


def _ci(pair: list[float | None], digits: int = 2) -> str:
    return f"[{fmt(pair[0], digits)}, {fmt(pair[1], digits)}]"


def _sections(r: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    return [*r["clips"].items(), ("pooled", r["pooled"])]


def _which_to_cite(r: dict[str, Any]) -> Paragraph:
    pooled = r["pooled"]
    a = pooled["agreement"]
    one = pooled["one_per_participant"]["agreement"]
    judges = judgements_per_pair(pooled, r["options"]["undecided"], dash="–")
    text = (
        f"Which is which: the sign tests of Table 2 and the agreement test of Table 4 treat "
        f"every presentation as an independent judge ({judges} judgements per pair from "
        f"{counted(pooled['participants'], 'participant')}, pooled over clips and both side "
        "orders), "
        "which overstates the evidence when a participant judges a pair more than once. "
        "Cite the participant-level tests below (Table 7: Wilcoxon tests with effect sizes; "
        "Table 8: u and sign tests with one judgement per participant) and the model "
        "scores of Table 9; report the pooled counts as description."
    )
    if a["chi2"] is not None and one["chi2"] is not None:
        text += (
            f" Pooled over clips, u = {a['u']:.3f} (χ² = {a['chi2']:.1f}) counting every "
            f"presentation against u = {one['u']:.3f} (χ² = {one['chi2']:.1f}, "
            f"df = {one['df']:.1f}, p {_p_text(one['p'])}) with one judgement per "
            "participant."
        )
    return Paragraph(text)


def _p_text(p: float | None) -> str:
    text = fmt_p(p)
    return text if text.startswith("<") else f"= {text}"


def _wilcoxon_table(r: dict[str, Any]) -> Table:
    ci = int(round(100 * r["options"]["confidence"]))
    rows = [
        [
            label,
            f"{w['a']} vs {w['b']}",
            str(w["n_participants"]),
            fmt(w["median_d"]),
            fmt(w["W"], 1),
            fmt_p(w["p"]),
            fmt_p(w["p_holm"]),
            fmt(w["effect"]),
            _ci(w["effect_ci"]),
        ]
        for label, s in _sections(r)
        for w in s["participant_level"]
    ]
    return Table(
        "Table 7. Participant-level Wilcoxon signed-rank tests of the net preference "
        "d_p per pair (cite these), with the rank-biserial effect size r and its "
        f"{ci} % bootstrap interval over participants.",
        [
            "clip",
            "pair (a vs b)",
            "participants",
            "median d",
            "W",
            "p",
            "p Holm",
            "r",
            f"{ci}% CI of r",
        ],
        rows,
        note="d_p = (votes for a − votes for b) / votes on the pair; r > 0 favours a. "
        "Holm over the pairs of each clip.",
        numeric=[False, False] + [True] * 7,
    )


def _one_per_participant_table(r: dict[str, Any]) -> Table:
    rows = []
    for label, s in _sections(r):
        a, one = s["agreement"], s["one_per_participant"]["agreement"]
        rows.append(
            [
                label,
                fmt(a["u"], 3),
                fmt(a["chi2"], 1),
                fmt_p(a["p"]),
                fmt(one["u"], 3),
                fmt(one["chi2"], 1),
                fmt(one["df"]),
                fmt_p(one["p"]),
            ]
        )
    signs = ", ".join(
        f"{t['a']} vs {t['b']}: {t['participants_for_a']}/{t['participants_tied']}/"
        f"{t['participants_for_b']}, Holm p {_p_text(t['p_holm'])}"
        for t in r["pooled"]["one_per_participant"]["sign_tests"]
    )
    return Table(
        "Table 8. Coefficient of agreement u counting every presentation (pooled) and "
        "with one judgement per participant and pair (the majority of their votes; a "
        "tie counts 1/2 to each side).",
        ["clip", "u pooled", "χ² pooled", "p pooled", "u per participant", "χ²", "df", "p"],
        rows,
        note="Sign tests with one judgement per participant, pooled over clips "
        f"(participants for a / tied / for b): {signs}."
        if signs
        else "",
        numeric=[False] + [True] * 7,
    )


def _btd_text(r: dict[str, Any]) -> Paragraph:
    m = r["pooled"]["btd"]
    if m["scores"] and all(v is None for v in m["scores"].values()):
        return Paragraph(f"The model could not be fitted to the pooled votes: {m['note']}.")
    order = sorted(
        (c for c in r["conditions"] if m["scores"][c] is not None), key=lambda c: -m["scores"][c]
    )
    listed = ", ".join(f"{c} {m['jod'][c]:.2f} {_ci(m['jod_ci'][c])}" for c in order)
    side = m["identical_pairs"]
    text = (
        f"Fitted to {m['n']} votes pooled over clips (log-likelihood {m['loglik']:.1f}), "
        f"scores in JOD: {listed}. Tie parameter ν = {fmt(m['nu'])} {_ci(m['nu_ci'])}; side "
        f"factor g = {fmt(m['gamma'], 3)} {_ci(m['gamma_ci'], 3)} (g > 1: the left panel "
        "is favoured). "
    )
    if side["votes"]:
        text += (
            f"Identical-clip pairs ({side['votes']} votes, left out of the fit): "
            f"{side['left']} left, {side['right']} right, {side['undecided']} undecided"
            + (
                f"; binomial test of left against right p {_p_text(side['p'])}."
                if side["p"] is not None
                else "."
            )
        )
    return Paragraph(text)


def _btd_table(r: dict[str, Any]) -> Table:
    ci = int(round(100 * r["options"]["confidence"]))
    m = r["pooled"]["btd"]
    scale = {s["condition"]: s for s in r["pooled"]["scale"]}
    clips = list(r["clips"])
    rows = [
        [
            c,
            fmt(m["scores"][c]),
            _ci(m["ci"][c]),
            fmt(m["jod"][c]),
            _ci(m["jod_ci"][c]),
            fmt(scale[c]["score"]),
        ]
        + [fmt(r["clips"][k]["btd"]["jod"][c]) for k in clips]
        for c in r["conditions"]
    ]
    notes = [f"{label}: {s['btd']['note']}" for label, s in _sections(r) if s["btd"]["note"]]
    return Table(
        f"Table 9. Bradley-Terry-Davidson scores pooled over clips (log worth, mean 0) "
        f"with {ci} % bootstrap intervals over participants, the same in JOD next to "
        "the Thurstone Case V scale (JOD), and each clip's model scores (JOD).",
        [
            "condition",
            "score",
            f"{ci}% CI",
            "JOD",
            f"{ci}% CI (JOD)",
            "Case V (JOD)",
            *[f"{k} (JOD)" for k in clips],
        ],
        rows,
        note="; ".join(notes),
        numeric=[False] + [True] * (5 + len(clips)),
    )


def _quality_blocks(r: dict[str, Any]) -> list[Block]:
    q = r["quality"]
    if q["rules"]:
        who = "; ".join(f"{pid}: {', '.join(why)}" for pid, why in q["excluded"].items())
        text = (
            f"Exclusion rules {', '.join(q['rules'])} were applied before every statistic "
            f"of this report: {len(q['excluded'])} of "
            f"{counted(len(q['participants']), 'participant')} excluded"
            + (f" ({who})." if who else ".")
        )
    else:
        text = (
            "No exclusion rules were applied (facepair analyze --exclude, e.g. "
            "'catch<1.0,side_p<0.001'); every participant is in every statistic."
        )
    rows = []
    for pid, p in list(q["participants"].items())[:MAX_LISTED_PARTICIPANTS]:
        rows.append(
            [
                pid,
                str(p["votes"]),
                fmt(p["side_left"]),
                fmt_p(p["side_p"]),
                fmt(p["undecided"]),
                fmt(p["tau"]),
                # quality's `catch` field: identical pairs of the design, not catch trials
                "-"
                if p["catch"] is None
                else f"{round(p['catch'] * p['catch_trials'])}/{p['catch_trials']}",
                fmt(p["median_ms"], 0),
                fmt(p["outlier"]),
                "excluded" if pid in q["excluded"] else "",
            ]
        )
    more = len(q["participants"]) - len(rows)
    flagged = [
        pid
        for pid, p in q["participants"].items()
        if (p["side_p"] is not None and p["side_p"] < ALPHA)
        or (p["outlier"] is not None and p["outlier"] > 1.5)
    ]
    table = Table(
        "Table 10. Participant quality, computed on all participants before any exclusion.",
        [
            "participant",
            "votes",
            "left share",
            "side p",
            "undecided",
            "τ_b",
            "identical undecided",
            "median ms",
            "outlier",
            "Excluded",
        ],
        rows,
        note=(f"{more} more participants are in the JSON output. " if more > 0 else "")
        + "identical undecided: the pairs with the same condition on both sides (A|A, the "
        "design's identical-clip pairs; not catch trials) answered undecided / shown; the "
        "exclusion rules call this share 'catch' (--exclude 'catch<1.0'). "
        + _catch_trials_text(r["input"].get("catch_votes", 0))
        + " Outlier: pwcmp's "
        "distance below the first quartile of the leave-one-out log-likelihood, in "
        "IQRs (above 1.5 is unusual). "
        + (
            f"Side p < .05 or outlier > 1.5: {', '.join(flagged)}."
            if flagged
            else "No participant has side p < .05 or outlier > 1.5."
        ),
        numeric=[False] + [True] * 8 + [False],
    )
    return [Paragraph(text), table, *_seen_blocks(q)]


def _catch_trials_text(votes: int) -> str:
    """What became of the catch trials (attention checks, ``kind = catch``): never in a
    statistic nor in the quality table."""
    if not votes:
        return (
            "The votes hold no catch trial (attention check, kind = catch) of an included "
            "participant."
        )
    return (
        f"Catch trials (attention checks, kind = catch) are in no statistic and not in this "
        f"table: {counted(votes, 'catch-trial vote')} of the included participants left out."
    )


#: The per-participant measures of the media log and identical pairs (``app.analysis.quality``).
SEEN = ("same_left", "unfinished", "stall_ms", "focus_lost")


def _seen_blocks(q: dict[str, Any]) -> list[Block]:
    """What participants saw: side bias on identical pairs and the media log, when recorded."""
    people = list(q["participants"].items())
    if not any(p.get(k) is not None for _, p in people for k in SEEN):
        return []
    rows = [
        [
            pid,
            fmt(p.get("same_left")),
            fmt(p.get("unfinished")),
            fmt(p.get("stall_ms"), 0),
            fmt(p.get("focus_lost"), 0),
        ]
        for pid, p in people[:MAX_LISTED_PARTICIPANTS]
    ]
    return [
        Table(
            "Table 11. What each participant saw: share of left among decided "
            "identical-pair votes (side bias), share of clips not played to their end, "
            "milliseconds of stalled playback and times the window lost focus.",
            ["participant", "identical: left", "not to end", "stall ms", "focus lost"],
            rows,
            note="From the media log of each vote; exclusion rules can use these "
            "fields (same_left, unfinished, stall_ms, focus_lost).",
            numeric=[False, True, True, True, True],
        )
    ]


def inference_blocks(r: dict[str, Any]) -> list[Block]:
    """The participant-level, model and participant-quality sections of the report."""
    return [
        Heading("Participant-level inference"),
        _which_to_cite(r),
        _wilcoxon_table(r),
        _one_per_participant_table(r),
        Heading("Bradley-Terry-Davidson model with ties and side"),
        _btd_text(r),
        Plot(
            "Figure 6. Bradley-Terry-Davidson scores in JOD with bootstrap intervals over "
            "participants (filled) and the Thurstone Case V scale (open), one panel per clip "
            "and pooled.",
            figures.btd_figure(r),
        ),
        _btd_table(r),
        *mixed_blocks(r),
        *objective_blocks(r),
        Heading("Participant quality"),
        *_quality_blocks(r),
    ]
