"""Structures shared by several studies."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import blockmpec as bm


def wall_shape(spec: str) -> tuple[int, int]:
    """``(courses, blocks per course)`` of a running-bond wall named ``"CxB"``, e.g. ``"100x100"``."""
    try:
        courses, per_course = (int(v) for v in spec.strip().lower().split("x"))
    except ValueError:
        raise ValueError(f"wall {spec!r}: expected CxB, courses x blocks per course (e.g. 100x100)") from None
    return courses, per_course


def wall_shapes(specs: str) -> list[tuple[int, int]]:
    """:func:`wall_shape` of each name in a comma-separated list (empty names skipped)."""
    return [wall_shape(spec) for spec in specs.split(",") if spec.strip()]


def named_wall(spec: str, **options) -> bm.Structure:
    """The running-bond wall ``"CxB"`` of :func:`blockmpec.cases.wall` (``options``: e.g. ``mu``)."""
    courses, per_course = wall_shape(spec)
    return bm.cases.wall(courses=courses, blocks_per_course=per_course, **options)


def lowered_friction(structure: bm.Structure, fraction: float, seed: int = 1) -> bm.Structure:
    """``structure`` with every interface's friction coefficient ``mu_k`` lowered to ``mu_k (1 - fraction u_k)``,
    ``u_k`` uniform on [0, 1) from ``seed`` (the same draws for every fraction; 0: the structure itself).  Lowered
    friction breaks ties between equal interfaces and keeps every statically admissible stress field of the
    perturbed structure admissible for the structure itself."""
    friction = structure.interface_friction()
    draws = np.random.default_rng(seed).uniform(0.0, 1.0, friction.size)
    return dataclasses.replace(structure, interfaces=dataclasses.replace(
        structure.interfaces, friction=friction * (1.0 - fraction * draws)))


def wall_for(n_blocks: int) -> bm.Structure:
    """A running-bond wall with about ``n_blocks`` blocks, twice as long as high in blocks."""
    courses = max(1, round(math.sqrt(n_blocks / 2) * 1.0))
    per = max(1, round(n_blocks / courses))
    return bm.cases.wall(courses=courses, blocks_per_course=per)


def wall_or_size(wall: str) -> bm.Structure:
    """The wall ``"CxB"`` (courses x blocks per course; running bond unless an option says otherwise), with options
    of :func:`blockmpec.cases.wall` after colons (``"100x100:mu=0.3"``, ``"100x100:bond=stack"``; values read as by
    the CLI's ``KEY=VALUE``), or :func:`wall_for` a size ``"1000"``.  A malformed name or option is one
    :class:`blockmpec.OptionError` (or ``ValueError``) naming it."""
    from blockmpec.cli import parse_pairs

    if "x" not in wall:
        return wall_for(int(wall))
    shape, *options = wall.split(":")
    return named_wall(shape, **parse_pairs(options, f"wall {wall!r}: option"))
