"""The adaptive design through the one vote path: each answer carries the pair of highest
expected information gain among those the participant can still be shown on the clip."""

import numpy as np
import sqlalchemy as sa

from app.trials.adaptive import fit_posterior, information_gain, wins_from_votes
from app.web.extensions import db
from app.web.models import Condition, Stimulus, Study, Trial, Vote
from tests.conftest import ParticipantActions
from tests.support.studies import EIGHT_CONDITIONS


def _pairs_of(app, token):
    """(trial id, left id, right id, clip id, voted) of a participant's ordinary trials, in
    order."""
    with app.app_context():
        rows = db.session.execute(
            sa.select(Trial.id, Stimulus.left_id, Stimulus.right_id, Stimulus.clip_id, Vote.id)
            .join(Stimulus, Stimulus.id == Trial.stimulus_id)
            .outerjoin(Vote, Vote.trial_id == Trial.id)
            .where(Trial.participant.has(token=token), Trial.kind == "trial")
            .order_by(Trial.position)
        ).all()
    return rows


def _gain_now(app, study_id):
    """The information gain of each pair (by condition ids) under the study's votes."""
    with app.app_context():
        ids = sorted(
            db.session.scalars(sa.select(Condition.id).where(Condition.study_id == study_id))
        )
        index = {c: k for k, c in enumerate(ids)}
        rows = db.session.execute(
            sa.select(Stimulus.left_id, Stimulus.right_id, Vote.choice)
            .join(Trial, Trial.stimulus_id == Stimulus.id)
            .join(Vote, Vote.trial_id == Trial.id)
            .where(Stimulus.study_id == study_id, Trial.kind == "trial")
        ).all()
    left, right, choice = (np.array(column) for column in zip(*rows, strict=True))
    wins = wins_from_votes(
        len(ids),
        np.vectorize(index.get)(left),
        np.vectorize(index.get)(right),
        np.vectorize({"left": 0, "right": 1, "undecided": 2}.get)(choice),
    )
    gain = information_gain(fit_posterior(wins))
    return {(a, b): gain[index[a], index[b]] for a in ids for b in ids if a != b}


def test_each_answer_carries_the_most_informative_pair_not_yet_judged(app, web):
    study_id = web.study(design="adaptive", extra=EIGHT_CONDITIONS)
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    rng = np.random.default_rng(0)
    for _person in range(3):
        who = ParticipantActions(app.test_client(), app)
        who.join(slug)
        rows = _pairs_of(app, who.token)
        assert len(rows) == 14  # half of the 28 pairs of one clip
        while (trial := who.current_trial()) is not None:
            answer = who.vote(trial, ["left", "right", "undecided"][rng.integers(3)])
            assert answer.status_code == 201
            rows = _pairs_of(app, who.token)
            judged = {frozenset(r[1:3]) for r in rows if r[4] is not None}
            pending = [r for r in rows if r[4] is None]
            if not pending:
                assert answer.json["next_trial"] is None
                break
            nxt = pending[0]
            assert frozenset(nxt[1:3]) not in judged  # never a pair it cannot show again
            gain = _gain_now(app, study_id)
            best = max(g for pair, g in gain.items() if frozenset(pair) not in judged)
            assert gain[(nxt[1], nxt[2])] >= best * (1 - 1e-6)
            assert who.current_trial() == nxt[0]
            carried = answer.json["next_trial"]
            # the answer carries the chosen pair, and nothing to preload: the trial after it
            # has no pair yet
            assert carried["trial_id"] == nxt[0] and carried["preload_url"] is None
            page = who.client.get(f"/p/{who.token}/trial").get_data(as_text=True)
            assert "data-preload-url" not in page
        done = _pairs_of(app, who.token)
        assert len({frozenset(r[1:3]) for r in done}) == 14  # 14 different pairs
    with app.app_context():
        shown = db.session.execute(
            sa.select(Stimulus.left_id, Stimulus.right_id)
            .join(Trial, Trial.stimulus_id == Stimulus.id)
            .join(Vote, Vote.trial_id == Trial.id)
        ).all()
    # both orders of a pair judged more than once appear
    twice = {frozenset(p) for p in shown if sum(frozenset(q) == frozenset(p) for q in shown) > 1}
    assert any((a, b) in shown and (b, a) in shown for a, b in (tuple(sorted(p)) for p in twice))


def test_other_designs_keep_their_schedule(app, web, participant):
    study_id = web.study(design="all_ordered")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)
    before = _pairs_of(app, participant.token)
    assert "data-preload-url" in participant.client.get(f"/p/{participant.token}/trial").text
    participant.vote(participant.current_trial(), "left")
    after = _pairs_of(app, participant.token)
    assert [r[:3] for r in before] == [r[:3] for r in after]
