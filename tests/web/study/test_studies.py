"""Creating a study from a study file: its settings reach the study's row."""

import pytest

from app.errors import InputError
from app.trials.studyfile import loads_study
from app.web.study.studies import create_study
from tests.conftest import create_test_user, write_tone_wav
from tests.support.studies import NAMED_CONDITIONS


def test_exclusion_rules_from_the_study_file_reach_the_study_and_bad_ones_are_refused(
    app, tmp_path
):
    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    good = loads_study(
        NAMED_CONDITIONS.format().replace(
            "practice = false", 'practice = false\nexclude = "catch<1.0,side_p<0.001"'
        ),
        base_dir=tmp_path,
    )
    bad = loads_study(
        NAMED_CONDITIONS.format().replace(
            "practice = false", 'practice = false\nexclude = "sidebias>2"'
        ),
        base_dir=tmp_path,
    )
    with app.app_context():
        user = create_test_user()
        study = create_study(user, good)
        assert study.settings["exclude"] == "catch<1.0,side_p<0.001"
        with pytest.raises(InputError, match="exclude: unknown field 'sidebias'"):
            create_study(user, bad)


@pytest.mark.parametrize(
    "toml",
    [
        {"design": "all_ordered", "catch": 1},
        {"design": "all_ordered", "catch": 2, "catch_kind": "onscreen"},
        {"design": "unordered_counterbalanced"},
    ],
)
def test_the_stimulus_rows_are_what_some_schedule_shows(app, web, toml):
    """``studies.stimulus_combinations`` is the pure package's ``shown_stimuli`` and
    ``variant_stimuli`` of the study file, stored once each."""
    import sqlalchemy as sa

    from app.web.extensions import db
    from app.web.models import Stimulus, Study
    from app.web.study.studies import stimulus_combinations

    study_id = web.study(video=False, **toml)
    spec = loads_study(web.toml(**toml), check_files=False)
    expected = [(clip, p.left, p.right, "", "") for clip, p in spec.stimuli()] + [
        (clip, p.left, p.right, i, f) for clip, p, i, f in spec.variants()
    ]
    with app.app_context():
        study = db.session.get(Study, study_id)
        assert stimulus_combinations(study) == expected
        stored = [
            (s.clip.name, s.left.name, s.right.name, s.instruction, s.foreign_side)
            for s in db.session.scalars(sa.select(Stimulus).order_by(Stimulus.id))
        ]
    assert stored == expected


def _sized(n_conditions: int, n_clips: int, design: str = "all_ordered") -> str:
    conditions = "".join(
        f'\n[[conditions]]\nname = "c{i}"\nmodel = "random"\n' for i in range(n_conditions)
    )
    clips = "".join(f'\n[[clips]]\nname = "s{i}"\naudio = "s1.wav"\n' for i in range(n_clips))
    return (
        f'title = "Sized"\nquestion = "Which?"\ndesign = "{design}"\npractice = false\n'
        + conditions
        + clips
    )


@pytest.mark.parametrize(
    "conditions,clips,field,fragment",
    [
        (200, 1, "conditions", "200 conditions, at most 20 (MAX_CONDITIONS)"),
        (2, 101, "clips", "101 clips, at most 100 (MAX_CLIPS)"),
        (20, 3, "design", "1200 trials a participant, at most 1000"),
    ],
)
def test_a_study_beyond_the_caps_is_refused_in_one_line(
    app, tmp_path, conditions, clips, field, fragment
):
    write_tone_wav(tmp_path / "s1.wav", seconds=0.5)
    spec = loads_study(_sized(conditions, clips), base_dir=tmp_path)
    with app.app_context():
        user = create_test_user()
        with pytest.raises(InputError) as caught:
            create_study(user, spec)
    message = str(caught.value)
    assert message.startswith(f"{field}: ") and fragment in message and "\n" not in message


def test_the_caps_are_configurable(app, tmp_path):
    write_tone_wav(tmp_path / "s1.wav", seconds=0.5)
    spec = loads_study(_sized(3, 2), base_dir=tmp_path)  # 9 pairs x 2 clips = 18 trials
    app.config["MAX_TRIALS_PER_PARTICIPANT"] = 17
    with app.app_context():
        user = create_test_user()
        with pytest.raises(InputError, match="18 trials a participant, at most 17"):
            create_study(user, spec)
        app.config["MAX_TRIALS_PER_PARTICIPANT"] = 18
        assert create_study(user, spec).design == "all_ordered"
