"""The built-in benchmark suite of ``blockmpec compare``."""

from __future__ import annotations

from typing import Any

#: The built-in benchmark suite of ``blockmpec compare``: label -> (case, parameters).
#: Sizes keep the default run (every method, with the time limits of
#: ``BENCHMARK_METHOD_OPTIONS``) within a few minutes on 2 cores.
BENCHMARK_SUITE: dict[str, tuple[str, dict[str, Any]]] = {
    "two-blocks": ("two-blocks", {"eta": 3.0, "mu": 0.65}),
    "round-arch": ("round-arch", {}),
    "arch-on-buttresses": ("arch-on-buttresses", {}),
    "wall-4x2-stack": ("wall", {"courses": 4, "blocks_per_course": 2, "bond": "stack"}),
    "wall-5x4": ("wall", {"courses": 5, "blocks_per_course": 4}),
    "wall-10x5": ("wall", {"courses": 10, "blocks_per_course": 5}),
}
