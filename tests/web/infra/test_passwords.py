"""The secret key's judge (``app.web.infra.passwords.key_problem``): the keys made as the
refusal says pass, and any key is judged in one line ending in how to make one."""

import secrets

from hypothesis import given, settings
from hypothesis import strategies as st

from app.web.infra.passwords import GENERATE_KEY, key_problem


def test_the_keys_made_as_documented_pass_every_time():
    for _ in range(40):
        for key in (secrets.token_hex(32), secrets.token_hex(16), secrets.token_urlsafe(32)):
            assert key_problem(key) is None, key
    # longer than zxcvbn reads (72 characters, beyond which it raised): judged, not a crash
    assert key_problem(secrets.token_hex(64)) is None
    assert key_problem("qwertyuiop" * 12) is not None


@settings(max_examples=60, deadline=None)
@given(key=st.text(max_size=200))
def test_any_key_is_judged_in_one_line(key):
    problem = key_problem(key)
    assert problem is None or ("\n" not in problem and problem.endswith(GENERATE_KEY))
