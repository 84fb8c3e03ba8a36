"""The compiled-formulation cache (formulations/pyomo_compile.py): keyed by content, copies out, disk only on request."""

import numpy as np
import pytest

import blockmpec as bm
from blockmpec.formulations import compile_linear, pyomo_compile, static_lp
from helpers import assert_same_program


@pytest.fixture(autouse=True)
def _fresh_cache(monkeypatch):
    monkeypatch.delenv(pyomo_compile.CACHE_DIR_VARIABLE, raising=False)
    pyomo_compile.clear_cache()
    yield
    pyomo_compile.clear_cache()


def test_cached_compile_equals_a_fresh_compile_and_hands_out_copies(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    ops = bm.assemble(bm.cases.wall())
    fresh = compile_linear(static_lp(ops))
    first = pyomo_compile.compiled_linear(static_lp, ops)
    assert_same_program(first, fresh)
    first.row_upper[:] = 7.0  # an engine's set_row_upper must not reach the cache
    builds = []
    monkeypatch.setattr(pyomo_compile, "compile_linear", lambda problem: builds.append(problem))
    second = pyomo_compile.compiled_linear(static_lp, ops)  # a hit: nothing is built
    assert builds == []
    assert_same_program(second, fresh)  # the cached model, untouched by the change to the first copy
    assert not np.any(second.row_upper == 7.0)
    assert list(tmp_path.iterdir()) == []  # no disk cache unless asked for


def test_cache_key_follows_the_content():
    ops = bm.assemble(bm.cases.wall())
    same = bm.assemble(bm.cases.wall())
    other = bm.assemble(bm.cases.wall(mu=0.5))
    key = pyomo_compile.content_hash(static_lp, ops)
    assert pyomo_compile.content_hash(static_lp, same) == key  # equal content, another object
    assert pyomo_compile.content_hash(static_lp, other) != key
    assert pyomo_compile.content_hash(static_lp, ops, cohesion=np.ones(ops.n_interfaces)) != key


def test_disk_cache_is_opt_in_and_reloads_without_building(monkeypatch, tmp_path):
    monkeypatch.setenv(pyomo_compile.CACHE_DIR_VARIABLE, str(tmp_path / "cache"))
    ops = bm.assemble(bm.cases.wall())
    built = pyomo_compile.compiled_linear(static_lp, ops)
    files = list((tmp_path / "cache").glob("*.npz"))
    assert len(files) == 1
    pyomo_compile.clear_cache()

    def no_build(problem):
        raise AssertionError("built although the disk cache holds the model")

    monkeypatch.setattr(pyomo_compile, "compile_linear", no_build)
    assert_same_program(pyomo_compile.compiled_linear(static_lp, ops), built)
