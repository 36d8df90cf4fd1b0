"""Progress of a job made of a known number of steps, for a caller's progress bar.

Example
-------
>>> seen = []
>>> step = progress_steps(lambda done, total: seen.append((done, total)), 2)
>>> step(); step(); seen
[(1, 2), (2, 2)]
"""

from __future__ import annotations

from collections.abc import Callable

#: ``progress(done, total)``, called after each step.
Progress = Callable[[int, int], None]


def progress_steps(progress: Progress | None, total: int) -> Callable[[], None]:
    """A function to call after each of ``total`` steps: it reports ``progress(done, total)``
    (nothing when ``progress`` is None)."""
    done = 0

    def step() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    return step
