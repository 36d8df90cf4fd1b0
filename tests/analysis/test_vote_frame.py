"""The memory helpers of :mod:`app.analysis.vote_frame`."""

from __future__ import annotations

import pyarrow as pa
import pytest

from app.analysis.vote_frame import system_allocator


def test_arrow_allocates_on_the_c_heap_inside_and_as_before_after() -> None:
    before = pa.default_memory_pool().backend_name
    with system_allocator():
        assert pa.default_memory_pool().backend_name == "system"
        made = pa.array(["a", "b"] * 10)
    assert pa.default_memory_pool().backend_name == before
    assert made.to_pylist()[:2] == ["a", "b"]  # still readable from its own pool


def test_the_pool_comes_back_when_the_step_fails() -> None:
    before = pa.default_memory_pool().backend_name

    @system_allocator()
    def fails() -> None:
        raise ValueError("bad row")

    with pytest.raises(ValueError):
        fails()
    assert pa.default_memory_pool().backend_name == before
