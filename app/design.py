"""The study's design rows, read through ``app.trials`` (the one place for design rules).

Translates between rows (:class:`~app.models.Study`, conditions, clips, stimuli) and the pure
package's values (condition and clip names, :class:`app.trials.design.Pair`,
:class:`app.trials.schedule.Trial`, :class:`app.trials.rules.ReplayPolicy`).
"""

from __future__ import annotations

from app.models import Study


def replay_policy(study: Study):  # type: ignore[no-untyped-def]
    from app.trials.rules import ReplayPolicy

    return ReplayPolicy(study.replay, max_plays=study.max_plays if study.replay == "max_plays"
                        else None)


def may_vote(study: Study, *, plays: int, watched_to_end: bool) -> str | None:
    """Why a vote after ``plays`` plays is refused by the study's replay policy, or None."""
    from app.trials.rules import may_vote as rule

    policy = replay_policy(study)
    if rule(policy, plays, watched_to_end):
        return None
    if plays == 0:
        return "plays: the clip must be played before voting"
    if policy.kind == "play_to_end":
        return "watched_to_end: the clip must play to the end before voting"
    return f"plays: at most {policy.max_plays} plays are allowed"


def design_pairs(study: Study):  # type: ignore[no-untyped-def]
    """The study's pairs (:class:`app.trials.design.Pair`) in the stored order."""
    from app.trials.design import Pair

    return [Pair(p.first.name, p.second.name) for p in study.pairs]


def n_lists(design: str, n_clips: int) -> int:
    from app.trials.schedule import n_lists_for

    return n_lists_for(design, n_clips=n_clips)


def participation(study: Study):  # type: ignore[no-untyped-def]
    """The study's participant-side settings
    (:class:`app.trials.participation.ParticipationSpec`)."""
    from app.trials.participation import ParticipationSpec

    return ParticipationSpec.from_settings((study.settings or {}).get("participation"))


def stimulus_combinations(study: Study) -> list[tuple[str, str, str, str, str]]:
    """Every (clip, left, right, instruction, foreign side) some participant may see: the
    practice pair included (the schedule decides the practice clip, so it is rendered on every
    clip), then the attention-check and appropriateness variants
    (:func:`app.trials.schedule.variant_stimuli`)."""
    from app.trials.design import Pair, stimulus_pairs
    from app.trials.schedule import variant_stimuli

    shown = list(stimulus_pairs(design_pairs(study), study.design))
    if study.catch_trials and study.catch_kind == "identical":
        shown += [Pair(c.name, c.name) for c in study.conditions]
    practice = study.settings.get("practice")
    if practice:
        shown.append(Pair(practice[0], practice[1]))
    unique = list(dict.fromkeys(shown))
    plain = [(clip.name, p.left, p.right, "", "") for clip in study.clips for p in unique]
    clips = [c.name for c in study.clips]
    variants = variant_stimuli(clips=clips, pairs=design_pairs(study), design=study.design,
                               catch_trials=study.catch_trials, catch_kind=study.catch_kind,
                               mismatched=participation(study).mismatched)
    return plain + [(clip, p.left, p.right, instruction, foreign)
                    for clip, p, instruction, foreign in variants]


def schedule(study: Study, *, seed: int, list_index: int):  # type: ignore[no-untyped-def]
    """One participant's trials (:class:`app.trials.schedule.Trial`), in presentation order."""
    from app.trials.design import Pair
    from app.trials.schedule import make_schedule

    practice = study.settings.get("practice")
    return make_schedule(
        clips=[c.name for c in study.clips], pairs=design_pairs(study), design=study.design,
        seed=seed, list_index=list_index, n_lists=len(study.lists),
        catch_trials=study.catch_trials, catch_kind=study.catch_kind,
        practice_pair=Pair(practice[0], practice[1]) if practice else None,
        practice_clip=study.settings.get("practice_clip"),
        block_by_clip=study.settings.get("block_by_clip", True),
        mismatched=participation(study).mismatched,
    )


def participant_seed(study: Study, number: int) -> int:
    from app.trials.schedule import participant_seed as derive

    return int(derive(study.seed, number))


def choose_list(study: Study, counts: dict[int, int]) -> int:
    """The least-filled list; ties broken by a generator seeded from the study and arrivals."""
    import numpy as np

    from app.trials.assignment import choose_list as choose

    rng = np.random.default_rng([study.seed, sum(counts.values())])
    return int(choose(counts, rng))
