"""Shared fixtures and helpers."""

import numpy as np
import pytest

import blockmpec as bm


def two_block_associative(eta: float, mu: float) -> float:
    """Closed-form associative multiplier of the paper's two-block problem (Sect. 3)."""
    candidates = [mu, 2.0 / eta]
    d1 = eta * (1 - mu**2) + mu
    if d1 > 0:
        candidates.append(1.0 / d1)
    d2 = eta * (1 + mu**2) - mu
    if d2 > 0:
        candidates.append((1 + 2 * mu**2) / d2)
    return min(candidates)


def two_block_nonassociative_min(eta: float, mu: float) -> float:
    """Closed-form minimum non-associative multiplier (psi = 0): mu if mu <= 1/eta else 1/eta."""
    return mu if mu <= 1.0 / eta else 1.0 / eta


def assert_success(res: bm.Result, multiplier: float | None = None, rtol: float = 1e-8) -> None:
    """A scipy-style assertion helper: success, and the multiplier if given."""
    assert res.success, f"{res.method}: status {res.status.value}, message: {res.message}, residuals {res.residuals}"
    if multiplier is not None:
        np.testing.assert_allclose(res.multiplier, multiplier, rtol=rtol)


@pytest.fixture(scope="session")
def builtin_structures():
    """One default instance of every built-in case."""
    return {name: spec.build() for name, spec in bm.cases.CASES.items()}
