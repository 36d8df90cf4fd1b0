"""``facepair leaderboard demo`` (``app.commands.leaderboard_demo``) end to end, once per module:
a season on the demo speech, three systems in three formats, simulated participants voting
through the HTTP API, two rounds, the board published. The tests read what it left: the order
recovers the simulated preferences, round 2 added a system without re-running round 1, the
files are what the guide says, and the pages work in a browser at desktop and phone width."""

from __future__ import annotations

import hashlib
import io
import json
import secrets
import zipfile
from pathlib import Path
from typing import Any

import pytest
import sqlalchemy as sa
from click.testing import CliRunner

from app.cli import main
from app.leaderboard.demo import TRUE_STRENGTHS

pytestmark = pytest.mark.slow


def _round_one_state(app: Any, out: Path) -> dict[str, Any]:
    """What round 1 is made of: its study's votes, jobs and clips, and its published package."""
    from app.web.board.models import BoardRound
    from app.web.extensions import db
    from app.web.models import Job, Stimulus, Vote
    from app.web.study.package import build_package

    with app.app_context():
        rnd = db.session.scalar(sa.select(BoardRound).where(BoardRound.number == 1))
        assert rnd is not None
        study = rnd.study
        votes = db.session.execute(
            sa.select(Vote.id, Vote.choice).where(Vote.participant.has(study_id=study.id))
        ).all()
        jobs = db.session.scalars(sa.select(Job.id).where(Job.study_id == study.id)).all()
        clips = db.session.scalars(
            sa.select(Stimulus.video_path).where(Stimulus.study_id == study.id)
        ).all()
        package = zipfile.ZipFile(io.BytesIO(build_package(study)))
        state = {
            "status": rnd.status,
            "systems": list(rnd.systems),
            "votes": sorted((i, c) for i, c in votes),
            "jobs": sorted(jobs),
            "clips": sorted(str(c) for c in clips),
            "package_votes": hashlib.sha256(
                package.read(next(n for n in package.namelist() if n.endswith("votes.csv")))
            ).hexdigest(),
            "board": json.loads((out / "leaderboard.json").read_text()),
        }
        db.session.remove()
        return state


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory) -> dict[str, Any]:
    """Run the demo once; snapshot round 1 after each publication."""
    from app.commands import leaderboard_demo

    out = tmp_path_factory.mktemp("demo") / "board"
    snapshots: list[dict[str, Any]] = []
    original = leaderboard_demo._round

    def watched(app, base, season_name, participants, seed, folder):  # type: ignore[no-untyped-def]
        board = original(app, base, season_name, participants, seed, folder)
        snapshots.append(_round_one_state(app, folder))
        return board

    patch = pytest.MonkeyPatch()
    patch.setattr(leaderboard_demo, "_round", watched)
    try:
        result = CliRunner().invoke(main, ["leaderboard", "demo", "--out", str(out)])
    finally:
        patch.undo()
    assert result.exit_code == 0, result.output + repr(result.exception)
    return {"out": out, "output": result.output, "snapshots": snapshots}


def _board(demo_run) -> dict[str, Any]:
    return json.loads((demo_run["out"] / "leaderboard.json").read_text())


def test_the_published_order_recovers_the_simulated_preferences(demo_run) -> None:
    from scipy.stats import kendalltau

    rows = {r["name"]: r for r in _board(demo_run)["systems"]}
    # anchors are in the votes under their model's name, submitted systems under their own
    truth = {n: TRUE_STRENGTHS[r["code"] if r["anchor"] else n] for n, r in rows.items()}
    published = sorted(rows, key=lambda n: -rows[n]["score"])
    expected = sorted(truth, key=lambda n: -truth[n])
    tau = kendalltau([rows[n]["score"] for n in expected], [truth[n] for n in expected])
    assert tau.statistic >= 0.85, (published, expected)
    # the ends are unambiguous: the capture on top, the still head at the bottom
    assert published[0] == expected[0] and published[-1] == expected[-1]
    # bands never put a truly weaker system in a better band than a stronger one by a
    # margin of 1.0 log worth or more
    for a in rows:
        for b in rows:
            if truth[a] - truth[b] >= 1.0:
                assert rows[a]["rank_band"] <= rows[b]["rank_band"], (a, b)


def test_leaderboard_json_has_the_fields_the_guide_names(demo_run) -> None:
    board = _board(demo_run)
    assert board["format"] == "facepair-leaderboard/1"
    assert len(board["systems"]) == 6 and len(board["rounds"]) == 2
    for row in board["systems"]:
        for key in ("name", "score", "ci_low", "ci_high", "rank_band", "votes", "participants"):
            assert row[key] is not None, (row["name"], key)
        assert row["ci_low"] <= row["score"] <= row["ci_high"]
        assert isinstance(row["preliminary"], bool) and isinstance(row["anchor"], bool)
        assert row["coherence"]["score"] is not None
        assert set(row["objective"]) or row["code"] == "ground_truth"
        for render in row["renders"]:
            assert (demo_run["out"] / render["url"]).is_file()
    anchors = {r["code"] for r in board["systems"] if r["anchor"]}
    assert anchors == {"ground_truth", "none"}
    truth = next(r for r in board["systems"] if r["code"] == "ground_truth")
    assert truth["renders"] == []  # test motion is never released while the season runs
    for rnd in board["rounds"]:
        assert (demo_run["out"] / rnd["package"]).is_file()
    assert (demo_run["out"] / "votes.csv").stat().st_size > 0
    assert board["robustness"]["systems"]


def test_a_second_round_adds_a_system_without_re_running_the_first(demo_run) -> None:
    first, second = demo_run["snapshots"]
    for key in ("systems", "votes", "jobs", "clips", "package_votes"):
        assert first[key] == second[key], key
    assert first["status"] == second["status"] == "published"
    before = {r["name"] for r in first["board"]["systems"]}
    after = {r["name"] for r in second["board"]["systems"]}
    assert after - before == {"LiveGMM"}
    rounds = second["board"]["rounds"]
    assert rounds[1]["newcomers"] == ["LiveGMM"]
    # round 2 took the anchors and the top two of round 1's board, not its whole field
    top_two = sorted(
        (r for r in first["board"]["systems"] if not r["anchor"]), key=lambda r: -r["score"]
    )[:2]
    fixed = {r["name"] for r in first["board"]["systems"] if r["anchor"]}
    assert set(rounds[1]["anchors"]) == fixed | {r["name"] for r in top_two}
    assert rounds[0]["votes"] == first["board"]["rounds"][0]["votes"]
    assert rounds[0]["drift"]["checked"] is False and rounds[1]["drift"]["checked"] is True


def test_the_platform_serves_the_same_board(demo_run) -> None:
    from app.web import create_app

    work = demo_run["out"].with_name("board.season")
    app = create_app(
        {
            "SQLALCHEMY_DATABASE_URI": f"sqlite:///{work / 'facepair.sqlite'}",
            "MEDIA_ROOT": str(work / "media"),
            "SECRET_KEY": secrets.token_hex(32),
            "TESTING": True,
        }
    )
    client = app.test_client()
    page = client.get("/leaderboard/demo/")
    assert page.status_code == 200 and "LiveGMM" in page.get_data(as_text=True)
    served = client.get("/leaderboard/demo/leaderboard.json").get_json()
    assert served == _board(demo_run)
    first = served["systems"][0]["renders"]
    if first:
        clip = client.get(f"/leaderboard/demo/{first[0]['url']}")
        assert clip.status_code == 200
        clip.close()
    package = client.get("/leaderboard/demo/rounds/1/package.zip")
    assert package.status_code == 200 and package.data[:2] == b"PK"
    votes = client.get("/leaderboard/demo/votes.csv")
    assert votes.data == (demo_run["out"] / "votes.csv").read_bytes()
    with app.app_context():
        from app.web.extensions import db

        db.engine.dispose()


@pytest.mark.browser
@pytest.mark.parametrize(
    ("label", "width", "height"), [("desktop", 1280, 900), ("phone", 390, 844)]
)
def test_the_static_page_in_a_browser(demo_run, browser, shots, label, width, height) -> None:
    out = demo_run["out"]
    from tests.support.axe import axe_script, violations

    script = axe_script()
    context = browser.new_context(viewport={"width": width, "height": height}, bypass_csp=True)
    try:
        page = context.new_page()
        failed: list[str] = []
        page.on("requestfailed", lambda r: failed.append(r.url))
        page.goto((out / "index.html").as_uri())
        rows = page.locator("table.standings tbody tr")
        assert rows.count() == 6
        assert "Ground truth" in rows.first.inner_text()
        # no sideways scrolling on a phone: the table folds into cards
        overflow = page.evaluate(
            "document.scrollingElement.scrollWidth - document.documentElement.clientWidth"
        )
        assert overflow <= 1, f"{label}: {overflow} px wider than the screen"
        css = page.evaluate("getComputedStyle(document.body).fontFamily")
        assert css, "the stylesheet did not load"
        for href in page.eval_on_selector_all(
            "a[href]", "els => els.map(e => e.getAttribute('href'))"
        ):
            if "://" not in href and not href.startswith("#"):
                assert (out / href).exists(), href
        page.screenshot(path=str(shots / f"leaderboard-{label}.png"), full_page=True)
        assert not failed, failed
        # after the check above: axe fetches the stylesheet again, which file:// refuses
        assert violations(page, script) == []
    finally:
        context.close()
