"""Fixtures shared by several test packages: the repository, the GPU marker, test WAVs and the
web (databases, app, client, participants, live server). Each package's own fixtures live in its
conftest.py (tests/analysis, tests/stimuli, tests/renderer, tests/trials). Warnings are errors
(pyproject)."""

from __future__ import annotations

import copy
import os
import re
import secrets
import shutil
import subprocess
import textwrap
import wave
from pathlib import Path

import pytest
from flask import Flask

from tests.support.services import (
    PG_DATABASE_PREFIX,
    PG_HOST,
    PG_PORT,
    REDIS_PORT,
    ensure_services,
    redis_databases,
)
from tests.support.waits import WaitingBrowser

REPO = Path(__file__).resolve().parent.parent
#: The test experimenters' password, one that the password policy accepts
#: (app.web.infra.passwords: zxcvbn score 4); every test that logs in uses this one.
PASSWORD = "violet kettle harbour lantern"


@pytest.fixture
def repo_root() -> Path:
    return REPO


def pytest_collection_modifyitems(config, items):
    """Modules with ``slow`` or ``browser`` tests first, each module's tests kept together and in
    their order. ``make test`` hands whole modules to its processes in this order
    (``--dist loadscope --no-loadscope-reorder``): the long modules start early and the short
    ones fill the end, so no process is left alone with a minute of work while the others
    idle. xdist's own order (most tests first) sent one-test modules such as the chaos check
    last."""
    heavy = {
        item.path
        for item in items
        if item.get_closest_marker("slow") is not None
        or item.get_closest_marker("browser") is not None
    }
    items.sort(key=lambda item: item.path not in heavy)  # stable: modules stay contiguous


def pytest_runtest_setup(item):
    """Skip ``gpu`` tests where frames would be drawn on a CPU rasteriser (or not at all)."""
    if item.get_closest_marker("gpu") is None:
        return
    from renderer.gl import GLUnavailable, device_name, is_software

    try:
        name = device_name()
    except GLUnavailable:
        pytest.skip("no OpenGL context")
    if is_software(name):
        pytest.skip(f"no GPU: EGL draws on {name}")


@pytest.fixture
def tone_wav(tmp_path: Path):
    """Factory: ``tone_wav(seconds)`` -> path of a fresh test WAV."""
    return lambda seconds: write_tone_wav(tmp_path / f"tone_{seconds}.wav", seconds)


# --- browsers ----------------------------------------------------------------------------------

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-dev-shm-usage",
    "--disable-background-networking",
    "--autoplay-policy=no-user-gesture-required",
]


@pytest.fixture(scope="session")
def browser():
    """Debian's chromium through Playwright, started once per test process (a start and stop
    cost about a second of CPU). Each test opens its own context, with cookies, storage and
    cache of its own, and closes it; a context waits at most ``tests.support.waits.WAIT_S``."""
    if not CHROMIUM.exists():
        pytest.skip("Debian's chromium is not installed (make test installs it)")
    from playwright.sync_api import sync_playwright

    manager = sync_playwright().start()
    try:
        browser = manager.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield WaitingBrowser(browser)
        finally:
            browser.close()
    finally:
        manager.stop()


@pytest.fixture
def shots(tmp_path) -> Path:
    """Where a browser test saves its screenshots: ``$FACEPAIR_SCREENSHOTS`` or the test's
    temporary folder."""
    folder = Path(os.environ.get("FACEPAIR_SCREENSHOTS", tmp_path / "shots"))
    folder.mkdir(parents=True, exist_ok=True)
    return folder


# --- web: databases, app, client, participants ---------------------------------------------
# Every web test runs on SQLite (a file) and on the real PostgreSQL (a throwaway database per
# run, so parallel runs never collide). The schema comes from the migrations, as in production.


@pytest.fixture(scope="session")
def postgres_url():
    """A fresh PostgreSQL database for this run, dropped at the end."""
    ensure_services()
    import psycopg

    name = f"{PG_DATABASE_PREFIX}_{secrets.token_hex(4)}"
    try:
        admin = psycopg.connect(
            f"host={PG_HOST} port={PG_PORT} user=postgres dbname=postgres", autocommit=True
        )
    except psycopg.OperationalError as exc:
        pytest.skip(f"PostgreSQL is not reachable on {PG_HOST}:{PG_PORT}: {exc}")
    with admin:
        admin.execute(f'CREATE DATABASE "{name}"')
        try:
            yield f"postgresql+psycopg://postgres@{PG_HOST}:{PG_PORT}/{name}"
        finally:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@pytest.fixture(scope="session")
def redis_url():
    """The local Redis, on this process's own database (``redis_databases``: 15 unless the
    environment says otherwise), flushed before use; or skip."""
    ensure_services()
    from redis import Redis
    from redis.exceptions import RedisError

    url = f"redis://127.0.0.1:{REDIS_PORT}/{redis_databases()[0]}"
    try:
        Redis.from_url(url, socket_connect_timeout=1).flushdb()
    except RedisError as exc:
        pytest.skip(f"Redis is not reachable on port {REDIS_PORT}: {exc}")
    return url


@pytest.fixture(scope="session")
def sqlite_url(tmp_path_factory):
    return f"sqlite:///{tmp_path_factory.mktemp('sqlite') / 'facepair.sqlite'}"


_MIGRATED: set[str] = set()


def make_app(url: str, media: Path, **config):
    from app.web import create_app

    return create_app(
        {
            "TESTING": True,
            "SECRET_KEY": "test-secret",
            "SQLALCHEMY_DATABASE_URI": url,
            "MEDIA_ROOT": str(media),
            "JOB_RUNNER": "inline",
            "REDIS_URL": None,
            # one PBKDF2 round: production's scrypt costs 0.1 s a hash, paid for every
            # experimenter a test makes and at every login
            # (tests/web/infra/test_security.py keeps it)
            "PASSWORD_HASH_METHOD": "pbkdf2:sha256:1",
            **config,
        }
    )


def upgrade_database(url: str, media: Path) -> None:
    """``flask db upgrade`` on ``url`` (once per database and run)."""
    if url in _MIGRATED:
        return
    from flask_migrate import upgrade

    app = make_app(url, media)
    with app.app_context():
        upgrade()
        from app.web.extensions import db

        db.engine.dispose()
    _MIGRATED.add(url)


def wipe_database(app) -> None:
    from app.web.extensions import db

    with app.app_context():
        db.session.remove()
        with db.engine.begin() as conn:
            for table in reversed(db.metadata.sorted_tables):
                conn.execute(table.delete())
        db.engine.dispose()


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
def database_url(request) -> str:
    return request.getfixturevalue(f"{request.param}_url")


#: One application per database and test process (building one costs about 0.1-0.2 s, mostly
#: werkzeug compiling the routes), with its configuration as made.
_APPS: dict[str, tuple[Flask, dict]] = {}


@pytest.fixture
def app(database_url, tmp_path):
    """The backend's application, made once per test process and lent to each test as made:
    its configuration restored afterwards, its own media folder, empty tables and fresh
    rate-limit counters. A test that changes the application itself (its hooks, its WSGI
    chain) takes :func:`fresh_app`."""
    upgrade_database(database_url, tmp_path / "media")
    if database_url not in _APPS:
        made = make_app(database_url, tmp_path / "media")
        _APPS[database_url] = (made, dict(made.config))
    app, config = _APPS[database_url]
    app.config.update(copy.deepcopy(config), MEDIA_ROOT=str(tmp_path / "media"))
    from app.web.extensions import limiter

    with app.app_context():
        limiter.reset()
    try:
        yield app
    finally:
        wipe_database(app)
        for key in set(app.config) - set(config):
            del app.config[key]


@pytest.fixture
def fresh_app(database_url, tmp_path):
    """An application of its own, for a test that changes the application object itself."""
    upgrade_database(database_url, tmp_path / "media")
    app = make_app(database_url, tmp_path / "media")
    try:
        yield app
    finally:
        wipe_database(app)


@pytest.fixture
def client(app):
    return app.test_client()


@pytest.fixture
def runner(app):
    return app.test_cli_runner()


def csrf_token(client, url: str) -> str:
    """The CSRF token of the form on ``url`` (every form carries one)."""
    page = client.get(url).get_data(as_text=True)
    found = re.search(r'name="csrf_token"[^>]*value="([^"]+)"', page) or re.search(
        r'id="[^"]*csrf_token"[^>]*value="([^"]+)"', page
    )
    assert found, f"no CSRF token on {url}"
    return found.group(1)


def write_tone_wav(path: Path, seconds: float = 0.5, rate: int = 16000) -> Path:
    import numpy as np

    t = np.arange(int(seconds * rate)) / rate
    samples = (0.2 * np.sin(2 * np.pi * 220 * t) * 32767).astype("<i2")
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(samples.tobytes())
    return path


def make_clip(
    path: Path, seconds: float = 0.6, size: str = "128x64", bitrate: str | None = None
) -> Path:
    """An H.264 + AAC test-pattern clip in the stimuli's format (streamable: +faststart)."""
    import imageio_ffmpeg

    rate = ["-b:v", bitrate] if bitrate else []
    subprocess.run(
        [
            imageio_ffmpeg.get_ffmpeg_exe(),
            "-v",
            "error",
            "-f",
            "lavfi",
            "-i",
            f"testsrc=size={size}:rate=25",
            "-f",
            "lavfi",
            "-i",
            "sine=frequency=440",
            "-t",
            str(seconds),
            "-c:v",
            "libx264",
            *rate,
            "-pix_fmt",
            "yuv420p",
            "-c:a",
            "aac",
            "-shortest",
            "-movflags",
            "+faststart",
            str(path),
        ],
        check=True,
    )
    return path


@pytest.fixture(scope="session")
def tiny_video(tmp_path_factory) -> Path:
    """A 0.6 s clip, the stand-in for a rendered side-by-side stimulus."""
    return make_clip(tmp_path_factory.mktemp("video") / "tiny.mp4")


@pytest.fixture(scope="session")
def tiny_webm(tiny_video, tmp_path_factory) -> Path:
    """The tiny clip's WebM rendition (VP9 + Opus), as the render job makes one."""
    from renderer.encode import write_webm

    return write_webm(tiny_video, tmp_path_factory.mktemp("webm") / "tiny.webm")


STUDY_TOML = """
title = "Test study"
question = "Which face moves more naturally?"
instructions = "Watch both faces."
consent = "You agree to take part."
design = "{design}"
seed = 11
completion_code = "DONE-123"
redirect_url = "https://example.org/complete?cc=DONE-123"
{extra}
[undecided]
allowed = {undecided}
label = "Cannot decide"

[replay]
policy = "{replay}"
{max_plays}
[catch]
trials = {catch}
kind = "{catch_kind}"

[[conditions]]
name = "none"
model = "none"

[[conditions]]
name = "random"
model = "random"

[[clips]]
name = "s1"
audio = "s1.wav"
"""


def study_toml(
    *,
    design: str = "unordered_counterbalanced",
    replay: str = "unlimited",
    max_plays: int | None = None,
    catch: int = 0,
    catch_kind: str = "identical",
    undecided: bool = True,
    extra: str = "",
) -> str:
    return textwrap.dedent(STUDY_TOML).format(
        design=design,
        replay=replay,
        catch=catch,
        catch_kind=catch_kind,
        undecided=str(undecided).lower(),
        max_plays=f"max_plays = {max_plays}" if max_plays else "",
        extra=extra,
    )


def create_test_user(email: str = "exp@example.org", password: str = PASSWORD):
    from app.web.extensions import db
    from app.web.infra.accounts import create_user

    user = create_user(email, password)
    db.session.commit()
    return user


def create_test_study(
    app,
    tmp_path: Path,
    video: Path | None,
    *,
    owner_email: str = "exp@example.org",
    status: str = "open",
    webm: Path | None = None,
    **toml,
) -> int:
    """A study from a TOML file; with ``video`` every stimulus 'rendered' as that file (and
    with ``webm`` given that file as its WebM rendition)."""
    import sqlalchemy as sa

    from app.trials.studyfile import loads_study
    from app.web.extensions import db
    from app.web.infra.storage import media_dir
    from app.web.models import Stimulus, User
    from app.web.study.studies import create_study

    folder = tmp_path / f"study-src-{secrets.token_hex(3)}"
    folder.mkdir()
    write_tone_wav(folder / "s1.wav")
    text = study_toml(**toml)
    with app.app_context():
        owner = db.session.scalar(sa.select(User).where(User.email == owner_email))
        if owner is None:
            owner = create_test_user(owner_email)
        study = create_study(owner, loads_study(text, base_dir=folder), source_toml=text)
        if video is not None:
            for stimulus in db.session.scalars(
                sa.select(Stimulus).where(Stimulus.study_id == study.id)
            ):
                rel = f"videos/{stimulus.id}.mp4"
                (media_dir(study) / "videos").mkdir(parents=True, exist_ok=True)
                shutil.copyfile(video, media_dir(study) / rel)
                stimulus.video_path = rel
                if webm is not None:
                    shutil.copyfile(webm, media_dir(study) / f"videos/{stimulus.id}.webm")
                    stimulus.webm_path = f"videos/{stimulus.id}.webm"
            study.status = status
        db.session.commit()
        return study.id


class ParticipantActions:
    """What a participant's browser does, through the test client."""

    def __init__(self, client, app) -> None:
        self.client, self.app = client, app
        self.token: str | None = None

    def join(self, slug: str, query: str = "") -> str:
        url = f"/s/{slug}" + (f"?{query}" if query else "")
        page = self.client.get(url)
        assert page.status_code == 200, page.status_code
        token = csrf_token(self.client, url)
        data = {"csrf_token": token, "agree": "1"}
        for key, value in (p.split("=") for p in query.split("&") if p):
            data[key] = value
        response = self.client.post(f"/s/{slug}", data=data)
        assert response.status_code == 302, response.get_data(as_text=True)
        self.token = response.headers["Location"].split("/p/")[1].split("/")[0]
        return self.token

    def join_pilot(self, pilot_token: str) -> str:
        """Through the pilot link's consent page, as a pilot participant."""
        url = f"/experimenter/pilot/{pilot_token}"
        page = self.client.get(url)
        assert page.status_code == 200 and "I agree" in page.get_data(as_text=True)
        response = self.client.post(url, data={"csrf_token": csrf_token(self.client, url)})
        assert response.status_code == 302, response.get_data(as_text=True)
        self.token = response.headers["Location"].split("/p/")[1].split("/")[0]
        return self.token

    def current_trial(self) -> int | None:
        response = self.client.get(f"/p/{self.token}/trial")
        if response.status_code == 302:
            return None
        found = re.search(r'data-trial-id="(\d+)"', response.get_data(as_text=True))
        assert found
        return int(found.group(1))

    def vote(
        self,
        trial_id: int,
        choice: str = "left",
        *,
        key: str | None = None,
        plays: int = 1,
        **extra,
    ):
        payload = {
            "token": self.token,
            "trial_id": trial_id,
            "choice": choice,
            "plays": plays,
            "watched_to_end": True,
            "response_ms": 1234,
            "presented_at": "2026-01-01T10:00:00.000Z",
            "idempotency_key": key or secrets.token_hex(8),
            **extra,
        }
        return self.client.post("/api/v1/votes", json=payload)


@pytest.fixture
def participant(client, app) -> ParticipantActions:
    return ParticipantActions(client, app)


def login(client, email: str = "exp@example.org", password: str = PASSWORD):
    token = csrf_token(client, "/experimenter/login")
    return client.post(
        "/experimenter/login", data={"csrf_token": token, "email": email, "password": password}
    )


@pytest.fixture
def web(app, tmp_path, tiny_video):
    """Helpers for web tests: ``web.study(**toml)`` (a rendered, open study by default),
    ``web.user()``, ``web.login(client)``, ``web.csrf(client, url)``."""
    from types import SimpleNamespace

    def study(video: bool = True, **toml) -> int:
        return create_test_study(app, tmp_path, tiny_video if video else None, **toml)

    def user(email: str = "exp@example.org", password: str = PASSWORD):
        with app.app_context():
            return create_test_user(email, password).id

    return SimpleNamespace(
        study=study,
        user=user,
        login=login,
        csrf=csrf_token,
        write_wav=write_tone_wav,
        toml=study_toml,
        tiny_video=tiny_video,
    )


@pytest.fixture(scope="session")
def migrated_sqlite(tmp_path_factory) -> Path:
    """A SQLite file the migrations brought to the schema, once per test process: a live
    server starts on a copy (a millisecond, where the migrations cost 0.2 s of CPU)."""
    path = tmp_path_factory.mktemp("migrated") / "migrated.sqlite"
    upgrade_database(f"sqlite:///{path}", path.parent / "media")
    return path


@pytest.fixture
def live_server(tmp_path, tiny_video, migrated_sqlite):
    """A threaded server on a migrated, file-backed SQLite database (never in-memory), for
    browser tests: ``live.url``, ``live.app``, ``live.study(**toml)``."""
    from types import SimpleNamespace

    from tests.support.liveserver import serve

    shutil.copyfile(migrated_sqlite, tmp_path / "live.sqlite")
    url = f"sqlite:///{tmp_path / 'live.sqlite'}"
    app = make_app(url, tmp_path / "media")
    try:
        with serve(app) as base:
            yield SimpleNamespace(
                app=app,
                url=base,
                study=lambda video=True, **toml: create_test_study(
                    app, tmp_path, tiny_video if video else None, **toml
                ),
                user=lambda: _in_context(app, create_test_user),
                write_wav=write_tone_wav,
                toml=study_toml,
            )
    finally:
        from app.web.extensions import db

        with app.app_context():
            db.engine.dispose()


def _in_context(app, function, *args):
    with app.app_context():
        return function(*args).id


@pytest.fixture
def stub_pipeline(monkeypatch, tiny_video):
    """Generation and rendering stand-ins for browser tests (the real pipeline is tested in
    its own packages; there only the web's wiring): every stimulus 'rendered' as the tiny
    video, the study then ready."""
    import sqlalchemy as sa

    from app.web.extensions import db
    from app.web.infra.storage import media_dir
    from app.web.jobs import bodies
    from app.web.models import Stimulus

    def fake_generate(study, progress):
        progress(1, 1)
        return "tracks: stub"

    def fake_render(study, progress):
        rows = db.session.scalars(sa.select(Stimulus).where(Stimulus.study_id == study.id)).all()
        for i, stimulus in enumerate(rows):
            progress(i, len(rows))
            stimulus.video_path = f"videos/{stimulus.id}.mp4"
            (media_dir(study) / "videos").mkdir(exist_ok=True)
            shutil.copyfile(tiny_video, media_dir(study) / stimulus.video_path)
        study.status = "ready"
        db.session.commit()
        return f"{len(rows)} clips rendered (stub)"

    monkeypatch.setitem(bodies.TASKS, "generate", fake_generate)
    monkeypatch.setitem(bodies.TASKS, "render", fake_render)
