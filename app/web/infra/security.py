"""What stands between the platform and a hostile request: the secret key, session cookies,
the reverse proxy, security headers, safe redirects and login rate limits.

Every setting is read from the application's configuration (``docs/operations.md``, "Deploying
safely"): ``SECRET_KEY`` (required outside tests), ``TRUST_PROXY`` (how many reverse proxies
set ``X-Forwarded-*``), ``LOGIN_LIMIT_PER_ACCOUNT`` and ``_PER_ADDRESS``, and ``REDIS_URL``
(shared limiter storage).
"""

from __future__ import annotations

import re
import secrets
from pathlib import Path
from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

from flask import request
from flask.sessions import SecureCookieSessionInterface
from werkzeug.middleware.proxy_fix import ProxyFix
from werkzeug.security import generate_password_hash

from app.errors import InputError
from app.web.extensions import limiter
from app.web.infra.passwords import GENERATE_KEY, key_problem

if TYPE_CHECKING:
    from flask import Flask, Response

#: Scripts only from this origin (no 'unsafe-inline'); videos play from blob: URLs.
CONTENT_SECURITY_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
    "media-src 'self' blob:; object-src 'none'; base-uri 'none'; form-action 'self'; "
    "frame-ancestors 'none'"
)
#: The analysis report is a self-contained page: inline CSS and data: figures, no script.
REPORT_CONTENT_SECURITY_POLICY = (
    "default-src 'none'; style-src 'unsafe-inline'; img-src data:; frame-ancestors 'none'"
)

#: Blueprints serving participants: no rate limit applies to them.
PARTICIPANT_BLUEPRINTS = frozenset({"participant", "questionnaire", "api"})

# Browsers drop tabs and line breaks anywhere in a URL and leading spaces and C0 controls, and
# read a backslash as a slash: "/\t/evil.example" and "/\\evil.example" both leave the site.
_STRIPPED = re.compile(r"[\x00-\x20\x7f]")


def check_secret_key(app: Flask) -> None:
    """Refuse to run with a missing or guessable ``SECRET_KEY``: whoever knows the key can
    sign an experimenter session and download any study's votes, and mint login device
    cookies, each a login-limit bucket of its own. The key is judged by what it is
    (:func:`app.web.infra.passwords.key_problem`): a placeholder, the alphabet, a keyboard row,
    a repeated chunk or a phrase of words is refused, in one line that says how to make one."""
    key = app.config.get("SECRET_KEY")
    if app.testing or not app.config.get("REQUIRE_SECRET_KEY", True):
        if not key:
            # Commands that never answer a request still sign nothing a browser keeps.
            app.config["SECRET_KEY"] = secrets.token_hex(32)
        return
    if not key:
        raise InputError(f"not set; {GENERATE_KEY}", field="SECRET_KEY")
    text = key.decode("latin-1") if isinstance(key, bytes) else str(key)
    problem = key_problem(text)
    if problem:
        raise InputError(problem, field="SECRET_KEY")


def stored_secret_key(instance: Path) -> str:
    """A random key kept in ``instance/secret_key`` (created on first use, readable by the
    owner only): for the demo on its own SQLite file, never for a shared deployment. A stored
    key that :func:`~app.web.infra.passwords.key_problem` refuses is replaced."""
    path = instance / "secret_key"
    if path.is_file():
        key = path.read_text(encoding="ascii", errors="replace").strip()
        if key_problem(key) is None:
            return key
    key = secrets.token_hex(32)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.touch(mode=0o600)
    path.write_text(key + "\n", encoding="ascii")
    return key


def safe_next(target: str | None, default: str) -> str:
    """``target`` if it is a path on this site, else ``default`` (no open redirect).

    >>> safe_next("/experimenter/studies/3", "/")
    '/experimenter/studies/3'
    >>> safe_next("/\\t/evil.example/path", "/")
    '/'
    """
    if not target:
        return default
    path = _STRIPPED.sub("", target).replace("\\", "/")
    parts = urlsplit(path)
    if parts.scheme or parts.netloc or not path.startswith("/") or path.startswith("//"):
        return default
    return path


#: JSON endpoints that authenticate by the participant's token (in the body or the URL), never
#: by the cookie session; the job status endpoint, which needs the experimenter's login, is not
#: among them.
TOKEN_AUTHENTICATED_PATHS = ("/api/v1/votes", "/api/v1/ratings", "/api/v1/plays")
TOKEN_AUTHENTICATED_PREFIX = "/api/v1/participants/"


def token_authenticated(path: str) -> bool:
    """Whether a request for ``path`` (below the script root) is authenticated by a
    participant's token alone, so its session cookie need not be read."""
    return path in TOKEN_AUTHENTICATED_PATHS or path.startswith(TOKEN_AUTHENTICATED_PREFIX)


class ForwardedSecureSessionInterface(SecureCookieSessionInterface):
    """The session cookie is ``Secure`` whenever the request came over HTTPS, which includes
    HTTPS ended at a trusted reverse proxy (``TRUST_PROXY``), not only when configured.

    A request to a token-authenticated endpoint (:func:`token_authenticated`: a vote, a
    rating, a play, the environment, the progress) gets a new, empty session without its
    cookie being checked and decoded: those requests are a participant's most frequent and
    never need it. Left unmodified, it sends no cookie back, so the browser keeps the one it
    has."""

    def get_cookie_secure(self, app: Flask) -> bool:
        return bool(app.config["SESSION_COOKIE_SECURE"]) or request.is_secure

    def open_session(self, app: Flask, request: Any) -> Any:
        if token_authenticated(request.path):
            return self.session_class()
        return super().open_session(app, request)


def _security_headers(response: Response) -> Response:
    headers = response.headers
    headers.setdefault("Content-Security-Policy", CONTENT_SECURITY_POLICY)
    headers.setdefault("X-Frame-Options", "DENY")
    headers.setdefault("X-Content-Type-Options", "nosniff")
    # Participant URLs carry their token: never hand them to another site.
    headers.setdefault("Referrer-Policy", "same-origin")
    if request.is_secure:
        headers.setdefault("Strict-Transport-Security", "max-age=31536000; includeSubDomains")
    return response


#: The weakest password hashing a deployment may choose: scrypt's cost N, or PBKDF2's
#: iterations (OWASP's Password Storage Cheat Sheet: scrypt N=2^17 with r=8 for new systems,
#: at least 2^15 here as werkzeug's default; PBKDF2-HMAC-SHA256 600,000 iterations).
MIN_PASSWORD_HASH = {"scrypt": 2**15, "pbkdf2": 600_000}


def check_password_hash_method(app: Flask) -> None:
    """Refuse a ``PASSWORD_HASH_METHOD`` werkzeug cannot use, or, outside tests, one cheaper
    than :data:`MIN_PASSWORD_HASH` (tests hash with one PBKDF2 round: a password is hashed for
    every experimenter a test makes and checked at every login)."""
    method = str(app.config.get("PASSWORD_HASH_METHOD") or "")
    name, _, args = method.partition(":")
    parts = args.split(":") if args else []
    field = "PASSWORD_HASH_METHOD"
    try:
        generate_password_hash("x", method)
    except (ValueError, TypeError):
        raise InputError(
            f"{method!r} is no werkzeug hash method (e.g. 'scrypt:32768:8:1')", field=field
        ) from None
    if app.testing:
        return
    # werkzeug's own defaults where the method leaves the cost out
    cost = int(parts[0]) if name == "scrypt" and parts else 2**15
    if name == "pbkdf2":
        cost = int(parts[1]) if len(parts) > 1 else 600_000
    if name not in MIN_PASSWORD_HASH or cost < MIN_PASSWORD_HASH[name]:
        raise InputError(
            f"{method!r} is weaker than scrypt:{2**15}:8:1 or pbkdf2:sha256:600000", field=field
        )


def init_security(app: Flask) -> None:
    """Wire everything above into ``app`` (called by the factory before the blueprints)."""
    check_secret_key(app)
    check_password_hash_method(app)
    app.config["SESSION_COOKIE_HTTPONLY"] = True
    if not app.config.get("SESSION_COOKIE_SAMESITE"):
        app.config["SESSION_COOKIE_SAMESITE"] = "Lax"
    app.session_interface = ForwardedSecureSessionInterface()
    proxies = int(app.config.get("TRUST_PROXY") or 0)
    if proxies > 0:
        app.wsgi_app = ProxyFix(  # type: ignore[method-assign]
            app.wsgi_app,
            x_for=proxies,
            x_proto=proxies,
            x_host=proxies,
            x_port=proxies,
            x_prefix=proxies,
        )
    app.after_request(_security_headers)

    app.config.setdefault("RATELIMIT_STORAGE_URI", app.config.get("REDIS_URL") or "memory://")
    # A Redis outage must not lock experimenters out: fall back to per-process counting.
    app.config.setdefault("RATELIMIT_IN_MEMORY_FALLBACK_ENABLED", True)
    app.config.setdefault("RATELIMIT_SWALLOW_ERRORS", True)
    app.config.setdefault("RATELIMIT_HEADERS_ENABLED", True)
    limiter.init_app(app)
    _limit_only_the_experimenter_side(app, limiter)


def _limit_only_the_experimenter_side(app: Flask, limiter: Any) -> None:
    """Run the limiter's per-request check on the experimenter's pages only.

    The limits are the login's (its decorators check them, and count only failed attempts);
    the check the limiter installs before every request finds nothing to limit on the
    participant side, whose requests are the most frequent, so it is not run there.
    """
    funcs = app.before_request_funcs.setdefault(None, [])
    check = limiter._check_request_limit
    if check not in funcs:
        return

    def check_unless_participant_side() -> None:
        if request.blueprint not in PARTICIPANT_BLUEPRINTS:
            check()

    funcs[funcs.index(check)] = check_unless_participant_side
