"""R as the reference the analysis is compared with: ``Rscript`` and the packages lme4,
BradleyTerry2 and psychotools, all from Debian (`make test` installs r-base-core, r-cran-lme4,
r-cran-bradleyterry2 and r-cran-psychotools).

A test that needs R calls :func:`run_r`. Without Rscript or a package it skips on a developer's
machine and fails in CI (``CI=true``), so the reference can never silently drop out of the suite.
Nothing here is part of the application.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

PACKAGES = ("lme4", "BradleyTerry2", "psychotools")
TIMEOUT_S = 600


def _missing(what: str) -> None:
    message = f"{what}: `make test` installs R and its packages from Debian"
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(message)
    pytest.skip(message)


def rscript() -> str:
    """The path of Rscript, or skip (fail in CI)."""
    path = shutil.which("Rscript")
    if path is None:
        _missing("Rscript not found")
    assert path is not None
    return path


def run_r(script: str, workdir: Path, *, packages: tuple[str, ...] = ()) -> Any:
    """Run an R ``script`` in ``workdir``; the script writes its answer as JSON to the file
    ``out.json`` (``jsonlite`` is not in base R: the script writes it with ``cat``, numbers
    as ``format(x, digits = 17)``). Returns the parsed answer."""
    exe = rscript()
    for package in packages:
        check = subprocess.run(
            [exe, "-e", f"quit(status = !requireNamespace('{package}', quietly = TRUE))"],
            capture_output=True,
            timeout=TIMEOUT_S,
        )
        if check.returncode != 0:
            _missing(f"the R package {package} is not installed")
    path = workdir / "reference.R"
    path.write_text(PRELUDE + script)
    done = subprocess.run(
        [exe, "--vanilla", str(path)],
        cwd=workdir,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    if done.returncode != 0:
        raise AssertionError(f"R failed ({done.returncode}):\n{done.stderr[-4000:]}")
    return json.loads((workdir / "out.json").read_text())


#: ``put(name = value, ...)`` collects numbers; ``write_out()`` writes them as one JSON object.
PRELUDE = r"""
.out <- list()
put <- function(...) { a <- list(...); for (k in names(a)) .out[[k]] <<- as.numeric(a[[k]]) }
write_out <- function() {
  items <- vapply(names(.out), function(k) {
    v <- .out[[k]]
    s <- ifelse(is.finite(v), format(v, digits = 17, scientific = TRUE), "null")
    paste0('"', k, '": [', paste(s, collapse = ", "), "]")
  }, "")
  writeLines(paste0("{", paste(items, collapse = ", "), "}"), "out.json")
}
"""
