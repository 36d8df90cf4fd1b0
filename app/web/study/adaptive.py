"""The ``adaptive`` design's next pair: each vote puts the pair of highest expected
information gain on the participant's next trial (:mod:`app.trials.adaptive`, ASAP).

An adaptive schedule holds half the pairs per clip (:func:`app.trials.schedule.make_schedule`);
its trials are places whose pair is decided when the one before is answered, from every vote
of the study so far. Candidates are the rendered plain stimuli of the next trial's clip whose
pair this participant has not judged on that clip, so the scheduler can only propose what the
study can show; catch and practice trials keep their place and clip.
"""

from __future__ import annotations

import numpy as np
import sqlalchemy as sa

from app.trials.adaptive import fit_posterior, next_pair, wins_from_votes
from app.trials.rules import CHOICES  # left, right, undecided: the order wins_from_votes reads
from app.web.extensions import db
from app.web.models import Pair, Participant, Stimulus, Trial, Vote
from app.web.study.enrolment import study_design

ADAPTIVE = "adaptive"


def choose_next_pair(participant: Participant) -> Trial | None:
    """Put the chosen pair on ``participant``'s next unanswered trial when their study is
    adaptive and that trial is an ordinary one; returns the trial changed, else None. Runs in
    the vote's transaction (the participant row is locked), after the vote is stored."""
    study = participant.study
    if study.design != ADAPTIVE:
        return None
    trial = db.session.scalars(
        sa.select(Trial)
        .outerjoin(Vote, Vote.trial_id == Trial.id)
        .where(
            Trial.participant_id == participant.id,
            Trial.kind != "practice",  # as the next pair's query (progress.upcoming)
            Vote.id.is_(None),
        )
        .order_by(Trial.position)
        .limit(1)
    ).first()
    if trial is None or trial.kind != "trial":
        return None
    fixed = study_design(study)
    index = {cid: k for k, cid in enumerate(sorted(fixed.conditions.values()))}
    n = len(index)
    clip_id = trial.stimulus.clip_id
    voted = db.session.execute(
        sa.select(
            Stimulus.left_id, Stimulus.right_id, Vote.choice, Trial.participant_id, Stimulus.clip_id
        )
        .join(Trial, Trial.stimulus_id == Stimulus.id)
        .join(Vote, Vote.trial_id == Trial.id)
        .where(Stimulus.study_id == study.id, Trial.kind == "trial")
    ).all()
    shown, sides = np.zeros((n, n)), np.zeros(n)
    judged: set[frozenset[int]] = set()
    lefts = np.array([index[row[0]] for row in voted], dtype=int)
    rights = np.array([index[row[1]] for row in voted], dtype=int)
    wins = wins_from_votes(n, lefts, rights, np.array([CHOICES.index(r[2]) for r in voted]))
    for left, right, (_, _, _, who, clip) in zip(lefts, rights, voted, strict=True):
        if left == right:
            continue
        shown[left, right] += 1
        if who == participant.id:
            sides[left] += 1
            sides[right] -= 1
            if clip == clip_id:
                judged.add(frozenset((left, right)))
    stimuli = {
        (index[s.left_id], index[s.right_id]): s
        for s in db.session.scalars(
            sa.select(Stimulus).where(
                Stimulus.study_id == study.id,
                Stimulus.clip_id == clip_id,
                Stimulus.instruction == "",
                Stimulus.foreign_side == "",
                Stimulus.left_id != Stimulus.right_id,
                Stimulus.video_path.is_not(None),
            )
        )
    }
    showable = [pair for pair in stimuli if frozenset(pair) not in judged]
    answered = int(shown.sum())
    rng = np.random.default_rng([participant.seed % 2**63, answered])
    choice = next_pair(fit_posterior(wins), showable, shown, sides, rng)
    if choice is None:
        return None
    stimulus = stimuli[choice]
    pair_id = fixed.pair_ids.get((stimulus.left_id, stimulus.right_id))
    pair = None if pair_id is None else db.session.get(Pair, pair_id)
    trial.stimulus, trial.pair = stimulus, pair
    db.session.flush()
    return trial
