"""Whether a password is one attackers try first (OWASP ASVS 4.0, 2.1.7).

The check is ``zxcvbn`` (Dropbox's estimator, Wheeler 2016, "zxcvbn: Low-Budget Password
Strength Estimation", USENIX Security; the Python port on PyPI), which ships the 30,000 most
common passwords of leaked sets and scores a password by the guesses its cheapest decomposition
into dictionary words, keyboard patterns, repeats, sequences and dates needs. Nothing is sent
anywhere: the lists are part of the package.
"""

from __future__ import annotations

from zxcvbn import zxcvbn
from zxcvbn.frequency_lists import FREQUENCY_LISTS

#: zxcvbn's score (0-4) a password must reach: 3 is "safely unguessable" (about 10^8 guesses
#: and more), what an online attack throttled by the login limits cannot reach.
MIN_SCORE = 3

_COMMON = frozenset(FREQUENCY_LISTS["passwords"])


def is_common(password: str) -> bool:
    """Whether ``password`` is among the common leaked passwords, or scores below
    :data:`MIN_SCORE` (``"password1234"``, ``"aaaaaaaaaaaa"``, ``"qwertyuiop12"``).

    >>> is_common("password1234"), is_common("correct horse battery")
    (True, False)
    """
    if password.lower() in _COMMON:
        return True
    return int(zxcvbn(password[:100])["score"]) < MIN_SCORE
