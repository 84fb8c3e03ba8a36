"""JSON structure files load and save losslessly; shipped examples load."""

import json
from importlib import resources

import numpy as np
import pytest

import blockmpec as bm


@pytest.mark.parametrize("name", [n for n in bm.cases.CASES if n not in bm.three_d.cases.CASES_3D])
def test_round_trip_is_lossless(tmp_path, name):
    s = bm.build_case(name)
    path = tmp_path / "s.json"
    bm.save_structure(s, path)
    s2 = bm.load_structure(path)
    assert np.array_equal(s.vertices, s2.vertices)
    assert np.array_equal(s.fixed, s2.fixed)
    assert np.array_equal(s.interfaces.start, s2.interfaces.start)
    assert bm.structure_to_dict(s2) == bm.structure_to_dict(s)
    assert bm.solve(s2, "static-lp").multiplier == bm.solve(s, "static-lp").multiplier


def test_interfaces_are_detected_when_omitted_and_overrides_apply(tmp_path):
    d = bm.structure_to_dict(bm.cases.two_blocks(eta=3, mu=0.65))
    d.pop("interfaces")
    detected = bm.structure_from_dict(d)
    assert len(detected.interfaces) == 3
    d = bm.structure_to_dict(bm.cases.two_blocks(eta=3, mu=0.65))
    for itf in d["interfaces"]:
        itf["friction"] = 0.2  # override every interface: sliding now governs
    s = bm.structure_from_dict(json.loads(json.dumps(d)))
    assert bm.solve(s, "static-lp").multiplier == pytest.approx(0.2, rel=1e-9)


def test_shipped_examples_load():
    files = sorted(p for p in resources.files("blockmpec").joinpath("data").iterdir() if p.name.endswith(".json"))
    assert files, "no example structure files shipped"
    for f in files:
        s = bm.load_structure(f)
        assert bm.solve(s, "static-lp").success
