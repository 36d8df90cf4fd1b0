"""Whether a password or the secret key is one attackers can guess (OWASP ASVS 4.0, 2.1.7
and 2.9 / 6.2).

The judge is ``zxcvbn`` (Dropbox's estimator, Wheeler 2016, "zxcvbn: Low-Budget Password
Strength Estimation", USENIX Security; the Python port on PyPI), which ships the 30,000 most
common passwords of leaked sets, English words, names and surnames, and estimates the guesses
a secret's cheapest decomposition into dictionary words, keyboard patterns, repeats, sequences
and dates needs; a character none of those explains counts 10 guesses. Nothing is sent
anywhere: the lists are part of the package.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

from zxcvbn import matching, scoring, zxcvbn
from zxcvbn.frequency_lists import FREQUENCY_LISTS

#: zxcvbn's score (0-4) an experimenter's password must reach: 4, at least 10^10 guesses
#: ("very unguessable"), what a copy of the database's scrypt hashes does not give up in a
#: year of a GPU. 3 (10^8) let ``Summer2026!!`` through: a common word, a year (zxcvbn's
#: lists, from 2017, know years up to 2019) and two symbols.
MIN_SCORE = 4
#: Words of this site that a password should not lean on, besides the account's own.
SITE_WORDS = ("facepair", "experimenter", "prolific", "study")
#: What zxcvbn reads of a password or key: its own limit (it raises on a longer text), and it
#: slows with the square of the length.
CHECKED = 72

#: The key's least length: ``secrets.token_hex(16)``, 128 bits.
MIN_KEY_LENGTH = 32
#: The fewest guesses (log10) zxcvbn may estimate for a key: 2^80 (ASVS 2.9: a secret no one
#: can enumerate; the key signs sessions and device cookies, which an attacker can test
#: offline). A random 64-digit hex key gets about 10^60.
MIN_KEY_GUESSES_LOG10 = 24.1
#: The largest share of a key that plain dictionary words (4 letters or more) may cover: a
#: random key's words are chance ones (at most a third of 10,000 random keys of 32 to 64
#: characters), a phrase's cover most of it.
MAX_KEY_WORDS = 0.5
#: How each of zxcvbn's patterns is named in a refusal (never the key's own text).
PATTERN_NAMES = {
    "dictionary": "common words or passwords",
    "spatial": "a keyboard pattern",
    "repeat": "a repeated chunk",
    "sequence": "a sequence such as abc or 123",
    "regex": "a year",
    "date": "a date",
}
GENERATE_KEY = 'generate one with: python -c "import secrets; print(secrets.token_hex(32))"'

_COMMON = frozenset(FREQUENCY_LISTS["passwords"])


def user_words(email: str, *names: str) -> list[str]:
    """What zxcvbn should treat as known words of this account: the e-mail address, its
    parts (``alice.smith@lab.example.org`` gives alice, smith, lab, example) and the names.

    >>> user_words("alice.smith@lab.example.org")
    ['alice.smith@lab.example.org', 'alice.smith', 'alice', 'smith', 'lab', 'example']
    """
    words = [email.lower()] if email else []
    local, _, domain = email.lower().partition("@")
    if local:
        words.append(local)
    for part in re.split(r"[._+\-@]", local) + domain.split(".")[:-1]:
        if len(part) >= 3 and part not in words:
            words.append(part)
    return words + [name.lower() for name in names if name]


def is_common(password: str, user_inputs: Iterable[str] = ()) -> bool:
    """Whether ``password`` is among the common leaked passwords, or scores below
    :data:`MIN_SCORE` once the account's words (:func:`user_words`) and the site's
    (:data:`SITE_WORDS`) count as known ones.

    >>> is_common("password1234"), is_common("Summer2026!!"), is_common("correct horse battery")
    (True, True, False)
    >>> mine = user_words("alice.smith@example.org")
    >>> is_common("Alice.Smith.26"), is_common("Alice.Smith.26", mine)
    (False, True)
    """
    if password.lower() in _COMMON:
        return True
    known = [*user_inputs, *SITE_WORDS]
    return int(zxcvbn(password[:CHECKED], user_inputs=known)["score"]) < MIN_SCORE


def _matches(text: str) -> list[dict[str, Any]]:
    """zxcvbn's matches in ``text`` against its own lists alone (no account's words)."""
    ranked = dict(matching.RANKED_DICTIONARIES)
    ranked["user_inputs"] = {}
    return list(matching.omnimatch(text, ranked))


def words_share(key: str, matches: list[dict[str, Any]] | None = None) -> float:
    """The share of ``key`` (its first :data:`CHECKED` characters) that plain dictionary words
    of 4 letters or more cover, any of zxcvbn's ``matches`` counted (not reversed, not l33t: a
    random hex key is full of those).

    >>> words_share("correcthorsebatterystaple"), words_share("f3a9c1e07b24d85e")
    (1.0, 0.0)
    """
    covered: set[int] = set()
    for match in _matches(key[:CHECKED]) if matches is None else matches:
        plain = not match.get("reversed") and not match.get("l33t")
        if match["pattern"] == "dictionary" and plain and len(match["token"]) >= 4:
            covered.update(range(match["i"], match["j"] + 1))
    return len(covered) / min(len(key), CHECKED) if key else 0.0


def key_problem(key: str) -> str | None:
    """Why ``key`` (a ``SECRET_KEY``) can be guessed, in one line that says how to make one,
    or None: shorter than :data:`MIN_KEY_LENGTH`, fewer than 10^:data:`MIN_KEY_GUESSES_LOG10`
    guesses by zxcvbn (the alphabet, a keyboard row, ``0123456789abcdef`` repeated), or more
    than :data:`MAX_KEY_WORDS` of it words (``correcthorsebatterystaple``). The refusal names
    the patterns found, never the key.

    >>> print(key_problem("abcdefghijklmnopqrstuvwxyz" + "0123456789"))  # doctest: +ELLIPSIS
    guessable: a sequence such as abc or 123 (about 10^4 guesses, 10^24 needed); generate ...
    >>> key_problem("0123456789abcdef" * 4)[:52]
    'guessable: a repeated chunk (about 10^5 guesses, 10^'
    >>> key_problem("k3Q!x9#Lm2@vR7$tP4&wZ8*cN6^bH1%e") is None
    True
    """
    if len(key) < MIN_KEY_LENGTH:
        return f"shorter than {MIN_KEY_LENGTH} characters; {GENERATE_KEY}"
    text = key[:CHECKED]
    matches = _matches(text)
    found = scoring.most_guessable_match_sequence(text, matches)
    guesses = float(found["guesses_log10"])
    if guesses < MIN_KEY_GUESSES_LOG10:
        kinds = dict.fromkeys(
            PATTERN_NAMES[m["pattern"]] for m in found["sequence"] if m["pattern"] in PATTERN_NAMES
        )
        made_of = ", ".join(kinds) or "too few kinds of characters"
        return (
            f"guessable: {made_of} (about 10^{guesses:.0f} guesses, "
            f"10^{MIN_KEY_GUESSES_LOG10:.0f} needed); {GENERATE_KEY}"
        )
    share = words_share(key, matches)
    if share > MAX_KEY_WORDS:
        return f"guessable: {share:.0%} of it dictionary words; {GENERATE_KEY}"
    return None
