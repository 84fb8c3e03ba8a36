"""Structures shared by several studies."""

from __future__ import annotations

import dataclasses

import numpy as np

import blockmpec as bm


def lowered_friction(structure: bm.Structure, fraction: float, seed: int = 1) -> bm.Structure:
    """``structure`` with every interface's friction coefficient ``mu_k`` lowered to ``mu_k (1 - fraction u_k)``,
    ``u_k`` uniform on [0, 1) from ``seed`` (the same draws for every fraction; 0: the structure itself).  Lowered
    friction breaks ties between equal interfaces and keeps every statically admissible stress field of the
    perturbed structure admissible for the structure itself."""
    friction = structure.interface_friction()
    draws = np.random.default_rng(seed).uniform(0.0, 1.0, friction.size)
    return dataclasses.replace(structure, interfaces=dataclasses.replace(
        structure.interfaces, friction=friction * (1.0 - fraction * draws)))
