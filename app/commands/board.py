"""What the leaderboard's commands share, ``facepair leaderboard`` and its ``demo``
(:mod:`app.commands.leaderboard_demo`): the software a season records (:func:`season_software`)
and the published board as lines of text (:func:`board_lines`).
"""

from __future__ import annotations


def season_software() -> dict[str, str | None]:
    """The software a season made here records in its manifest besides facepair: the
    renderer's version."""
    from renderer.api import RENDERER_VERSION

    return {"renderer": RENDERER_VERSION}


def board_lines(board: dict) -> list[str]:  # type: ignore[type-arg]
    """The board as text: band, system, score [interval], coherence, votes."""
    lines = []
    for row in board["systems"]:
        flags = " (anchor)" * bool(row["anchor"]) + " (preliminary)" * bool(row["preliminary"])
        coherence = row["coherence"]["score"]
        lines.append(
            f"  band {row['rank_band'] or '-'}  {row['name']:<34} "
            f"{_num(row['score'])} [{_num(row['ci_low'])}, {_num(row['ci_high'])}]  "
            f"coherence {_num(coherence, 1)}%  {row['votes']} votes{flags}"
        )
    for rnd in board["rounds"]:
        drift = rnd.get("drift") or {}
        state = "drifted" if drift.get("drifted") else ("no drift" if drift.get("checked") else "-")
        lines.append(f"  round {rnd['number']}: {rnd['votes']} votes, drift check: {state}")
    return lines


def _num(value: float | None, digits: int = 0) -> str:
    return "-" if value is None else f"{value:.{digits}f}"
