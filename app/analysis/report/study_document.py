"""The report's head when a study describes the votes (a report the web app writes): the
study's title, the date, the design, the participants, the included participants'
questionnaire answers and the command that writes the same report from the exported votes.

Placed first by :func:`app.analysis.report.document.build_document`, for paired-comparison
and rating studies alike.
"""

from __future__ import annotations

from typing import Any

from app.analysis.report.blocks import Block, Heading, Paragraph, Table


def study_blocks(study: dict[str, Any]) -> list[Block]:
    """The report's head when a study describes the votes: its title, the date, the design
    and the command that writes the same report from the exported votes."""
    blocks: list[Block] = [Heading(study["title"], 1)]
    blocks.append(Paragraph(f"Report written {study['date']}. " + study.get("design", "")))
    if study.get("participants"):
        blocks.append(Paragraph(study["participants"]))
    blocks += _questionnaire_blocks(study.get("questionnaire") or [])
    if study.get("command"):
        blocks.append(
            Paragraph(
                "To reproduce this report from the exported votes "
                f"({study.get('votes_file', 'votes.csv')}): {study['command']}"
            )
        )
    return blocks


def _questionnaire_blocks(summary: list[dict[str, Any]]) -> list[Block]:
    """The included participants' questionnaire answers: options counted, numbers summarised,
    free texts listed."""
    if not summary:
        return []
    rows = []
    for q in summary:
        if q["kind"] == "choice":
            given = "; ".join(f"{c}: {n}" for c, n in q["counts"].items() if n)
        elif q["kind"] == "number":
            given = (
                f"median {q['median']:g}, range {q['min']:g}-{q['max']:g}" if q["answered"] else ""
            )
        else:
            given = " | ".join(q["texts"])
        rows.append([q["text"], f"{q['answered']} of {q['asked']}", given or "-"])
    return [
        Heading("Questionnaire", 2),
        Table(
            "Answers of the included participants.",
            ["Question", "Answered", "Answers"],
            rows,
            numeric=[False, True, False],
        ),
    ]
