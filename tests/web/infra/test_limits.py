"""Input limits from the column definitions, and no 5xx from any input: the JSON endpoints,
the consent form and the study-file upload, on SQLite and PostgreSQL, with generated hostile
input (integers beyond 64 bits, NaN and infinity, NUL bytes, lone surrogates, deep nesting,
out-of-range times, over-long text)."""

import io
import json
import re
import secrets
import string

import pytest
import sqlalchemy as sa
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.errors import InputError
from app.web.extensions import db
from app.web.infra import limits
from app.web.models import Participant, Study, Trial, User, Vote

FUZZ = settings(
    max_examples=2000,
    deadline=None,
    database=None,
    suppress_health_check=[
        HealthCheck.function_scoped_fixture,
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
    ],
)


# --- the limits themselves -------------------------------------------------------------------


def test_limits_come_from_the_columns():
    assert limits.problem(Participant.prolific_pid.property.columns[0], "x" * 64) is None
    assert limits.problem(limits.column_of(Participant.prolific_pid), "x" * 65) == (
        "at most 64 characters, got 65"
    )
    assert limits.fits(Study.target_participants, 2**31 - 1)
    assert not limits.fits(Study.target_participants, 2**31)
    assert limits.fits(Study.seed, 2**40) and not limits.fits(Study.seed, 2**63)
    assert not limits.fits(Study.instructions, "a\x00b")
    assert not limits.fits(Study.title, "\ud800")
    assert not limits.fits(Study.settings, {"render": {"fps": float("nan")}})
    nested: list = []
    for _ in range(100):
        nested = [nested]
    assert not limits.fits(Study.settings, {"deep": nested})


def test_check_names_the_field():
    with pytest.raises(InputError, match=r"^replay.max_plays: expected a whole number from"):
        limits.check(Study.max_plays, 2**40)
    with pytest.raises(InputError, match=r"^PROLIFIC_PID: must not contain a NUL"):
        limits.check(Participant.prolific_pid, "a\x00")


def test_every_flush_is_guarded(app):
    with app.app_context():
        db.session.add(User(email="x" * 201, password_hash="h"))
        with pytest.raises(InputError, match=r"^email: at most 200 characters, got 201$"):
            db.session.flush()
        db.session.rollback()


# --- generated hostile input -------------------------------------------------------------------

HOSTILE_TEXT = st.one_of(
    st.text(max_size=80),
    st.text(
        alphabet=st.characters(min_codepoint=0, max_codepoint=0xDFFF, exclude_categories=()),
        max_size=20,
    ),
    st.sampled_from(
        [
            "\x00",
            "a\x00b",
            "\ud800",
            "\udfff x",
            "x" * 65,
            "x" * 300,
            "",
            " ",
            "NaN",
            "left",
            "right",
            "undecided",
            "9" * 30,
        ]
    ),
)
HOSTILE_INT = st.one_of(
    st.integers(-5, 50),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([2**31 - 1, 2**31, 2**32, 2**63 - 1, 2**63, 2**64, -(2**31) - 1]),
)
HOSTILE_FLOAT = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([float("nan"), float("inf"), -float("inf"), 1e308]),
)
HOSTILE_TIME = st.one_of(
    st.sampled_from(
        [
            "0001-01-01T00:00:00+01:00",
            "9999-12-31T23:59:59-14:00",
            "0001-01-01T00:00:00Z",
            "2026-02-30T10:00:00Z",
            "2026-01-01T10:00:00.000Z",
            "10000-01-01T00:00:00Z",
            "2026-01-01T25:00:00Z",
        ]
    ),
    st.datetimes().map(lambda d: d.isoformat()),
    HOSTILE_TEXT,
)
SCALAR = st.one_of(st.none(), st.booleans(), HOSTILE_INT, HOSTILE_FLOAT, HOSTILE_TEXT)
JSON_VALUE = st.recursive(
    SCALAR,
    lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(HOSTILE_TEXT, inner, max_size=3)
    ),
    max_leaves=8,
)


def _deep(depth: int) -> str:
    return "[" * depth + "]" * depth


@st.composite
def vote_bodies(draw, token: str, trial_ids: list[int]):
    """A vote request body: mostly a real participant's vote with some fields made hostile,
    sometimes not a vote at all."""
    kind = draw(st.sampled_from(["vote"] * 8 + ["json", "deep", "bytes"]))
    if kind == "deep":
        return _deep(draw(st.sampled_from([500, 5000, 100_000]))).encode()
    if kind == "bytes":
        return draw(st.binary(max_size=200))
    if kind == "json":
        return json.dumps(draw(JSON_VALUE)).encode()
    payload = {
        "token": token,
        "trial_id": draw(st.sampled_from(trial_ids)),
        "choice": draw(st.sampled_from(["left", "right", "undecided"])),
        "plays": 1,
        "watched_to_end": True,
        "response_ms": 1234,
        "presented_at": "2026-01-01T10:00:00.000Z",
        "idempotency_key": secrets.token_hex(8),
    }
    hostile = {
        "token": HOSTILE_TEXT,
        "trial_id": st.one_of(HOSTILE_INT, HOSTILE_FLOAT),
        "choice": HOSTILE_TEXT,
        "plays": st.one_of(HOSTILE_INT, HOSTILE_FLOAT),
        "response_ms": st.one_of(HOSTILE_INT, HOSTILE_FLOAT),
        "presented_at": HOSTILE_TIME,
        "idempotency_key": HOSTILE_TEXT,
        "watched_to_end": JSON_VALUE,
    }
    for name in draw(st.lists(st.sampled_from(sorted(hostile)), max_size=3, unique=True)):
        payload[name] = draw(hostile[name])
    if draw(st.booleans()):
        payload[draw(HOSTILE_TEXT)] = draw(JSON_VALUE)
    return json.dumps(payload).encode()  # NaN spelled as JSON's NaN, surrogates as \ud800


def _joined(app, participant, web):
    study_id = web.study(design="all_ordered")
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    token = participant.join(slug)
    with app.app_context():
        trial_ids = list(
            db.session.scalars(
                sa.select(Trial.id).join(Participant).where(Participant.token == token)
            )
        )
    return token, trial_ids


def _server_errors(responses: list) -> list:
    return [r for r in responses if r >= 500]


@pytest.mark.slow
def test_votes_never_answer_5xx(app, participant, web):
    token, trial_ids = _joined(app, participant, web)
    client = app.test_client()
    codes: list[int] = []

    @FUZZ
    @given(body=vote_bodies(token, trial_ids))
    def post(body):
        response = client.post("/api/v1/votes", data=body, content_type="application/json")
        codes.append(response.status_code)
        assert response.status_code < 500, (body[:300], response.get_data(as_text=True))
        if response.status_code >= 400:
            assert response.json["error"]

    post()
    assert len(codes) >= 2000 and not _server_errors(codes)
    # The hostile requests stored nothing a participant did not send as a vote.
    with app.app_context():
        stored = db.session.scalars(sa.select(Vote)).all()
    assert all(
        v.trial_id in trial_ids and v.choice in ("left", "right", "undecided") for v in stored
    )


@pytest.mark.parametrize(
    "body, field",
    [
        ({"trial_id": 2**31}, "trial_id"),
        ({"trial_id": 2**70}, "trial_id"),
        ({"plays": float("nan")}, "plays"),
        ({"response_ms": float("inf")}, "response_ms"),
        ({"response_ms": 2**40}, "response_ms"),
        ({"idempotency_key": "abc\x00defgh"}, "idempotency_key"),
        ({"idempotency_key": "\ud800" * 9}, "idempotency_key"),
        ({"presented_at": "0001-01-01T00:00:00+01:00"}, "presented_at"),
    ],
)
def test_each_bad_vote_field_is_named(app, participant, web, body, field):
    token, trial_ids = _joined(app, participant, web)
    payload = {
        "token": token,
        "trial_id": trial_ids[-1],
        "choice": "left",
        "plays": 1,
        "watched_to_end": True,
        "idempotency_key": "a-good-key-1",
        **body,
    }
    response = participant.client.post(
        "/api/v1/votes", data=json.dumps(payload), content_type="application/json"
    )
    assert response.status_code == 400 and response.json["error"].startswith(field + ":")


def test_deeply_nested_json_is_a_400(client):
    for body in (_deep(100_000), _deep(3000)):
        response = client.post("/api/v1/votes", data=body, content_type="application/json")
        assert response.status_code == 400 and response.json["error"].startswith("body:")


URL_TEXT = st.one_of(HOSTILE_TEXT, st.text(alphabet=string.printable, max_size=300))


@pytest.mark.slow
def test_progress_and_jobs_never_answer_5xx(app, participant, web):
    from urllib.parse import quote

    token, _ = _joined(app, participant, web)
    client = app.test_client()
    web.login(client)
    codes: list[int] = []

    quoted = URL_TEXT.map(lambda t: quote(t, safe="", errors="surrogatepass"))

    @FUZZ
    @given(value=st.one_of(quoted, st.just(token), HOSTILE_INT.map(str)), number=HOSTILE_INT)
    def get(value, number):
        for url in (
            f"/api/v1/participants/{value}/progress",
            f"/api/v1/jobs/{number}",
            f"/api/v1/jobs/{value}",
        ):
            response = client.get(url)
            codes.append(response.status_code)
            assert response.status_code < 500, (url, response.get_data(as_text=True))

    get()
    assert len(codes) >= 2000 * 3 and not _server_errors(codes)


# --- the study-file parser, through the upload form ----------------------------------------


def _toml_string(text: str) -> str:
    # TOML basic strings: JSON's escapes are TOML's, except that lone surrogates are invalid
    # (then the file is refused as invalid TOML, which is also an answer).
    return json.dumps(text)


TOML_VALUE = st.one_of(
    HOSTILE_INT.map(str),
    HOSTILE_TEXT.map(_toml_string),
    st.sampled_from(["nan", "inf", "-inf", "true", "1e400", "[]", "{}"]),
    st.integers(1, 5000).map(_deep),
    st.integers(1, 5000).map(lambda n: "{a = " * n + "1" + "}" * n),
)
TOP_KEYS = [
    "title",
    "question",
    "instructions",
    "consent",
    "design",
    "reference",
    "seed",
    "target_participants",
    "completion_code",
    "redirect_url",
]
TABLE_KEYS = {
    "undecided": ["allowed", "label"],
    "replay": ["policy", "max_plays"],
    "catch": ["trials", "kind"],
}


@st.composite
def study_files(draw, web, design):
    """A study file: the valid test study of ``design`` with some values replaced by hostile
    ones, or something else entirely."""
    if draw(st.integers(0, 9)) == 0:
        return draw(
            st.one_of(st.text(max_size=300), st.integers(1, 6000).map(lambda n: "a = " + _deep(n)))
        )
    text = web.toml(design=design)
    for key in draw(st.lists(st.sampled_from(TOP_KEYS), max_size=3, unique=True)):
        line = f"{key} = {draw(TOML_VALUE)}"
        pattern = re.compile(rf"^{key} = .*$", re.M)
        text = (
            pattern.sub(lambda _m, line=line: line, text, count=1)
            if pattern.search(text)
            else line + "\n" + text
        )
    for table, keys in TABLE_KEYS.items():
        if draw(st.booleans()):
            key = draw(st.sampled_from(keys))
            text = text.replace(f"[{table}]\n", f"[{table}]\n{key} = {draw(TOML_VALUE)}\n", 1)
    if draw(st.booleans()):
        name = draw(HOSTILE_TEXT)
        text = text.replace('name = "random"', f"name = {_toml_string(name)}", 1)
    if draw(st.booleans()):
        text = text.replace(
            'model = "random"', f'model = "random"\nsettings = {{ seed = {draw(TOML_VALUE)} }}', 1
        )
    return text


@pytest.mark.slow
@pytest.mark.parametrize("design", ["all_ordered", "unordered_counterbalanced"])
def test_study_uploads_never_answer_5xx(app, web, tmp_path, design):
    """Half of the 2,000 files a backend is sent for each design: two tests of a minute rather
    than one of two, so the suite's processes share them."""
    web.user()
    client = app.test_client()
    web.login(client)
    wav = web.write_wav(tmp_path / "s1.wav").read_bytes()
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    csrf = re.search(r'name="file-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    codes: list[int] = []

    @settings(FUZZ, max_examples=1000)
    @given(text=study_files(web, design))
    def upload(text):
        response = client.post(
            "/experimenter/studies/new",
            content_type="multipart/form-data",
            data={
                "file-csrf_token": csrf,
                "file-submit": "1",
                "file-study_file": (
                    io.BytesIO(text.encode("utf-8", "surrogatepass")),
                    "study.toml",
                ),
                "file-media": [(io.BytesIO(wav), "s1.wav")],
            },
        )
        codes.append(response.status_code)
        assert response.status_code < 500, (text[:500], response.get_data(as_text=True))
        if response.status_code == 400:
            assert "study.toml" in response.get_data(as_text=True)

    upload()
    assert len(codes) >= 1000 and not _server_errors(codes) and 302 in codes and 400 in codes


@pytest.mark.parametrize(
    "line, field",
    [
        ('title = "' + "t" * 300 + '"', "title: at most 200 characters"),
        ("target_participants = 1099511627776", "target_participants: expected a whole number"),
        ('completion_code = "a\\u0000b"', "completion_code: must not contain a NUL"),
        ("seed = " + "[" * 5000 + "]" * 5000, "invalid TOML: arrays or tables nested too deeply"),
    ],
)
def test_each_bad_study_value_is_named(app, client, web, tmp_path, line, field):
    web.user()
    web.login(client)
    key = line.split(" = ")[0]
    text = re.sub(rf"^{key} = .*$", lambda _m: line, web.toml(), count=1, flags=re.M)
    if key not in web.toml():
        text = line + "\n" + text
    page = client.get("/experimenter/studies/new").get_data(as_text=True)
    csrf = re.search(r'name="file-csrf_token" type="hidden" value="([^"]+)"', page).group(1)
    response = client.post(
        "/experimenter/studies/new",
        content_type="multipart/form-data",
        data={
            "file-csrf_token": csrf,
            "file-submit": "1",
            "file-study_file": (io.BytesIO(text.encode()), "study.toml"),
            "file-media": [(web.write_wav(tmp_path / "s1.wav").open("rb"), "s1.wav")],
        },
    )
    assert response.status_code == 400 and field in response.get_data(as_text=True)
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Study.id))) == 0


@pytest.mark.parametrize(
    "query, field",
    [
        ("PROLIFIC_PID=" + "p" * 65, "PROLIFIC_PID: at most 64 characters"),
        ("PROLIFIC_PID=a%00b", "PROLIFIC_PID: must not contain a NUL"),
        ("SESSION_ID=" + "s" * 70, "SESSION_ID: at most 64 characters"),
    ],
)
def test_bad_prolific_ids_are_a_400_naming_the_field(app, client, web, query, field):
    study_id = web.study()
    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    url = f"/s/{slug}?{query}"
    token = web.csrf(client, url)
    from urllib.parse import parse_qsl

    data = {"csrf_token": token, "agree": "1", **dict(parse_qsl(query))}
    response = client.post(f"/s/{slug}", data=data)
    assert response.status_code == 400 and field in response.get_data(as_text=True)
    with app.app_context():
        assert db.session.scalar(sa.select(sa.func.count(Participant.id))) == 0


@pytest.mark.parametrize(
    "path",
    [
        "/experimenter/studies/99999999999",
        "/s/a%00b",
        "/p/%00/trial",
        "/p/tok/video/4294967296",
        "/api/v1/jobs/9223372036854775808",
    ],
)
def test_identifiers_no_row_can_have_are_404(client, web, path):
    web.user()
    web.login(client)
    assert client.get(path).status_code == 404
