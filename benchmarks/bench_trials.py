"""Print how long the trials package takes for what the web layer does per request.

Run: ``PYTHONPATH=$PWD python benchmarks/bench_trials.py``. A participant's page rebuilds the
schedule from the stored seed (so resuming needs no stored order), an arrival chooses a list,
and creating a study parses its file; these are the figures to watch.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from app.trials.assignment import choose_list, initial_counts
from app.trials.design import build_pairs
from app.trials.schedule import make_schedule, n_lists_for, participant_seed
from app.trials.studyfile import load_study_file

REPO = Path(__file__).resolve().parent.parent


def timed(label: str, call: Callable[[], object], repeat: int) -> None:
    """Print the median and the 95th percentile of ``repeat`` calls, in milliseconds."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append((time.perf_counter() - start) * 1000.0)
    times.sort()
    p95 = times[min(len(times) - 1, int(0.95 * len(times)))]
    print(f"{label:<60} median {statistics.median(times):8.3f} ms   p95 {p95:8.3f} ms")


def schedule_case(design: str, n_conditions: int, n_clips: int, catch: int) -> None:
    conditions = [f"c{i}" for i in range(n_conditions)]
    clips = [f"s{j}" for j in range(n_clips)]
    reference = conditions[0] if design == "reference" else None
    pairs = build_pairs(conditions, design, reference=reference)
    n_lists = n_lists_for(design, n_clips=n_clips)
    seed = participant_seed(2005, 17)

    def build() -> object:
        return make_schedule(
            clips=clips,
            pairs=pairs,
            design=design,
            seed=seed,
            list_index=n_lists - 1,
            n_lists=n_lists,
            catch_trials=catch,
        )

    n_trials = len(build())  # type: ignore[arg-type]
    timed(f"make_schedule {design} {n_conditions}x{n_clips} ({n_trials} trials)", build, 200)


def main() -> None:
    print("trials package benchmark (figures taken on a shared, loaded machine)")
    schedule_case("all_ordered", 4, 2, 2)  # the thesis' experiment 1
    schedule_case("reference", 5, 10, 4)  # the 2012 head motion study
    schedule_case("unordered_counterbalanced", 6, 10, 4)
    schedule_case("all_ordered", 10, 20, 10)  # a large study
    counts = initial_counts(40)
    rng = np.random.default_rng(0)
    timed("choose_list over 40 lists", lambda: choose_list(counts, rng), 2000)
    example = REPO / "app" / "data" / "examples" / "study.toml"
    timed(
        "load_study_file app/data/examples/study.toml (no file checks)",
        lambda: load_study_file(example, check_files=False),
        200,
    )

    arrivals, drop_rate, n_lists = 2000, 0.3, 12
    counts = initial_counts(n_lists)
    events = np.random.default_rng(1)
    held: list[int] = []  # the lists of participants who have arrived and not dropped out
    worst = 0
    for _ in range(arrivals):
        chosen = choose_list(counts, rng)
        counts[chosen] += 1
        held.append(chosen)
        if events.random() < drop_rate:  # someone who arrived earlier gives the slot back
            counts[held.pop(int(events.integers(len(held))))] -= 1
        worst = max(worst, max(counts.values()) - min(counts.values()))
    print(
        f"{arrivals} arrivals over {n_lists} lists, {drop_rate:.0%} drop-outs: "
        f"largest spread of the assignment table {worst}"
    )


if __name__ == "__main__":
    main()
