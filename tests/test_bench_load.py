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


def test_cpu_used_counts_each_process_from_its_own_start():
    from benchmarks.bench_load import cpu_used

    before = {"server": {10: 1.0, 11: 2.0}, "postgres": {20: 5.0}, "generator": {1: 0.5}}
    # 11 ended, 12 started (a restarted worker), a new backend 21 appeared.
    after = {"server": {10: 1.5, 12: 0.25}, "postgres": {20: 5.5, 21: 0.1}, "generator": {1: 0.75}}
    used = cpu_used(before, after)
    assert used == pytest.approx({"server": 0.75, "postgres": 0.6, "generator": 0.25})


def test_only_the_benchmarks_own_database_backends_count_as_postgresql(postgres_url):
    """A backend of another database (the admin connection's) is not the server's."""
    import os

    import psycopg

    from benchmarks.bench_load import CpuMeter

    dsn = postgres_url.replace("postgresql+psycopg://", "postgresql://")
    name = dsn.rsplit("/", 1)[1]
    admin_dsn = dsn.rsplit("/", 1)[0] + "/postgres"
    with psycopg.connect(admin_dsn, autocommit=True) as admin, psycopg.connect(dsn) as ours:
        ours_pid = ours.execute("SELECT pg_backend_pid()").fetchone()[0]
        admin_pid = admin.execute("SELECT pg_backend_pid()").fetchone()[0]
        seen = CpuMeter(os.getppid(), admin, name).read()
    assert ours_pid in seen["postgres"] and admin_pid not in seen["postgres"]
    assert os.getpid() in seen["generator"]


def test_database_url_follows_the_connection_string():
    from benchmarks.bench_load import database_url

    assert (
        database_url("host=db.local port=6543 user=bench", "x")
        == "postgresql+psycopg://bench@db.local:6543/x"
    )
    assert database_url("host=127.0.0.1", "y") == "postgresql+psycopg://postgres@127.0.0.1:5432/y"


def test_a_counted_round_lasts_at_least_the_seconds_asked_at_the_warm_up_rate():
    from benchmarks.bench_load import round_size

    assert round_size(100.0, 10.0, 18) == 1500  # half again over 100/s x 10 s
    assert round_size(1.0, 10.0, 2160) == 2160


def test_capacity_is_the_largest_count_under_the_p99_and_the_cpu_bound():
    from benchmarks.bench_load import OpenRun, capacity_lines

    runs = [OpenRun(200, 40.0, 4.0, 2.0), OpenRun(500, 150.0, 4.0, 2.0), OpenRun(1000, 900.0, 5, 1)]
    lines = capacity_lines(runs, think=6.0, cores=2)
    # 6 ms a trial every 6 s: two cores (12,000 ms a 6 s) serve 2,000 participants.
    assert "CPU per trial 6.0 ms" in lines[0] and "about 2000 participants" in lines[0]
    assert lines[-1].startswith("largest count run with steady vote p99 < 200 ms: 500 ")
    assert capacity_lines([OpenRun(10, None, 0, 0)], 6.0, 2)[-1].split(": ")[1].startswith("none")
