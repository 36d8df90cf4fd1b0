"""Creating a study from a study file: its settings reach the study's row."""

import pytest

from app.errors import InputError
from app.trials.studyfile import loads_study
from app.web.study.studies import create_study
from tests.conftest import create_test_user, write_tone_wav
from tests.jobs.test_tasks import TOML


def test_exclusion_rules_from_the_study_file_reach_the_study_and_bad_ones_are_refused(
    app, tmp_path
):
    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    good = loads_study(
        TOML.format().replace(
            "practice = false", 'practice = false\nexclude = "catch<1.0,side_p<0.001"'
        ),
        base_dir=tmp_path,
    )
    bad = loads_study(
        TOML.format().replace("practice = false", 'practice = false\nexclude = "sidebias>2"'),
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
