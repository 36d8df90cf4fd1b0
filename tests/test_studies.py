"""Creating a study from a study file: its settings reach the study's row."""

import pytest

from app.errors import InputError
from app.studies import create_study
from app.trials.studyfile import loads_study
from tests.conftest import create_test_user, write_tone_wav
from tests.jobs.test_tasks import TOML


def test_exclusion_rules_from_the_study_file_reach_the_study_and_bad_ones_are_refused(app,
                                                                                     tmp_path):
    write_tone_wav(tmp_path / "s1.wav", seconds=1.0)
    good = loads_study(TOML.format().replace('practice = false', 'practice = false\nexclude = '
                                                                  '"catch<1.0,side_p<0.001"'),
                       base_dir=tmp_path)
    bad = loads_study(TOML.format().replace('practice = false', 'practice = false\nexclude = '
                                                                 '"sidebias>2"'),
                      base_dir=tmp_path)
    with app.app_context():
        user = create_test_user()
        study = create_study(user, good)
        assert study.settings["exclude"] == "catch<1.0,side_p<0.001"
        with pytest.raises(InputError, match="exclude: unknown field 'sidebias'"):
            create_study(user, bad)
