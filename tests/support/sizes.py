"""The size check of ``make lint``: the modules, functions and page scripts that outgrew the
house's limits (a module that grows past about 400 lines holds two ideas).

The limits: a Python module of ``app/``, ``renderer/`` or ``benchmarks/`` over
:data:`MODULE_LINES` lines, a function or method in one over :data:`FUNCTION_LINES` lines (from
its ``def`` to its last line, nested functions counted in the one around them as well), a script
under ``app/web/static`` over :data:`SCRIPT_LINES` lines. The migrations Alembic writes are left
out, as ruff leaves them.

What was over the limits when the check came in is listed, with its size, in
:data:`BASELINE` (``sizes-baseline.txt`` beside this file), so the check holds the line without
blocking that code: ``python -m tests.support.sizes`` prints every item over its limit and fails
(exit 1, one line per offender) when an item not in the baseline is over, or a baselined item
grew past its recorded size. A baselined item that is back under its limit (or gone) is named,
to be taken out of the baseline; one that shrank but is still over may have its size lowered
there. ``--write`` rewrites the baseline from the tree as it is (review its diff: it must only
ever lose lines or shrink). Nothing here is part of the application.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BASELINE = Path(__file__).with_name("sizes-baseline.txt")
MODULE_LINES = 400
FUNCTION_LINES = 100
SCRIPT_LINES = 400
#: The folders whose Python modules are measured, and the one whose page scripts are.
PYTHON_FOLDERS = ("app", "renderer", "benchmarks")
SCRIPT_FOLDER = "app/web/static"
#: Written by Alembic, reviewed by hand, never restyled (pyproject.toml's ruff exclude).
LEFT_OUT = ("app/web/migrations",)
HEADER = """\
# Over-size items that predate the size check (tests/support/sizes.py), with their sizes in
# lines: `make lint` fails when one grows or a new one appears. Take an item out once it is
# back under its limit; never add one by hand.
"""


@dataclass(frozen=True)
class Item:
    """One measured thing: ``name`` is a file's path from the repository root, or
    ``path:Qualified.function`` for a function; ``limit`` is the most lines it may have."""

    name: str
    lines: int
    limit: int

    @property
    def over(self) -> bool:
        return self.lines > self.limit


def _lines(text: str) -> int:
    return len(text.splitlines())


def functions(tree: ast.AST, prefix: str = "") -> Iterator[tuple[str, int]]:
    """Every function and method in ``tree`` with its qualified name (``Class.method``,
    ``outer.inner``) and its length in lines, from its ``def`` to its last line.

    >>> tree = ast.parse("class A:\\n    def f(self):\\n        def g():\\n            pass\\n")
    >>> list(functions(tree))
    [('A.f', 3), ('A.f.g', 2)]
    """
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            name = f"{prefix}{node.name}"
            if not isinstance(node, ast.ClassDef):
                yield name, (node.end_lineno or node.lineno) - node.lineno + 1
            yield from functions(node, f"{name}.")
        else:
            yield from functions(node, prefix)


def measure_python(path: Path, name: str) -> Iterator[Item]:
    """The module at ``path`` (called ``name`` in the report) and each of its functions."""
    text = path.read_text(encoding="utf-8")
    yield Item(name, _lines(text), MODULE_LINES)
    longest: dict[str, int] = {}
    for qualified, lines in functions(ast.parse(text, filename=str(path))):
        # Two definitions of one name (e.g. in the branches of an if) count as the longer.
        longest[qualified] = max(lines, longest.get(qualified, 0))
    for qualified, lines in longest.items():
        yield Item(f"{name}:{qualified}", lines, FUNCTION_LINES)


def measure(root: Path = ROOT) -> list[Item]:
    """Every module, function and page script under ``root`` that the check covers."""
    items: list[Item] = []
    for folder in PYTHON_FOLDERS:
        for path in sorted((root / folder).rglob("*.py")):
            name = path.relative_to(root).as_posix()
            if not name.startswith(LEFT_OUT):
                items.extend(measure_python(path, name))
    for path in sorted((root / SCRIPT_FOLDER).rglob("*.js")):
        text = path.read_text(encoding="utf-8")
        items.append(Item(path.relative_to(root).as_posix(), _lines(text), SCRIPT_LINES))
    return items


def read_baseline(path: Path) -> dict[str, int]:
    """The baseline's items and their recorded sizes (``name lines`` a line; ``#`` comments)."""
    if not path.exists():
        return {}
    recorded: dict[str, int] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, lines = line.rsplit(maxsplit=1)
            recorded[name] = int(lines)
    return recorded


def write_baseline(path: Path, items: Iterable[Item]) -> None:
    """The items over their limits, as the baseline."""
    body = "".join(f"{item.name} {item.lines}\n" for item in items if item.over)
    path.write_text(HEADER + body, encoding="utf-8")


def check(items: list[Item], recorded: dict[str, int]) -> tuple[list[str], list[str], list[str]]:
    """The report on ``items`` against the baseline ``recorded``: the items over their limits
    that the baseline allows, the offenders (new, or grown past their recorded size) and the
    baselined items that can be taken out (back under their limit, or gone); a line each."""
    allowed: list[str] = []
    offenders: list[str] = []
    found = {item.name: item for item in items}
    for item in items:
        if not item.over:
            continue
        size = f"{item.name}: {item.lines} lines (limit {item.limit})"
        if item.name not in recorded:
            offenders.append(f"{size}: over the limit, not in the baseline")
        elif item.lines > recorded[item.name]:
            offenders.append(f"{size}: grew past its baseline of {recorded[item.name]}")
        elif item.lines < recorded[item.name]:
            allowed.append(f"{size}: baseline {recorded[item.name]}, may be lowered")
        else:
            allowed.append(f"{size}: in the baseline")
    removable = []
    for name in sorted(recorded):
        item = found.get(name)
        if item is None:
            removable.append(f"{name}: gone; take it out of the baseline")
        elif not item.over:
            removable.append(
                f"{name}: {item.lines} lines, back under the limit of {item.limit}; "
                "take it out of the baseline"
            )
    return allowed, offenders, removable


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m tests.support.sizes", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--root", type=Path, default=ROOT, help="the tree to measure")
    parser.add_argument("--baseline", type=Path, default=BASELINE, help="the baseline file")
    parser.add_argument(
        "--write", action="store_true", help="rewrite the baseline from the tree as it is"
    )
    args = parser.parse_args(argv)
    items = measure(args.root)
    if args.write:
        write_baseline(args.baseline, items)
        print(f"{args.baseline.name}: {sum(item.over for item in items)} items over the limits")
        return 0
    allowed, offenders, removable = check(items, read_baseline(args.baseline))
    for line in allowed + removable + offenders:
        print(line)
    print(
        f"sizes: {len(allowed) + len(offenders)} items over the limits (modules {MODULE_LINES} "
        f"lines, functions {FUNCTION_LINES}, page scripts {SCRIPT_LINES}), "
        f"{len(offenders)} not allowed by {args.baseline.name}"
    )
    return 1 if offenders else 0


if __name__ == "__main__":
    sys.exit(main())
