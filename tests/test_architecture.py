"""The import arrows of docs/developer/architecture.md, read from the source with ``ast``.

The pure packages (``app.stimuli``, ``app.trials``, ``app.analysis``, ``app.leaderboard``,
``renderer``) import
neither a web framework nor the web layer; the web layer never imports moderngl or the GL
context, and loads the renderer only inside the job that renders.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
PURE = ("app/stimuli", "app/trials", "app/analysis", "app/leaderboard", "renderer")
#: What the pure packages may import from the project besides each other: the package root
#: (its version; Flask is imported inside ``create_app`` only), errors and shipped data.
SHARED = ("app", "app.errors", "app.data")
WEB_FRAMEWORKS = (
    "flask",
    "flask_sqlalchemy",
    "flask_migrate",
    "flask_wtf",
    "flask_limiter",
    "werkzeug",
    "wtforms",
    "sqlalchemy",
    "rq",
    "redis",
    "gunicorn",
)
WEB = ("app/web",)
#: The blueprints: they call the services, never each other.
BLUEPRINTS = (
    "app.web.api",
    "app.web.participant",
    "app.web.experimenter",
    "app.web.questionnaire",
    "app.web.leaderboard",
)
#: The services and what they stand on: no request handling, so no blueprint.
SERVICES = ("app/web/study", "app/web/infra", "app/web/jobs", "app/web/prolific", "app/web/board")
GL = ("moderngl", "renderer.gl")


def _files(pattern: str) -> list[Path]:
    if pattern.endswith(".py"):
        return sorted(REPO.glob(pattern))
    return sorted((REPO / pattern).rglob("*.py"))


def _module_name(path: Path) -> str:
    if not path.is_relative_to(REPO):
        return path.stem
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> list[tuple[str, bool]]:
    """Every module ``path`` imports, absolute, with whether the import is at module level
    (run on import) rather than inside a function or an ``if TYPE_CHECKING`` block."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = (
        _module_name(path) if path.name == "__init__.py" else _module_name(path).rpartition(".")[0]
    )
    found: list[tuple[str, bool]] = []

    def visit(node: ast.AST, top: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = top and not isinstance(
                child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)
            )
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                inner = False
            if isinstance(child, ast.Import):
                found.extend((alias.name, top) for alias in child.names)
            elif isinstance(child, ast.ImportFrom):
                base = child.module or ""
                if child.level:
                    anchor = package.split(".")[: len(package.split(".")) - child.level + 1]
                    base = ".".join([*anchor, base] if base else anchor)
                found.append((base, top))
                # ``from app import design`` imports the module app.design.
                found.extend((f"{base}.{alias.name}", top) for alias in child.names)
            visit(child, inner)

    visit(tree, True)
    return found


def _is(name: str, prefixes: tuple[str, ...]) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def _project_module_exists(name: str) -> bool:
    path = REPO.joinpath(*name.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


@pytest.mark.parametrize("package", PURE)
def test_pure_packages_import_no_web(package: str) -> None:
    pure = tuple(p.replace("/", ".") for p in PURE)
    bad = []
    for path in _files(package):
        for name, _ in imports(path):
            web_module = (
                _is(name, ("app",))
                and not _is(name, pure)
                and name not in SHARED
                and _project_module_exists(name)
            )
            if _is(name, WEB_FRAMEWORKS) or web_module:
                bad.append(f"{path.relative_to(REPO)}: {name}")
    assert not bad, bad


def test_the_web_never_imports_gl_and_loads_the_renderer_only_in_a_job() -> None:
    bad = []
    web = [path for pattern in WEB for path in _files(pattern)]
    assert len(web) > 20  # the globs still find the web layer
    for path in web:
        for name, top in imports(path):
            if _is(name, GL) or (top and _is(name, ("renderer",))):
                bad.append(f"{path.relative_to(REPO)}: {name}")
    assert not bad, bad


def test_blueprints_never_import_each_other() -> None:
    bad = []
    for blueprint in BLUEPRINTS:
        for path in _files(blueprint.replace(".", "/")):
            for name, _ in imports(path):
                others = tuple(b for b in BLUEPRINTS if b != blueprint)
                if _is(name, others):
                    bad.append(f"{path.relative_to(REPO)}: {name}")
    assert not bad, bad


def test_services_never_import_blueprints() -> None:
    bad = [
        f"{path.relative_to(REPO)}: {name}"
        for package in SERVICES
        for path in _files(package)
        for name, _ in imports(path)
        if _is(name, BLUEPRINTS)
    ]
    assert not bad, bad


def test_the_package_root_imports_no_web() -> None:
    """``app/__init__.py`` holds the version alone, so a type checker that follows a pure
    package's ``from app.errors import ...`` never walks the web application."""
    names = [name for name, _ in imports(REPO / "app" / "__init__.py")]
    assert not [n for n in names if _is(n, WEB_FRAMEWORKS) or _is(n, ("app.web",))], names


def test_trials_never_import_analysis() -> None:
    # the vote vocabulary lives in app.trials.rules and analysis reads it, not the reverse
    bad = [
        f"{path.relative_to(REPO)}: {name}"
        for path in _files("app/trials")
        for name, _ in imports(path)
        if _is(name, ("app.analysis",))
    ]
    assert not bad, bad


def test_the_check_sees_a_forbidden_import(tmp_path: Path) -> None:
    """The checks above can fail: a function-level Flask import and a relative web import
    are both found."""
    source = tmp_path / "mod.py"
    source.write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import moderngl\n"
        "def f():\n    from flask import g\n    from ..models import Vote\n",
        encoding="utf-8",
    )
    names = imports(source)
    assert ("moderngl", False) in names
    assert ("flask", False) in names
    assert any(name.endswith("models.Vote") for name, _ in names)
