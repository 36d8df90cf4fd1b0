"""The size check of ``make lint`` (tests/support/sizes.py): it names each module, function and
page script over its limit that its baseline does not allow, and passes on the repository."""

from __future__ import annotations

from pathlib import Path

from tests.support import sizes


def _tree(root: Path, body_lines: int, script_lines: int = 10) -> Path:
    """A tree with one module, ``app/study.py``, whose function ``Plan.build`` has
    ``body_lines`` lines after its ``def``, and one page script of ``script_lines`` lines."""
    (root / "app").mkdir(parents=True, exist_ok=True)
    body = "".join(f"        x{i} = {i}\n" for i in range(body_lines))
    (root / "app" / "study.py").write_text(f"class Plan:\n    def build(self):\n{body}")
    static = root / "app" / "web" / "static"
    static.mkdir(parents=True, exist_ok=True)
    (static / "page.js").write_text("var a;\n" * script_lines)
    return root


def _check(root: Path, capsys) -> tuple[int, list[str]]:
    code = sizes.main(["--root", str(root), "--baseline", str(root / "baseline.txt")])
    return code, capsys.readouterr().out.splitlines()


def test_an_over_long_function_fails_the_check(tmp_path, capsys):
    code, out = _check(_tree(tmp_path, 120), capsys)
    assert code == 1
    line = "app/study.py:Plan.build: 121 lines (limit 100): over the limit, not in the baseline"
    assert line in out


def test_the_baseline_allows_what_it_lists_and_no_more(tmp_path, capsys):
    root = _tree(tmp_path, 120, script_lines=450)
    sizes.main(["--root", str(root), "--baseline", str(root / "baseline.txt"), "--write"])
    capsys.readouterr()
    assert sizes.read_baseline(root / "baseline.txt") == {
        "app/study.py:Plan.build": 121,
        "app/web/static/page.js": 450,
    }
    code, out = _check(root, capsys)
    assert code == 0 and "app/study.py:Plan.build: 121 lines (limit 100): in the baseline" in out
    # grown past its recorded size: fails, naming the file, the function and both sizes
    code, out = _check(_tree(root, 125, script_lines=450), capsys)
    assert code == 1
    assert "app/study.py:Plan.build: 126 lines (limit 100): grew past its baseline of 121" in out
    # back under the limit: passes, and says the item can leave the baseline
    code, out = _check(_tree(root, 50, script_lines=450), capsys)
    assert code == 0
    assert any(line.startswith("app/study.py:Plan.build: 51 lines, back under") for line in out)


def test_a_long_page_script_fails_the_check(tmp_path, capsys):
    code, out = _check(_tree(tmp_path, 5, script_lines=401), capsys)
    assert code == 1
    line = "app/web/static/page.js: 401 lines (limit 400): over the limit, not in the baseline"
    assert line in out


def test_the_repository_passes(capsys):
    """Nothing over its limit that the committed baseline does not allow."""
    code = sizes.main([])
    assert code == 0, "\n".join(capsys.readouterr().out.splitlines()[-20:])


def test_a_long_module_fails_the_check(tmp_path, capsys):
    code, out = _check(_tree(tmp_path, 450), capsys)
    assert code == 1
    assert "app/study.py: 452 lines (limit 400): over the limit, not in the baseline" in out
