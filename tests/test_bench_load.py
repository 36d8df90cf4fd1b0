"""The load benchmark's inputs and the development services it shares with the tests."""

import socket

import pytest
from hypothesis import given
from hypothesis import strategies as st

from benchmarks.bench_load import participant_counts
from tests.support.services import port_open, wait_for_port


def test_participant_counts():
    assert participant_counts("200,500,1000") == [200, 500, 1000]
    assert participant_counts(" 7") == [7]
    for bad in ("", "0", "-5", "200,,500", "a lot", "1e3", "200000"):
        with pytest.raises(ValueError, match="^--participants: "):
            participant_counts(bad)


@given(st.text(max_size=40))
def test_any_participants_text_is_counts_or_one_line(text):
    try:
        counts = participant_counts(text)
    except ValueError as exc:
        assert str(exc).startswith("--participants: ") and "\n" not in str(exc)
    else:
        assert counts and all(0 < n <= 100_000 for n in counts)


def test_port_open_and_wait_for_port():
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen()
        port = listener.getsockname()[1]
        assert port_open(port) and wait_for_port(port, 1)
    assert not port_open(port)
    assert not wait_for_port(port, 0.3)
