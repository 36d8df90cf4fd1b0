"""Benchmark: the cost the adaptive design adds to a vote (``record_vote`` choosing the next
pair, ``app/web/study/adaptive.py``), against the same vote in a fixed design.

Two studies of eight conditions on one clip, ``adaptive`` and ``unordered_counterbalanced``
(the comparator), on a file-backed SQLite database; participants join and vote through the
services (``enrol``, ``record_vote``, one commit per vote, as the vote request does) until
each study holds ``--votes`` votes. Printed: the median and 95th percentile time of one vote
in each, by how many votes the study held, and the ratio. The vote path's target (p99 below
200 ms under load, docs/benchmarks.md) is what the added time is read against.

Run from the repository root:

    PYTHONPATH=$PWD python benchmarks/bench_adaptive_vote.py            # 2,000 votes each
    PYTHONPATH=$PWD python benchmarks/bench_adaptive_vote.py --votes 500
"""

from __future__ import annotations

import argparse
import secrets
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks.synthetic import write_speech  # noqa: E402

CONDITIONS = "".join(f'[[conditions]]\nname = "c{k}"\nmodel = "random"\n\n' for k in range(8))
STUDY = """title = "Adaptive benchmark"
question = "Which face moves more naturally?"
design = "{design}"
seed = 3
target_participants = 100000

[replay]
policy = "unlimited"

{conditions}[[clips]]
name = "s1"
audio = "s1.wav"
"""


def run(votes: int) -> dict[str, list[tuple[int, float]]]:
    import numpy as np
    import sqlalchemy as sa
    from flask_migrate import upgrade

    from app.trials.studyfile import loads_study
    from app.web import create_app
    from app.web.extensions import db
    from app.web.infra.accounts import create_user
    from app.web.models import Stimulus, Trial
    from app.web.study.enrolment import enrol
    from app.web.study.studies import create_study
    from app.web.study.votes import participant_for_vote, record_vote

    tmp = Path(tempfile.mkdtemp(prefix="bench-adaptive-"))
    write_speech(tmp / "s1.wav", 2.0)
    app = create_app(
        {
            "SQLALCHEMY_DATABASE_URI": f"sqlite:///{tmp / 'db.sqlite'}",
            "MEDIA_ROOT": str(tmp / "media"),
            "JOB_RUNNER": "inline",
            "REQUIRE_SECRET_KEY": False,
        }
    )
    rng = np.random.default_rng(0)
    out: dict[str, list[tuple[int, float]]] = {}
    with app.app_context():
        upgrade()
        owner = create_user("bench@example.org", "adaptive benchmark orchid tundra")
        db.session.commit()
        for design in ("unordered_counterbalanced", "adaptive"):
            text = STUDY.format(design=design, conditions=CONDITIONS)
            study = create_study(owner, loads_study(text, base_dir=tmp), source_toml=text)
            for stimulus in db.session.scalars(
                sa.select(Stimulus).where(Stimulus.study_id == study.id)
            ):
                stimulus.video_path = f"videos/{stimulus.id}.mp4"
            study.status = "open"
            db.session.commit()
            timings: list[tuple[int, float]] = []
            cast = 0
            while cast < votes:
                person = enrol(study)
                db.session.commit()
                token = person.token
                while cast < votes:
                    participant = participant_for_vote(token).participant  # type: ignore[union-attr]
                    trial = db.session.scalars(
                        sa.select(Trial)
                        .where(Trial.participant_id == participant.id, Trial.kind != "practice")
                        .where(~Trial.vote.has())
                        .order_by(Trial.position)
                        .limit(1)
                    ).first()
                    if trial is None:
                        db.session.commit()
                        break
                    trial.plays = 1
                    payload = {
                        "token": token,
                        "trial_id": trial.id,
                        "choice": ("left", "right", "undecided")[int(rng.integers(3))],
                        "plays": 1,
                        "watched_to_end": True,
                        "response_ms": 1500,
                        "presented_at": "2026-01-01T10:00:00.000Z",
                        "idempotency_key": secrets.token_hex(8),
                    }
                    start = time.perf_counter()
                    record_vote(participant, payload)
                    db.session.commit()
                    timings.append((cast, time.perf_counter() - start))
                    cast += 1
            out[design] = timings
        db.engine.dispose()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--votes", type=int, default=2000, help="votes per study")
    args = parser.parse_args()
    result = run(args.votes)
    edges = [0, args.votes // 4, args.votes // 2, 3 * args.votes // 4, args.votes]
    print(f"{args.votes} votes per study, 8 conditions, SQLite file; ms per vote (median / p95)")
    print(f"{'votes held':>14}  {'fixed (comparator)':>20}  {'adaptive':>16}  ratio of medians")
    for low, high in zip(edges, edges[1:], strict=False):
        cells = []
        for design in ("unordered_counterbalanced", "adaptive"):
            ms = sorted(1000 * t for n, t in result[design] if low <= n < high)
            cells.append((statistics.median(ms), ms[int(0.95 * (len(ms) - 1))]))
        (fm, fp), (am, ap) = cells
        print(f"{low:>6}-{high:<7}  {fm:9.2f} / {fp:7.2f}  {am:7.2f} / {ap:7.2f}  {am / fm:6.2f}")


if __name__ == "__main__":
    main()
