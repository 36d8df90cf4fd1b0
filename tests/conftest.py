"""Shared fixtures. Warnings are errors (pyproject); each area adds its fixtures here."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def repo_root() -> Path:
    return REPO


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


# --- analysis -------------------------------------------------------------------------------

ANALYSIS_DATA = REPO / "tests" / "analysis" / "data"


@pytest.fixture
def analysis_data() -> Path:
    """Published paired-comparison matrices (tests/analysis/data/README.md)."""
    return ANALYSIS_DATA


def votes_from_matrix(counts, names=None, clip="c1"):
    """A votes frame whose pooled preference counts equal ``counts`` (rows beat columns).

    Judge k of a pair (i, j) is participant ``J{k}``; sides alternate so both orders occur.
    """
    import numpy as np
    import pandas as pd

    counts = np.asarray(counts, dtype=int)
    n = counts.shape[0]
    names = names or [f"c{i:02d}" for i in range(n)]
    rows = []
    for i in range(n):
        for j in range(i + 1, n):
            judges = ["i"] * counts[i, j] + ["j"] * counts[j, i]
            for k, winner in enumerate(judges):
                left, right = (i, j) if k % 2 == 0 else (j, i)
                chosen = i if winner == "i" else j
                rows.append({"participant": f"J{k:03d}", "clip": clip, "left": names[left],
                             "right": names[right],
                             "choice": "left" if chosen == left else "right"})
    return pd.DataFrame(rows)


@pytest.fixture
def matrix_votes():
    return votes_from_matrix
# -- stimuli ---------------------------------------------------------------------------------
def harmonic_glide(f_start: float, f_end: float, seconds: float, sr: int = 16000,
                   amplitude: float = 0.2, n_harmonics: int = 5):
    """A voiced-like harmonic signal whose F0 glides linearly; returns (samples, f0 of time)."""
    import numpy as np

    t = np.arange(round(seconds * sr)) / sr
    slope = (f_end - f_start) / seconds
    phase = 2 * np.pi * (f_start * t + 0.5 * slope * t * t)
    x = sum(np.sin(k * phase) / k for k in range(1, n_harmonics + 1))
    x = amplitude * x / np.max(np.abs(x))
    return x, (lambda tt: f_start + slope * np.asarray(tt))


def write_wav(path, samples, sr: int = 16000, *, channels: int = 1) -> None:
    """Write float samples in [-1, 1] as 16-bit PCM; ``samples`` may be (n,) or (n, channels)."""
    import wave

    import numpy as np

    data = np.asarray(samples, dtype=np.float64)
    ints = np.round(np.clip(data, -1, 1) * 32767).astype("<i2")
    with wave.open(str(path), "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(2)
        w.setframerate(sr)
        w.writeframes(ints.tobytes())


@pytest.fixture
def demo_wav(repo_root: Path) -> Path:
    return repo_root / "data" / "demo" / "speech.wav"
# -- live head-and-eye generator (app/stimuli/live) ----------------------------------------------

def live_synthetic_speaker(n_frames: int = 3000, fps: float = 30.0, seed: int = 0,
                           blink_params: tuple[tuple[float, float], tuple[float, float]] = (
                               (0.6, 0.4), (1.3, 0.3))):
    """Synthetic speech features and a ground-truth track with KNOWN couplings, for the live
    model's tests: talk spurts and pauses; head pitch follows F0 and yaw follows loudness
    (smoothed, plus noise); gaze follows head yaw and loudness; the lids follow gaze pitch; blink
    intervals are log-normal with ``blink_params`` (mu, sigma) for (talking, listening)."""
    import numpy as np
    from scipy.ndimage import gaussian_filter1d

    from app.stimuli.features import SpeechFeatures
    from app.stimuli.live.eyelids import blink_closure
    from app.stimuli.live.inputs import talking_mode
    from app.stimuli.track import MotionTrack

    rng = np.random.default_rng(seed)
    n = n_frames
    talk = np.zeros(n, bool)
    t = 0
    while t < n:  # alternating talk spurts (2-6 s) and pauses (1-3 s)
        spurt = int(rng.uniform(2, 6) * fps)
        talk[t:t + spurt] = True
        t += spurt + int(rng.uniform(1, 3) * fps)
    syll = np.sin(2 * np.pi * np.arange(n) / fps * 4.0 + rng.uniform(0, 6)) > -0.3
    voiced = talk & syll
    contour = 150 * 2 ** (gaussian_filter1d(rng.normal(0, 1, n), 8) * 2.0 / 12 * 3)
    f0 = np.where(voiced, contour, 0.0)
    intensity = np.where(talk, 62 + 6 * syll + gaussian_filter1d(rng.normal(0, 3, n), 2),
                         25 + rng.normal(0, 2, n))
    st = 12 * np.log2(np.maximum(contour, 1) / 150)
    drive_p = gaussian_filter1d(np.where(voiced, st, 0.0), 3)
    drive_l = gaussian_filter1d((intensity - 45) / 20, 5)
    pitch_deg = -1.5 * drive_p + gaussian_filter1d(rng.normal(0, 1.2, n), 6)
    yaw_deg = 6 * drive_l + gaussian_filter1d(rng.normal(0, 1.5, n), 10)
    roll_deg = 0.5 * drive_p + gaussian_filter1d(rng.normal(0, 0.8, n), 8)
    gaze_yaw = -0.6 * yaw_deg + 3 * drive_l + gaussian_filter1d(rng.normal(0, 1.0, n), 3)
    gaze_pitch = 0.4 * pitch_deg + gaussian_filter1d(rng.normal(0, 1.0, n), 3)
    openness = 0.9 - 0.02 * gaze_pitch
    mode = talking_mode(intensity, 42.0, fps)
    closure = np.zeros(n)
    onset = rng.uniform(0, 2.0)
    times = np.arange(n) / fps
    while onset < n / fps:
        closure = np.maximum(closure, blink_closure(times - onset))
        mu, sigma = blink_params[0 if mode[min(int(np.ceil(onset * fps)), n - 1)] else 1]
        onset += float(np.exp(mu + sigma * rng.standard_normal()))
    total = (1 - openness * (1 - closure)) * 1024
    au = np.pi / 180 / 1e-5
    cols = {48: pitch_deg * au, 49: yaw_deg * au, 50: roll_deg * au,
            23: gaze_yaw * au, 24: gaze_yaw * au, 25: gaze_pitch * au, 26: gaze_pitch * au,
            19: 0.8 * total, 20: 0.8 * total, 21: 0.2 * total, 22: 0.2 * total}
    features = SpeechFeatures(fps, f0, intensity, np.where(voiced, f0, 150.0), {})
    track = MotionTrack.from_channels(fps, cols).replace(name="synthetic", source="synthetic")
    return features, track


@pytest.fixture(scope="session")
def live_training_data():
    """(features, ground truth) of the synthetic live speaker, 100 s at 30 fps."""
    return live_synthetic_speaker(3000, 30.0, seed=1)


@pytest.fixture(scope="session")
def live_held_out_speech():
    """Other speech of the synthetic live speaker (100 s): for held-out tests."""
    return live_synthetic_speaker(3000, 30.0, seed=7)[0]


@pytest.fixture(scope="session")
def live_model(live_training_data):
    """A live model trained on :func:`live_training_data` (session-wide: EM takes seconds)."""
    from app.stimuli.live.model import train_live_model

    return train_live_model(*live_training_data, seed=0)


@pytest.fixture
def tone_wav(tmp_path: Path):
    """Factory: ``tone_wav(seconds)`` -> path of a fresh test WAV."""
    return lambda seconds: write_tone_wav(tmp_path / f"tone_{seconds}.wav", seconds)


# --- web: databases, app, client, participants ---------------------------------------------
# Every web test runs on SQLite (a file) and on the real PostgreSQL (a throwaway database per
# run, so parallel runs never collide). The schema comes from the migrations, as in production.

import re  # noqa: E402
import secrets  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import textwrap  # noqa: E402
import wave  # noqa: E402

from tests.support.services import PG_HOST, PG_PORT, REDIS_PORT, ensure_services  # noqa: E402


@pytest.fixture(scope="session")
def postgres_url():
    """A fresh PostgreSQL database for this run, dropped at the end."""
    ensure_services()
    import psycopg

    name = f"facepair_test_{secrets.token_hex(4)}"
    try:
        admin = psycopg.connect(f"host={PG_HOST} port={PG_PORT} user=postgres dbname=postgres",
                                autocommit=True)
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
    """The local Redis (database 15, flushed before use), or skip."""
    ensure_services()
    from redis import Redis
    from redis.exceptions import RedisError

    url = f"redis://127.0.0.1:{REDIS_PORT}/15"
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
    from app import create_app

    return create_app({
        "TESTING": True, "SECRET_KEY": "test-secret", "SQLALCHEMY_DATABASE_URI": url,
        "MEDIA_ROOT": str(media), "JOB_RUNNER": "inline", "REDIS_URL": None, **config})


def upgrade_database(url: str, media: Path) -> None:
    """``flask db upgrade`` on ``url`` (once per database and run)."""
    if url in _MIGRATED:
        return
    from flask_migrate import upgrade

    app = make_app(url, media)
    with app.app_context():
        upgrade()
        from app.extensions import db

        db.engine.dispose()
    _MIGRATED.add(url)


def wipe_database(app) -> None:
    from app.extensions import db

    with app.app_context():
        db.session.remove()
        with db.engine.begin() as conn:
            for table in reversed(db.metadata.sorted_tables):
                conn.execute(table.delete())
        db.engine.dispose()


@pytest.fixture(params=["sqlite", pytest.param("postgres", marks=pytest.mark.postgres)])
def database_url(request) -> str:
    return request.getfixturevalue(f"{request.param}_url")


@pytest.fixture
def app(database_url, tmp_path):
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
        r'id="[^"]*csrf_token"[^>]*value="([^"]+)"', page)
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


def make_clip(path: Path, seconds: float = 0.6, size: str = "128x64",
              bitrate: str | None = None) -> Path:
    """An H.264 + AAC test-pattern clip in the stimuli's format (streamable: +faststart)."""
    import imageio_ffmpeg

    rate = ["-b:v", bitrate] if bitrate else []
    subprocess.run([
        imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-f", "lavfi",
        "-i", f"testsrc=size={size}:rate=25", "-f", "lavfi", "-i", "sine=frequency=440",
        "-t", str(seconds), "-c:v", "libx264", *rate, "-pix_fmt", "yuv420p", "-c:a", "aac",
        "-shortest", "-movflags", "+faststart", str(path)], check=True)
    return path


@pytest.fixture(scope="session")
def tiny_video(tmp_path_factory) -> Path:
    """A 0.6 s clip, the stand-in for a rendered side-by-side stimulus."""
    return make_clip(tmp_path_factory.mktemp("video") / "tiny.mp4")


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


def study_toml(*, design: str = "unordered_counterbalanced", replay: str = "unlimited",
               max_plays: int | None = None, catch: int = 0, catch_kind: str = "identical",
               undecided: bool = True, extra: str = "") -> str:
    return textwrap.dedent(STUDY_TOML).format(
        design=design, replay=replay, catch=catch, catch_kind=catch_kind,
        undecided=str(undecided).lower(),
        max_plays=f"max_plays = {max_plays}" if max_plays else "", extra=extra)


def create_test_user(email: str = "exp@example.org", password: str = "correct horse"):
    from app.experimenter.auth import create_user
    from app.extensions import db

    user = create_user(email, password)
    db.session.commit()
    return user


def create_test_study(app, tmp_path: Path, video: Path | None, *, owner_email: str =
                      "exp@example.org", status: str = "open", **toml) -> int:
    """A study from a TOML file; with ``video`` every stimulus 'rendered' as that file."""
    import sqlalchemy as sa

    from app.extensions import db
    from app.models import Stimulus, User
    from app.storage import media_dir
    from app.studies import create_study
    from app.trials.studyfile import loads_study

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
            for stimulus in db.session.scalars(sa.select(Stimulus)
                                               .where(Stimulus.study_id == study.id)):
                rel = f"videos/{stimulus.id}.mp4"
                (media_dir(study) / "videos").mkdir(parents=True, exist_ok=True)
                shutil.copyfile(video, media_dir(study) / rel)
                stimulus.video_path = rel
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

    def current_trial(self) -> int | None:
        response = self.client.get(f"/p/{self.token}/trial")
        if response.status_code == 302:
            return None
        found = re.search(r'data-trial-id="(\d+)"', response.get_data(as_text=True))
        assert found
        return int(found.group(1))

    def vote(self, trial_id: int, choice: str = "left", *, key: str | None = None,
             plays: int = 1, **extra):
        payload = {"token": self.token, "trial_id": trial_id, "choice": choice, "plays": plays,
                   "watched_to_end": True, "response_ms": 1234,
                   "presented_at": "2026-01-01T10:00:00.000Z",
                   "idempotency_key": key or secrets.token_hex(8), **extra}
        return self.client.post("/api/v1/votes", json=payload)


@pytest.fixture
def participant(client, app) -> ParticipantActions:
    return ParticipantActions(client, app)


def login(client, email: str = "exp@example.org", password: str = "correct horse"):
    token = csrf_token(client, "/experimenter/login")
    return client.post("/experimenter/login", data={"csrf_token": token, "email": email,
                                                    "password": password})


@pytest.fixture
def web(app, tmp_path, tiny_video):
    """Helpers for web tests: ``web.study(**toml)`` (a rendered, open study by default),
    ``web.user()``, ``web.login(client)``, ``web.csrf(client, url)``."""
    from types import SimpleNamespace

    def study(video: bool = True, **toml) -> int:
        return create_test_study(app, tmp_path, tiny_video if video else None, **toml)

    def user(email: str = "exp@example.org", password: str = "correct horse"):
        with app.app_context():
            return create_test_user(email, password).id

    return SimpleNamespace(study=study, user=user, login=login, csrf=csrf_token,
                           write_wav=write_tone_wav, toml=study_toml, tiny_video=tiny_video)


@pytest.fixture
def live_server(tmp_path, tiny_video):
    """A threaded server on a migrated, file-backed SQLite database (never in-memory), for
    browser tests: ``live.url``, ``live.app``, ``live.study(**toml)``."""
    import threading
    from types import SimpleNamespace

    from werkzeug.serving import make_server

    url = f"sqlite:///{tmp_path / 'live.sqlite'}"
    upgrade_database(url, tmp_path / "media")
    app = make_app(url, tmp_path / "media")
    server = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield SimpleNamespace(
            app=app, url=f"http://127.0.0.1:{server.port}",
            study=lambda video=True, **toml: create_test_study(
                app, tmp_path, tiny_video if video else None, **toml),
            user=lambda: _in_context(app, create_test_user), write_wav=write_tone_wav,
            toml=study_toml)
    finally:
        server.shutdown()
        server.server_close()
        thread.join(timeout=10)
        from app.extensions import db

        with app.app_context():
            db.engine.dispose()


def _in_context(app, function, *args):
    with app.app_context():
        return function(*args).id


@pytest.fixture(scope="session")
def exported_head(tmp_path_factory) -> Path:
    """The built-in head exported as a glTF avatar (``facepair face export``)."""
    from renderer.faceexport import export_builtin_head

    return export_builtin_head(tmp_path_factory.mktemp("avatar") / "head.glb")


@pytest.fixture
def stub_pipeline(monkeypatch, tiny_video):
    """Generation and rendering stand-ins for browser tests (the real pipeline is tested in
    its own packages; there only the web's wiring): every stimulus 'rendered' as the tiny
    video, the study then ready."""
    import sqlalchemy as sa

    from app.extensions import db
    from app.jobs import tasks
    from app.models import Stimulus
    from app.storage import media_dir

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

    monkeypatch.setitem(tasks.TASKS, "generate", fake_generate)
    monkeypatch.setitem(tasks.TASKS, "render", fake_render)
