"""Experimenter accounts (OWASP ASVS 4.0 L1, V2 and V3): logins kept on the server and ended by
logout, "log out everywhere" and a password change; idle and absolute timeouts; passwords and
e-mail addresses checked; no account enumeration by timing; no lock-out of a known device."""

import datetime as dt

import pytest
import sqlalchemy as sa
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from app.cli import main
from app.errors import InputError
from app.web.extensions import db
from app.web.infra.accounts import authenticate, create_user, login_is_live, password_problem
from app.web.infra.passwords import is_common
from app.web.models import LoginSession, User
from tests.conftest import PASSWORD, csrf_token

DASHBOARD = "/experimenter/"


def _logged_in(app, web):
    web.user()
    client = app.test_client()
    assert web.login(client).status_code == 302
    return client


def _copy(client, app):
    """Another browser holding a copy of ``client``'s cookies (a stolen session)."""
    thief = app.test_client()
    for cookie in client._cookies.values():
        thief.set_cookie(cookie.key, cookie.value, domain=cookie.domain, path=cookie.path)
    return thief


def _post(client, url, **data):
    return client.post(
        url, data={"csrf_token": csrf_token(client, "/experimenter/account"), **data}
    )


def test_a_cookie_copied_before_logout_opens_nothing_after_it(app, web):
    client = _logged_in(app, web)
    thief = _copy(client, app)
    assert thief.get(DASHBOARD).status_code == 200
    assert _post(client, "/experimenter/logout").status_code == 302
    assert client.get(DASHBOARD).status_code == 302
    assert thief.get(DASHBOARD).status_code == 302  # the copy names an ended login


def test_log_out_everywhere_ends_every_browsers_login(app, web):
    first = _logged_in(app, web)
    second = app.test_client()
    assert web.login(second).status_code == 302
    assert _post(first, "/experimenter/account/logout-everywhere").status_code == 302
    assert first.get(DASHBOARD).status_code == 302 and second.get(DASHBOARD).status_code == 302
    with app.app_context():
        ended = db.session.scalars(sa.select(LoginSession.ended_at)).all()
        assert len(ended) == 2 and all(ended)


def test_a_password_change_ends_the_other_logins_and_keeps_this_one(app, web):
    mine = _logged_in(app, web)
    other = app.test_client()
    assert web.login(other).status_code == 302
    weak = _post(mine, "/experimenter/account/password", current=PASSWORD, password="password1234")
    assert weak.status_code == 400 and "common password" in weak.get_data(as_text=True)
    wrong = _post(
        mine, "/experimenter/account/password", current="not it", password="a new long passphrase"
    )
    assert wrong.status_code == 400
    changed = _post(
        mine,
        "/experimenter/account/password",
        current=PASSWORD,
        password="a new long passphrase",
    )
    assert changed.status_code == 302
    assert mine.get(DASHBOARD).status_code == 200 and other.get(DASHBOARD).status_code == 302
    with app.app_context():
        assert authenticate("exp@example.org", "a new long passphrase") is not None
        assert authenticate("exp@example.org", PASSWORD) is None


def test_idle_and_absolute_timeouts_end_a_login(app, web):
    client = _logged_in(app, web)
    with app.app_context():
        record = db.session.scalar(sa.select(LoginSession))
        record.seen_at -= dt.timedelta(minutes=app.config["SESSION_IDLE_MINUTES"] + 1)
        db.session.commit()
    assert client.get(DASHBOARD).status_code == 302
    client = app.test_client()
    assert web.login(client).status_code == 302
    with app.app_context():
        record = db.session.scalars(sa.select(LoginSession).order_by(LoginSession.id)).all()[-1]
        record.created_at -= dt.timedelta(hours=app.config["SESSION_ABSOLUTE_HOURS"])
        db.session.commit()
    assert client.get(DASHBOARD).status_code == 302


def test_login_liveness_rule():
    now = dt.datetime(2026, 12, 3, 12, 0)
    live = LoginSession(created_at=now - dt.timedelta(hours=1), seen_at=now, ended_at=None)
    assert login_is_live(live, now, idle=60, absolute=12)
    assert not login_is_live(live, now + dt.timedelta(minutes=61), idle=60, absolute=12)
    assert not login_is_live(live, now, idle=60, absolute=1)
    live.ended_at = now
    assert not login_is_live(live, now, idle=60, absolute=12)


def test_a_cookie_from_before_kept_logins_is_refused(app, web):
    """The old cookie held the user id alone: anyone who could sign one was anyone."""
    user_id = web.user()
    client = app.test_client()
    with client.session_transaction() as session:
        session["user_id"] = user_id
    assert client.get(DASHBOARD).status_code == 302


@pytest.mark.parametrize(
    "password,problem",
    [
        ("password", "at least 12 characters"),
        ("12345678", "at least 12 characters"),
        ("password1234", "common password"),
        ("aaaaaaaaaaaa", "common password"),
        ("qwertyuiop123", "common password"),
        ("x" * 129, "at most 128 characters"),
    ],
)
def test_weak_passwords_are_refused(password, problem):
    assert problem in (password_problem(password) or "")


def test_good_passphrases_pass():
    for password in ("correct horse battery", "Tr0ub4dor&3-staple", "facepair-demo-2026"):
        assert password_problem(password) is None, password
    assert is_common("iloveyou1234") and not is_common("correct horse battery")


@pytest.mark.parametrize("email", ["not-an-email", "a@b", "two@@example.org", "x@example"])
def test_addresses_that_are_not_e_mail_are_refused(app, email):
    with app.app_context(), pytest.raises(InputError) as caught:
        create_user(email, "correct horse battery")
    assert str(caught.value).startswith("email: not an e-mail address")


def test_a_password_longer_than_the_estimator_reads_is_judged_not_a_crash():
    """zxcvbn raises on more than 72 characters; passwords may have 128."""
    import secrets

    assert password_problem(secrets.token_urlsafe(96)[:128]) is None
    assert "common password" in (password_problem("password" * 16) or "")


def test_the_accounts_own_words_do_not_make_a_password(app):
    assert "common password" in (password_problem("Alice.Smith.2026", "alice.smith@lab.org") or "")
    assert password_problem("Alice.Smith.2026", "bob@lab.org") is None
    assert "common password" in (password_problem("Summer2026!!") or "")


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(email=st.text(max_size=60), password=st.text(max_size=140))
def test_any_account_input_is_an_account_or_one_line(app, email, password):
    with app.app_context():
        try:
            create_user(email, password)
        except InputError as exc:
            assert "\n" not in str(exc) and str(exc).split(":")[0] in ("email", "password")
        finally:
            db.session.rollback()


def test_an_unknown_e_mail_costs_what_a_wrong_password_does(app, web, monkeypatch):
    """Both run one password hash of the configured method (production's scrypt here), so an
    unknown address cannot be told from a known one by the time the answer takes. Checked by
    the hashes run, not by a clock: timings on a shared machine vary by more than the gap
    (before the dummy hash, an unknown address took about 1/15 of a known one)."""
    import app.web.infra.accounts as accounts
    import app.web.models as models

    method = "scrypt:32768:8:1"
    app.config["PASSWORD_HASH_METHOD"] = method
    web.user()
    checked: list[str] = []

    def recording(real):
        def check(pwhash, password):
            checked.append(pwhash.split("$", 1)[0])
            return real(pwhash, password)

        return check

    for module in (accounts, models):
        monkeypatch.setattr(module, "check_password_hash", recording(module.check_password_hash))

    def hashes_run(email):
        checked.clear()
        with app.app_context():
            assert authenticate(email, "wrong password") is None
        return list(checked)

    assert hashes_run("exp@example.org") == [method]
    assert hashes_run("nobody@example.org") == [method]
    assert hashes_run("not an address" * 40) == [method]  # too long for the column: no query


def test_an_address_flood_does_not_lock_out_a_known_device(app, web):
    """20 failures a minute from a lab's NAT address lock that address; the experimenter whose
    browser logged in before (the device cookie) still gets in with the right password."""
    web.user()
    mine = app.test_client()
    assert web.login(mine).status_code == 302  # the device cookie is issued
    assert _post(mine, "/experimenter/logout").status_code == 302
    attacker = app.test_client()  # same address: the test clients share 127.0.0.1
    codes = [web.login(attacker, f"nobody{i}@example.org").status_code for i in range(25)]
    assert 429 in codes
    assert web.login(app.test_client()).status_code == 429  # an unknown browser: limited
    assert web.login(mine).status_code == 302  # the known one: in


def test_an_account_flood_does_not_lock_out_its_owner(app, web):
    web.user()
    mine = app.test_client()
    assert web.login(mine).status_code == 302
    attacker = app.test_client()
    attacker.environ_base["REMOTE_ADDR"] = "10.6.6.6"
    codes = [web.login(attacker, password=f"guess {i}").status_code for i in range(10)]
    assert codes[-1] == 429 and web.login(attacker).status_code == 429
    assert web.login(mine).status_code == 302


def test_cli_add_errors_are_one_line(app, monkeypatch, tmp_path):
    from tests.support.cli import cli_env

    cli_env(monkeypatch, app)
    runner = CliRunner()
    ok = runner.invoke(
        main, ["experimenter", "add", "lab@example.org", "--password", "a long passphrase"]
    )
    assert ok.exit_code == 0, ok.output
    for args, fragment in (
        (["lab@example.org", "--password", "another long one"], "already exists"),
        (["not-an-email", "--password", "another long one"], "not an e-mail address"),
        (["x@example.org", "--password", "password1234"], "common password"),
    ):
        result = runner.invoke(main, ["experimenter", "add", *args])
        lines = [ln for ln in result.output.splitlines() if ln.strip()]
        assert result.exit_code == 2 and len(lines) == 1 and fragment in lines[0], result.output


def test_cli_against_an_unmigrated_database_is_one_line(monkeypatch, tmp_path):
    monkeypatch.setenv("DATABASE_URL", f"sqlite:///{tmp_path}/empty.db")
    monkeypatch.setenv("FACEPAIR_INSTANCE", str(tmp_path / "instance"))
    for args in (
        ["experimenter", "add", "lab@example.org", "--password", "a long passphrase"],
        ["study", "list"],
    ):
        result = CliRunner().invoke(main, args)
        lines = [ln for ln in result.output.splitlines() if ln.strip()]
        assert result.exit_code == 2 and len(lines) == 1, result.output
        assert "facepair db upgrade" in lines[0] and "Traceback" not in result.output


def test_cli_password_change_ends_logins(app, monkeypatch, web):
    from tests.support.cli import cli_env

    client = _logged_in(app, web)
    cli_env(monkeypatch, app)
    result = CliRunner().invoke(
        main, ["experimenter", "password", "exp@example.org", "--password", "a fresh passphrase"]
    )
    assert result.exit_code == 0 and "1 login(s) ended" in result.output, result.output
    assert client.get(DASHBOARD).status_code == 302
    with app.app_context():
        assert db.session.scalar(sa.select(User.email)) == "exp@example.org"


def _unlock_link(app, monkeypatch, email="exp@example.org") -> str:
    """``facepair experimenter unlock`` run with the server's key; returns the printed link."""
    import secrets

    from tests.support.cli import cli_env

    key = secrets.token_hex(32)
    app.config["SECRET_KEY"] = key  # the server's key, as the command reads it
    cli_env(monkeypatch, app)
    monkeypatch.setenv("SECRET_KEY", key)
    result = CliRunner().invoke(
        main, ["experimenter", "unlock", email, "--site", "https://studies.example.org/"]
    )
    assert result.exit_code == 0, result.output
    link = result.output.split()[-1]
    assert link.startswith("https://studies.example.org/experimenter/login?unlock="), link
    return link.removeprefix("https://studies.example.org")


def test_an_owner_held_at_429_from_a_new_browser_gets_in_with_an_unlock_link(app, web, monkeypatch):
    """An attacker's failures hold the account at 429, and the owner's browser never logged
    in before (no device cookie): the unlock link gives it a count of its own, and the right
    password then passes; a wrong one still fails, and the attacker stays held."""
    app.config["LOGIN_LIMIT_PER_ACCOUNT"] = "5 per hour"  # a slow run outlasts a minute
    web.user()
    # made first: the command's app, in this process, starts the limiter's memory afresh
    link = _unlock_link(app, monkeypatch)
    attacker = app.test_client()
    attacker.environ_base["REMOTE_ADDR"] = "10.6.6.6"
    codes = [web.login(attacker, password=f"guess {i}").status_code for i in range(10)]
    assert codes[-1] == 429
    owner = app.test_client()
    held = web.login(owner)
    page = held.get_data(as_text=True)
    assert held.status_code == 429 and "facepair experimenter unlock" in page
    opened = owner.get(link)
    assert opened.status_code == 200 and "may now log in as exp@example.org" in opened.get_data(
        as_text=True
    )
    assert web.login(owner, password="not the password").status_code == 200
    assert web.login(owner).status_code == 302
    assert web.login(attacker, password="guess 11").status_code == 429


def test_one_unlock_link_opened_many_times_is_one_count(app, web, monkeypatch):
    """A leaked link is one more bucket, not a new one at every opening."""
    app.config["LOGIN_LIMIT_PER_ACCOUNT"] = "5 per hour"
    web.user()
    link = _unlock_link(app, monkeypatch)
    first, second = app.test_client(), app.test_client()
    first.get(link)
    codes = [web.login(first, password=f"guess {i}").status_code for i in range(6)]
    assert codes[-1] == 429
    second.get(link)
    assert web.login(second, password="guess 7").status_code == 429


@pytest.mark.parametrize("token", ["", "x" * 40, "not.a.token", "A" * 600])
def test_a_bad_or_expired_unlock_link_changes_nothing(app, web, monkeypatch, token):
    web.user()
    browser = app.test_client()
    page = browser.get(f"/experimenter/login?unlock={token}")
    assert page.status_code == 200 and "fp-device" not in page.headers.get("Set-Cookie", "")
    if token:
        assert "not valid or has expired" in page.get_data(as_text=True)
    link = _unlock_link(app, monkeypatch)
    import app.web.experimenter.views as views

    monkeypatch.setattr(views, "UNLOCK_MINUTES", 0)
    with monkeypatch.context() as later:
        import time

        now = time.time()
        later.setattr(time, "time", lambda: now + 5)
        stale = browser.get(link)
    assert "not valid or has expired" in stale.get_data(as_text=True)
    assert "fp-device" not in stale.headers.get("Set-Cookie", "")


def test_unlock_names_an_unknown_experimenter_in_one_line(app, monkeypatch):
    from tests.support.cli import cli_env

    cli_env(monkeypatch, app)
    monkeypatch.setenv("SECRET_KEY", "a" * 64)
    weak = CliRunner().invoke(main, ["experimenter", "unlock", "exp@example.org"])
    assert weak.exit_code == 2 and weak.output.startswith("facepair: error: SECRET_KEY: guessable")
    import secrets

    monkeypatch.setenv("SECRET_KEY", secrets.token_hex(32))
    result = CliRunner().invoke(main, ["experimenter", "unlock", "nobody@example.org"])
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "no experimenter nobody@example.org" in lines[0]


@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(token=st.text(max_size=700))
def test_any_unlock_parameter_is_a_login_page(app, token):
    answer = app.test_client().get("/experimenter/login", query_string={"unlock": token})
    assert answer.status_code == 200
    assert "fp-device" not in answer.headers.get("Set-Cookie", "")
