"""Asynchronous load generator for ``bench_load.py``: open-loop participants and a saturating
vote sender, one asyncio loop and one shared connection pool instead of a thread each.

Open loop (:func:`open_loop`): participants arrive as a Poisson process at a given rate, each
consents, loads the trial page, and for each trial asks for a play (``/api/v1/plays``, as the
browser does before the clip starts), watches the clip for ``think`` seconds and posts the vote,
whose answer carries the next pair: as in the browser, a trial page is loaded again only when
an answer does not carry one. One vote in ten is posted twice with the same idempotency key (a
retried request) and one in twenty a third time with a new key (a double click). A vote that
times out or fails is sent again with the same key, as the browser does, up to three times.
Unlike a closed loop, the request rate is set by the participants, not by how fast the server
answers.

Saturated (:func:`saturate`): ``concurrency`` senders post prepared JSON bodies back to back;
the same function drives facepair's vote endpoint and the bare baseline's.
"""

from __future__ import annotations

import asyncio
import json
import re
import secrets
import time
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlencode

import aiohttp
import numpy as np
from tqdm import tqdm

CONSENT_TOKEN = re.compile(r'name="csrf_token"[^>]*value="([^"]+)"')
TRIAL_ID = re.compile(r'data-trial-id="(\d+)"')
VOTE_ATTEMPTS = 3


@dataclass
class Tally:
    """What the clients saw: latencies per request kind, statuses, errors, acknowledged votes."""

    ms: dict[str, list[float]] = field(default_factory=dict)
    statuses: dict[int, int] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    #: trial id -> the choice the server acknowledged (200 or 201) for it.
    acknowledged: dict[int, str] = field(default_factory=dict)
    active: int = 0
    peak: int = 0
    finished: int = 0
    #: Votes answered with an earlier vote's other choice for the same trial (first one kept).
    superseded: int = 0
    #: Votes answered so far, shown while the run lasts (on stderr).
    bar: tqdm | None = None

    #: Per request kind, (time.perf_counter(), participants present) when each
    #: request of ``ms`` was sent.
    sent: dict[str, list[tuple[float, int]]] = field(default_factory=dict)

    def latency(self, kind: str, ms: float, sent_at: float = 0.0, present: int = 0) -> None:
        self.ms.setdefault(kind, []).append(ms)
        self.sent.setdefault(kind, []).append((sent_at, present))

    def values(self, kind: str, share: float = 0.0) -> np.ndarray:
        """The latencies (ms) of ``kind``; with ``share``, of the requests sent while at least
        that share of the peak were present (the steady state, not the arrivals and
        departures)."""
        values = np.asarray(self.ms.get(kind, []))
        if share:
            present = np.asarray([n for _, n in self.sent.get(kind, [])])
            values = values[present >= share * self.peak] if values.size else values
        return values

    def p99(self, kind: str, share: float = 0.0) -> float | None:
        """The 99th percentile of :meth:`values` in ms, None when there are none."""
        values = self.values(kind, share)
        return float(np.percentile(values, 99)) if values.size else None

    def summary(self, kind: str, share: float = 0.0) -> str:
        """Count, p50, p99 and max of :meth:`values`."""
        values = self.values(kind, share)
        if values.size == 0:
            return "none"
        return (
            f"{values.size}, p50 {np.percentile(values, 50):.1f} ms, "
            f"p99 {np.percentile(values, 99):.1f} ms, max {values.max():.1f} ms"
        )

    def window(self, share: float) -> float:
        """Seconds between the first and last request sent while at least ``share`` of the
        peak were present."""
        times = [t for sent in self.sent.values() for t, n in sent if n >= share * self.peak]
        return max(times) - min(times) if times else 0.0


def new_session(timeout_s: float, connections: int) -> aiohttp.ClientSession:
    """One pool for every simulated participant; cookies are kept per participant by hand.

    Idle connections are dropped after 1 s, before gunicorn's 2 s keep-alive closes them:
    otherwise a vote after a clip goes out on a connection the server is closing (a reset
    that a browser would retry unseen)."""
    return aiohttp.ClientSession(
        timeout=aiohttp.ClientTimeout(total=timeout_s),
        connector=aiohttp.TCPConnector(limit=connections, keepalive_timeout=1.0),
        cookie_jar=aiohttp.DummyCookieJar(),
    )


async def _request(
    session: aiohttp.ClientSession,
    tally: Tally,
    kind: str,
    method: str,
    url: str,
    cookies: dict[str, str],
    **kwargs: Any,
) -> tuple[int, dict[str, str], str] | None:
    """One request; its latency is recorded under ``kind``; None (an error counted) when it
    timed out or the connection failed."""
    headers = dict(kwargs.pop("headers", {}))
    if cookies:
        headers["Cookie"] = "; ".join(f"{k}={v}" for k, v in cookies.items())
    start, present = time.perf_counter(), tally.active
    try:
        async with session.request(
            method, url, headers=headers, allow_redirects=False, **kwargs
        ) as response:
            body = await response.text()
            for value in response.headers.getall("Set-Cookie", []):
                key, _, rest = value.partition("=")
                cookies[key] = rest.split(";", 1)[0]
            status, head = response.status, {k.lower(): v for k, v in response.headers.items()}
    except (TimeoutError, aiohttp.ClientError) as exc:
        tally.errors.append(f"{kind}: {type(exc).__name__} {exc}".strip())
        return None
    tally.latency(kind, (time.perf_counter() - start) * 1e3, start, present)
    tally.statuses[status] = tally.statuses.get(status, 0) + 1
    if status >= 500:
        tally.errors.append(f"{kind}: HTTP {status}")
    return status, head, body


async def consent(
    session: aiohttp.ClientSession, base: str, slug: str, tally: Tally
) -> tuple[str, dict[str, str]]:
    """Open the study link and consent; returns the participant's token and cookies."""
    cookies: dict[str, str] = {}
    link = f"{base}/s/{slug}?PROLIFIC_PID=load{secrets.token_hex(6)}&STUDY_ID=load&SESSION_ID=s"
    answer = await _request(session, tally, "consent", "GET", link, cookies)
    token = CONSENT_TOKEN.search(answer[2]) if answer else None
    if answer is None or answer[0] != 200 or token is None:
        raise RuntimeError(f"consent page: {answer[0] if answer else 'no answer'}")
    form = urlencode({"csrf_token": token.group(1), "agree": "1"})
    answer = await _request(
        session,
        tally,
        "consent",
        "POST",
        link,
        cookies,
        data=form,
        headers={"Content-Type": "application/x-www-form-urlencoded"},
    )
    if answer is None or answer[0] != 302:
        raise RuntimeError(f"consent: {answer[0] if answer else 'no answer'}")
    return answer[1]["location"].split("/p/")[1].split("/")[0], cookies


def vote_body(token: str, trial: int, choice: str, key: str, response_ms: int) -> bytes:
    return json.dumps(
        {
            "token": token,
            "trial_id": trial,
            "choice": choice,
            "plays": 1,
            "watched_to_end": True,
            "response_ms": response_ms,
            "idempotency_key": key,
        }
    ).encode()


async def _vote(
    session: aiohttp.ClientSession, base: str, tally: Tally, cookies: dict[str, str], body: bytes
) -> tuple[int | None, str | None]:
    """Post one vote, resent with the same body after a timeout or a 5xx (the browser keeps
    it); returns the final status (None if no attempt got an answer) and the server's answer
    when it holds the vote (with the choice it holds for the trial, and the next pair)."""
    status = None
    for _ in range(VOTE_ATTEMPTS):
        answer = await _request(
            session,
            tally,
            "vote",
            "POST",
            f"{base}/api/v1/votes",
            cookies,
            data=body,
            headers={"Content-Type": "application/json"},
        )
        status = answer[0] if answer else None
        if answer is not None and status in (200, 201):
            return status, json.loads(answer[2])
        if status is not None and status < 500:
            return status, None
    return status, None


async def take_part(
    session: aiohttp.ClientSession,
    base: str,
    slug: str,
    tally: Tally,
    *,
    think: float,
    trials: int,
    rng: np.random.Generator,
) -> None:
    """One participant's browser: consent, then play, clip, vote per trial, with a trial
    page where the browser loads one: for the first pair, and whenever a vote's answer does
    not carry the next pair (``static/pair.js``)."""
    tally.active += 1
    tally.peak = max(tally.peak, tally.active)
    try:
        token, cookies = await consent(session, base, slug, tally)
        trial: int | None = None  # the pair the last vote's answer carried
        for _ in range(trials):
            if trial is None:
                answer = await _request(
                    session, tally, "page", "GET", f"{base}/p/{token}/trial", cookies
                )
                if answer is None:
                    continue  # the participant reloads the page
                if answer[0] == 302:
                    break  # all trials answered
                found = TRIAL_ID.search(answer[2])
                if answer[0] != 200 or found is None:
                    raise RuntimeError(f"trial page: HTTP {answer[0]}")
                trial = int(found.group(1))
            await _request(
                session,
                tally,
                "play",
                "POST",
                f"{base}/api/v1/plays",
                cookies,
                json={"token": token, "trial_id": trial},
            )
            await asyncio.sleep(think * rng.uniform(0.9, 1.1))
            choice = str(rng.choice(["left", "right", "undecided"]))
            key = secrets.token_hex(8)
            keys = (
                [key]
                + ([key] if rng.random() < 0.1 else [])
                + ([secrets.token_hex(8)] if rng.random() < 0.05 else [])
            )
            if tally.bar is not None:
                tally.bar.update()
            carried: Any = "unknown"  # the next pair, if an answer carried it (null: done)
            for k in keys:
                status, body = await _vote(
                    session,
                    base,
                    tally,
                    cookies,
                    vote_body(token, trial, choice, k, int(rng.integers(800, 4000))),
                )
                if body is not None:
                    stored = body["vote"]["choice"]
                    # Another choice: a vote on this trial whose answer timed out was stored
                    # first, and the page shown again before it was committed; it is kept.
                    tally.superseded += stored != choice
                    tally.acknowledged[trial] = stored
                    carried = body.get("next_trial", "unknown")
                elif status is not None:
                    raise RuntimeError(f"vote: HTTP {status}")
            if carried is None:
                break  # all trials answered
            trial = carried["trial_id"] if isinstance(carried, dict) else None
        tally.finished += 1
    except RuntimeError as exc:
        tally.errors.append(str(exc))
    finally:
        tally.active -= 1


async def open_loop(
    base: str,
    slug: str,
    participants: int,
    *,
    rate: float,
    think: float,
    trials: int,
    timeout: float,
    seed: int = 0,
) -> tuple[Tally, float]:
    """``participants`` arriving at ``rate`` per second (Poisson); returns the tally and the
    seconds from the first arrival to the last vote."""
    rng = np.random.default_rng(seed)
    tally = Tally(
        bar=tqdm(
            total=participants * trials,
            desc=f"{participants} participants",
            unit="vote",
            leave=False,
        )
    )
    async with new_session(timeout, participants + 16) as session:
        start = time.perf_counter()
        tasks = []
        for _ in range(participants):
            tasks.append(
                asyncio.create_task(
                    take_part(
                        session,
                        base,
                        slug,
                        tally,
                        think=think,
                        trials=trials,
                        rng=np.random.default_rng(rng.integers(2**32)),
                    )
                )
            )
            await asyncio.sleep(rng.exponential(1 / rate))
        await asyncio.gather(*tasks)
        tally.bar.close()
        return tally, time.perf_counter() - start


async def saturate(
    url: str, bodies: list[tuple[int, str, bytes]], *, concurrency: int, timeout: float
) -> tuple[Tally, float]:
    """Post every ``(trial, choice, body)`` to ``url`` from ``concurrency`` senders, each
    sending its next as soon as the last is answered; returns the tally and the seconds."""
    tally = Tally(bar=tqdm(total=len(bodies), desc="saturated", unit="vote", leave=False))
    queue = list(reversed(bodies))

    async def sender(session: aiohttp.ClientSession) -> None:
        while queue:
            trial, choice, body = queue.pop()
            answer = await _request(
                session,
                tally,
                "vote",
                "POST",
                url,
                {},
                data=body,
                headers={"Content-Type": "application/json"},
            )
            if answer is not None and answer[0] in (200, 201):
                tally.acknowledged[trial] = choice
            tally.bar.update()  # type: ignore[union-attr]

    async with new_session(timeout, concurrency) as session:
        start = time.perf_counter()
        await asyncio.gather(*(sender(session) for _ in range(concurrency)))
        tally.bar.close()  # type: ignore[union-attr]
        return tally, time.perf_counter() - start


async def consent_many(base: str, slug: str, participants: int, *, timeout: float) -> list[str]:
    """Enrol ``participants`` through the consent form (32 at a time); returns their tokens."""
    tally = Tally()
    limit = asyncio.Semaphore(32)
    async with new_session(timeout, 32) as session:

        async def one() -> str:
            async with limit:
                return (await consent(session, base, slug, tally))[0]

        return list(await asyncio.gather(*(one() for _ in range(participants))))
