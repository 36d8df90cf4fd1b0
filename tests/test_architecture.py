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
#: The packages whose modules may import no circle, and what is left out of them: Alembic's
#: migration scripts, which nothing imports.
GRAPHED = ("app", "renderer")
NOT_GRAPHED = ("app/web/migrations",)


def _files(pattern: str) -> list[Path]:
    if pattern.endswith(".py"):
        return sorted(REPO.glob(pattern))
    return sorted((REPO / pattern).rglob("*.py"))


def _module_name(path: Path, root: Path = REPO) -> str:
    if not path.is_relative_to(root):
        return path.stem
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path, root: Path = REPO, *, type_checking: bool = True) -> list[tuple[str, bool]]:
    """Every module ``path`` imports, absolute, with whether the import is at module level
    (run on import) rather than inside a function or an ``if TYPE_CHECKING`` block; with
    ``type_checking=False`` the imports of an ``if TYPE_CHECKING`` block (which never run) are
    left out. Module names are relative to ``root``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    name = _module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: list[tuple[str, bool]] = []

    def visit(node: ast.AST, top: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inner = top and not isinstance(
                child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)
            )
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                if type_checking:
                    visit(child, False)
                else:  # its ``else`` runs
                    visit(ast.Module(body=child.orelse, type_ignores=[]), top)
                continue
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


def import_graph(
    root: Path, packages: tuple[str, ...], left_out: tuple[str, ...] = ()
) -> dict[str, dict[str, bool]]:
    """Each module of ``packages`` (folders under ``root``) -> the modules of the same packages
    it imports, each with whether some import of it is at module level; imports inside a
    function count, those of an ``if TYPE_CHECKING`` block do not (they never run).

    An import names what it imports, as :func:`imports` reads it: ``import a.b`` and
    ``from a.b import f`` the module ``a.b``; ``from a import b`` the package ``a`` (whose
    namespace is asked for ``b``) and, where ``b`` is a module, the module ``a.b`` too. The
    package ``a`` that Python initialises before loading ``a.b`` is not an edge of ``a.b``'s
    importer: a package's ``__init__`` may import its own modules (it is their facade) while
    they import each other by their full names.
    """
    skipped = tuple(root / folder for folder in left_out)
    paths = {
        _module_name(path, root): path
        for package in packages
        for path in sorted((root / package).rglob("*.py"))
        if not any(path.is_relative_to(folder) for folder in skipped)
    }
    graph: dict[str, dict[str, bool]] = {}
    for module, path in paths.items():
        edges = graph.setdefault(module, {})
        for name, top in imports(path, root, type_checking=False):
            if name in paths and name != module:
                edges[name] = edges.get(name, False) or top
    return graph


def import_circles(graph: dict[str, dict[str, bool]]) -> list[tuple[str, ...]]:
    """The strongly connected components of ``graph`` with more than one module, each sorted:
    the modules each of which imports, directly or through the others, every other one."""

    def reachable(start: str) -> set[str]:
        seen: set[str] = set()
        todo = [start]
        while todo:
            for name in graph[todo.pop()]:
                if name not in seen:
                    seen.add(name)
                    todo.append(name)
        return seen

    reach = {module: reachable(module) for module in graph}
    components = {
        tuple(sorted(other for other in reach[module] if module in reach[other]))
        for module in graph
        if module in reach[module]
    }
    return sorted(c for c in components if len(c) > 1)


def _describe(circle: tuple[str, ...], graph: dict[str, dict[str, bool]]) -> str:
    arrows = [
        f"    {module} -> {name}" + ("" if top else " (in a function)")
        for module in circle
        for name, top in sorted(graph[module].items())
        if name in circle
    ]
    return "\n".join([f"{len(circle)} modules: {', '.join(circle)}", *arrows])


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


def test_no_import_circles() -> None:
    """No import circle between the modules of ``app`` and ``renderer``: each module can be
    read, tested and moved after those it imports. An import inside a function counts (it only
    puts the circle off until the first call); an ``if TYPE_CHECKING`` one does not.

    How a package's ``__init__`` counts (:func:`import_graph`): its imports of its own modules
    are edges like any others (they run when the package loads; leaving them out would hide
    every circle through a package), and a package that re-exports its modules (a facade)
    stands above them. Those modules import each other by their full names
    (``from renderer.face import Face``, ``import renderer.defaults as defaults``): importing a
    module is not an import of the packages above it, which Python initialises first. What a
    module takes from a package is an edge to that package's ``__init__``: a name it defines
    (``from app.stimuli.conditions import DISPLAY_NAMES``) or one of its modules asked of it
    (``from renderer import defaults``). So a module that takes something from its own package,
    which imports the module back, is a circle; what both need goes in a module named for what
    it is (a blueprint's ``bp`` in its ``blueprint.py``)."""
    graph = import_graph(REPO, GRAPHED, NOT_GRAPHED)
    assert len(graph) > 200  # the globs still find the project
    circles = import_circles(graph)
    assert not circles, "import circles:\n" + "\n".join(_describe(c, graph) for c in circles)


def test_the_check_sees_an_import_circle(tmp_path: Path) -> None:
    """The check above can fail: a module that takes a name from its own package inside a
    function, relatively, while the package imports it, is a circle; imports that only a type
    checker reads, and a package importing the modules that import each other, are not."""
    package = tmp_path / "pkg"
    (package / "sub").mkdir(parents=True)
    files = {
        "__init__.py": "from typing import TYPE_CHECKING\nfrom pkg.shapes import Shape\n"
        "NAMES = {}\nif TYPE_CHECKING:\n    from pkg.later import Later\n",
        "shapes.py": "class Shape:\n    def name(self):\n        from . import NAMES\n",
        "later.py": "from pkg import shapes\nfrom pkg.sub.leaf import LEAF\n",
        "sub/__init__.py": "from pkg.sub.leaf import LEAF\n",
        "sub/leaf.py": "import pkg.sub.other\nLEAF = 1\n",
        "sub/other.py": "",
    }
    for name, text in files.items():
        (package / name).write_text(text, encoding="utf-8")
    graph = import_graph(tmp_path, ("pkg",))
    assert graph["pkg.shapes"] == {"pkg": False}
    assert graph["pkg.later"] == {"pkg": True, "pkg.shapes": True, "pkg.sub.leaf": True}
    assert "pkg.later" not in graph["pkg"]
    assert graph["pkg.sub.leaf"] == {"pkg.sub.other": True}
    circles = import_circles(graph)
    assert circles == [("pkg", "pkg.shapes")]
    assert "pkg.shapes -> pkg (in a function)" in _describe(circles[0], graph)


def _test_module_imports(root: Path) -> list[str]:
    """Every import of one test module by another under ``root``/tests, as "file: module"."""
    found = []
    for path in sorted((root / "tests").rglob("*.py")):
        for name, _top in imports(path, root):
            if name.startswith("tests.") and name.rpartition(".")[2].startswith("test_"):
                found.append(f"{path.relative_to(root)}: {name}")
    return found


def test_test_modules_never_import_each_other() -> None:
    """A helper two test modules share lives in ``tests/support/`` (or a ``conftest.py``),
    not in one of them: a test module is run, not imported."""
    assert _test_module_imports(REPO) == []


def test_the_check_sees_a_test_module_imported(tmp_path: Path) -> None:
    (tmp_path / "tests" / "web").mkdir(parents=True)
    (tmp_path / "tests" / "web" / "test_a.py").write_text("def helper():\n    return 1\n")
    (tmp_path / "tests" / "test_b.py").write_text(
        "def test_b():\n    from tests.web.test_a import helper\n\n    assert helper() == 1\n"
    )
    assert _test_module_imports(tmp_path) == ["tests/test_b.py: tests.web.test_a"]
