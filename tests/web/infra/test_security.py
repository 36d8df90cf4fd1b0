"""Secrets, session cookies, proxies, security headers, safe redirects and login limits."""

import re
import secrets

import pytest

from app.errors import InputError
from app.web import create_app
from app.web.infra.security import safe_next
from tests.conftest import PASSWORD


def _bare(tmp_path, **config):
    return create_app({"SQLALCHEMY_DATABASE_URI": f"sqlite:///{tmp_path}/x.db", **config})


@pytest.mark.parametrize(
    "key",
    [None, "", "dev-only-change-me", "short-key", "a" * 16, "a" * 64, "abababababababab" * 2],
)
def test_no_real_secret_key_is_refused_outside_tests(tmp_path, monkeypatch, key):
    monkeypatch.delenv("SECRET_KEY", raising=False)
    with pytest.raises(InputError) as caught:
        _bare(tmp_path, SECRET_KEY=key)
    assert str(caught.value).startswith("SECRET_KEY: ") and "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "key",
    [
        "abcdefghijklmnopqrstuvwxyz0123456789",  # the alphabet
        "qwertyuiopasdfghjklzxcvbnmqwertyuiop",  # keyboard rows
        "1qaz2wsx3edc4rfv5tgb6yhn7ujm8ik,9ol.",  # a keyboard's columns
        "0123456789abcdef" * 2,  # a repeated chunk
        "0123456789abcdef" * 4,
        "correcthorsebatterystaple",  # dictionary words, and short
        "correcthorsebatterystaple" * 2,
        "ThisIsMyVeryLongAndSecureSecretKey!",
        "please-change-this-secret-key-in-production",
    ],
)
def test_a_guessable_secret_key_is_refused_with_how_to_make_one(tmp_path, monkeypatch, key):
    """These passed the old check (16 characters, 80 bits of character frequencies); the key
    signs sessions and login device cookies, so whoever guesses it logs in unlimited."""
    monkeypatch.delenv("SECRET_KEY", raising=False)
    with pytest.raises(InputError) as caught:
        _bare(tmp_path, SECRET_KEY=key)
    message = str(caught.value)
    assert message.startswith(("SECRET_KEY: guessable", "SECRET_KEY: shorter than 32"))
    assert "\n" not in message
    assert message.endswith('python -c "import secrets; print(secrets.token_hex(32))"')
    assert key[:12] not in message  # the refusal never repeats the key


def test_a_real_secret_key_is_accepted(tmp_path, monkeypatch):
    key = secrets.token_hex(32)
    monkeypatch.setenv("SECRET_KEY", key)
    assert _bare(tmp_path).secret_key == key
    for other in (secrets.token_urlsafe(32), secrets.token_hex(16)):
        assert _bare(tmp_path, SECRET_KEY=other).secret_key == other


@pytest.mark.parametrize(
    "method",
    ["pbkdf2:sha256:1", "pbkdf2:sha256:599999", "scrypt:16384:8:1", "plain", "md5", "", "scrypt:x"],
)
def test_a_cheap_or_unknown_password_hash_is_refused_outside_tests(tmp_path, method):
    with pytest.raises(InputError) as caught:
        _bare(tmp_path, SECRET_KEY=secrets.token_hex(32), PASSWORD_HASH_METHOD=method)
    assert str(caught.value).startswith("PASSWORD_HASH_METHOD: ") and "\n" not in str(caught.value)


def test_passwords_are_hashed_with_scrypt_by_default_and_old_hashes_still_check(tmp_path):
    from werkzeug.security import generate_password_hash

    from app.web.models import User

    for method in ("scrypt", "scrypt:65536:8:1", "pbkdf2", "pbkdf2:sha512:700000"):
        _bare(tmp_path, SECRET_KEY=secrets.token_hex(32), PASSWORD_HASH_METHOD=method)
    app = _bare(tmp_path, SECRET_KEY=secrets.token_hex(32))
    assert app.config["PASSWORD_HASH_METHOD"] == "scrypt:32768:8:1"
    with app.app_context():
        user = User(email="a@example.org")
        user.set_password(PASSWORD)
        assert user.password_hash.startswith("scrypt:32768:8:1$")
        assert user.check_password(PASSWORD) and not user.check_password("wrong")
        # a hash made under another setting (tests' one round, an older deployment) checks
        user.password_hash = generate_password_hash(PASSWORD, "pbkdf2:sha256:1")
        assert user.check_password(PASSWORD)


@pytest.mark.parametrize(
    "target",
    [
        "/%09/evil.example/path",
        "/\t/evil.example/path",
        "//evil.example",
        "/\\evil.example",
        "\\\\evil.example",
        " //evil.example",
        "/\r\n/evil.example",
        "https://evil.example/",
        "javascript:alert(1)",
        "/\x00/evil.example",
        "evil.example",
        "///evil.example",
    ],
)
def test_safe_next_keeps_only_paths_on_this_site(target):
    from urllib.parse import unquote

    for value in (target, unquote(target)):
        result = safe_next(value, "/home")
        assert result == "/home" or (
            result.startswith("/")
            and not result.startswith("//")
            and "evil.example" not in result.split("/")[1]
        )


def test_safe_next_keeps_a_local_path():
    assert safe_next("/experimenter/studies/4?x=1", "/") == "/experimenter/studies/4?x=1"


@pytest.mark.parametrize(
    "query",
    ["/%09/evil.example/path", "/%5C/evil.example", "%20//evil.example", "/%0D%0A/evil.example"],
)
def test_login_never_redirects_off_site(client, web, query):
    web.user()
    token = web.csrf(client, "/experimenter/login")
    response = client.post(
        f"/experimenter/login?next={query}",
        data={"csrf_token": token, "email": "exp@example.org", "password": PASSWORD},
    )
    assert response.status_code == 302
    location = response.headers["Location"]
    assert location.startswith("/") and not location.startswith("//"), location


def _session_cookie(response) -> str:
    cookies = [c for c in response.headers.getlist("Set-Cookie") if c.startswith("session=")]
    assert cookies, response.headers
    return cookies[-1]


def test_session_cookie_flags_over_http(client, web):
    web.user()
    cookie = _session_cookie(web.login(client))
    assert "HttpOnly" in cookie and "SameSite=Lax" in cookie and "Secure" not in cookie


def test_session_cookie_is_secure_over_https(app, web):
    web.user()
    client = app.test_client()
    page = client.get("/experimenter/login", base_url="https://study.example")
    token = re.search(r'name="csrf_token"[^>]*value="([^"]+)"', page.get_data(as_text=True))
    # Flask-WTF checks the Referer of a form posted over HTTPS.
    response = client.post(
        "/experimenter/login",
        base_url="https://study.example",
        headers={"Referer": "https://study.example/experimenter/login"},
        data={
            "csrf_token": token.group(1),
            "email": "exp@example.org",
            "password": PASSWORD,
        },
    )
    assert response.status_code == 302
    assert "Secure" in _session_cookie(response)
    assert "max-age=" in response.headers["Strict-Transport-Security"]


@pytest.mark.parametrize("trusted", [0, 1])
def test_https_behind_a_trusted_proxy(app, trusted):
    proxied = create_app(
        {
            "TESTING": True,
            "SECRET_KEY": "k" * 32,
            "TRUST_PROXY": trusted,
            "SQLALCHEMY_DATABASE_URI": app.config["SQLALCHEMY_DATABASE_URI"],
        }
    )
    client = proxied.test_client()
    response = client.get("/experimenter/login", headers={"X-Forwarded-Proto": "https"})
    cookie = _session_cookie(response)  # the CSRF token lives in the session
    assert ("Secure" in cookie) == bool(trusted)
    assert ("Strict-Transport-Security" in response.headers) == bool(trusted)


@pytest.mark.parametrize(
    "path",
    [
        "/experimenter/login",
        "/healthz",
        "/s/nothing-here",
        "/static/participant.js",
        "/api/v1/participants/x/progress",
    ],
)
def test_security_headers_on_every_response(client, path):
    response = client.get(path)
    response.close()  # a static file's handle
    headers = response.headers
    csp = headers["Content-Security-Policy"]
    directives = dict((d.strip().split(" ", 1) + [""])[:2] for d in csp.split(";"))
    assert "'unsafe-inline'" not in directives["script-src"]
    assert directives["frame-ancestors"] == "'none'" and headers["X-Frame-Options"] == "DENY"
    assert headers["X-Content-Type-Options"] == "nosniff"
    assert headers["Referrer-Policy"] == "same-origin"
    assert "Strict-Transport-Security" not in headers


def test_login_attempts_are_limited_per_account(app, web):
    web.user()
    client = app.test_client()
    codes = [web.login(client, password=f"wrong {i}").status_code for i in range(40)]
    assert codes[:5] == [200] * 5 and set(codes[5:]) == {429}
    # The right password is refused too while the account is locked ...
    assert web.login(client).status_code == 429
    # ... but another account from another address is unaffected.
    web.user("other@example.org")
    other = app.test_client()
    other.environ_base["REMOTE_ADDR"] = "10.1.2.3"
    assert web.login(other, "other@example.org").status_code == 302


def test_login_attempts_are_limited_per_address(app, web):
    web.user()
    client = app.test_client()
    codes = [web.login(client, f"nobody{i}@example.org").status_code for i in range(25)]
    assert codes[:20] == [200] * 20 and set(codes[20:]) == {429}


def test_successful_logins_do_not_count(app, web):
    web.user()
    client = app.test_client()
    assert {web.login(client).status_code for _ in range(8)} == {302}


def test_token_authenticated_endpoints_are_exactly_the_participant_json_ones(app):
    """Every JSON endpoint but the job status and Prolific's webhook (signed by Prolific)
    authenticates by the participant's token, so its session cookie is never read; a new
    endpoint must be placed on one side or the other."""
    from app.web.infra.security import token_authenticated

    sides = {}
    for rule in app.url_map.iter_rules():
        if rule.endpoint.startswith("api."):
            path = re.sub(
                r"<(?:int:)?(\w+)>", lambda m: "7" if "int:" in m.group(0) else "tok", rule.rule
            )
            sides[rule.endpoint] = token_authenticated(path)
    assert sides == {
        "api.post_vote": True,
        "api.post_rating": True,
        "api.post_play": True,
        "api.post_environment": True,
        "api.progress": True,
        "api.post_unplayable": True,
        "api.job_status": False,
        "api.prolific_webhook": False,
    }
    for path in ("/experimenter/login", "/s/slug", "/p/tok/trial", "/api/v1/jobs/1", "/"):
        assert not token_authenticated(path), path


def test_a_vote_leaves_the_session_cookie_unread_and_unchanged(app, participant, web, monkeypatch):
    from flask.sessions import SecureCookieSessionInterface

    study_id = web.study()
    from app.web.extensions import db
    from app.web.models import Study

    with app.app_context():
        slug = db.session.get(Study, study_id).slug
    participant.join(slug)  # the consent form put a CSRF token in the session cookie
    assert participant.client.get_cookie("session") is not None
    opened = []
    original = SecureCookieSessionInterface.open_session

    def counted(self, flask_app, request):
        opened.append(request.path)
        return original(self, flask_app, request)

    monkeypatch.setattr(SecureCookieSessionInterface, "open_session", counted)
    trial = participant.current_trial()
    play = participant.client.post(
        "/api/v1/plays", json={"token": participant.token, "trial_id": trial}
    )
    vote = participant.vote(trial)
    assert play.status_code == 200 and vote.status_code == 201
    assert "Set-Cookie" not in play.headers and "Set-Cookie" not in vote.headers
    # The page read the cookie; the play and the vote did not.
    assert opened == [f"/p/{participant.token}/trial"], opened
    assert participant.client.get_cookie("session") is not None
