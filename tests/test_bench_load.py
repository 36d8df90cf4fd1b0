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


def test_the_steady_state_is_the_requests_sent_while_nearly_everyone_was_present():
    from benchmarks.load_clients import Tally

    tally = Tally()
    # Arrivals (1, 2 ... 10 present), a plateau at 10 with slow answers, departures.
    for present, ms, at in (
        [(n, 5.0, float(n)) for n in range(1, 10)]
        + [(10, 300.0, 10.0 + i) for i in range(20)]
        + [(n, 5.0, 40.0 - n) for n in range(9, 0, -1)]
    ):
        tally.peak = max(tally.peak, present)
        tally.latency("vote", ms, at, present)
    assert tally.summary("vote").startswith("38, ")  # every request
    assert tally.summary("vote", 0.95) == "20, p50 300.0 ms, p99 300.0 ms, max 300.0 ms"
    assert tally.window(0.95) == 19.0
    # 90 % of 10 lets in the 9 present on the way up and down.
    assert tally.summary("vote", 0.9).startswith("22, ")
    assert Tally().summary("vote", 0.95) == "none" and Tally().window(0.95) == 0.0


def test_the_ab_benchmark_takes_only_facepair_checkouts(tmp_path):
    from pathlib import Path

    from benchmarks.bench_ab import checkout

    root = Path(__file__).resolve().parent.parent
    assert checkout(str(root / "tests" / "..")) == root
    with pytest.raises(ValueError, match=r": not a facepair checkout \(no app/__main__\.py\)$"):
        checkout(str(tmp_path))
