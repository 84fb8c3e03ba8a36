"""Write the bad-input corpus: ``tests/data/bad_inputs/*.json`` and ``tests/data/bad_inputs.manifest.json``.

Each entry is a structure file that a hostile or careless user could write, with the
fragment of the one-line error it must get (``tests/test_bad_input.py`` runs every file
through ``blockmpec solve`` in-process and checks exit code 2, one line, the fragment).
The fragments are written here by hand, from what is wrong with the file, not copied
from the program's output.  Re-run after adding entries:

    python tests/data/make_bad_inputs.py
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

HERE = Path(__file__).resolve().parent / "bad_inputs"
MANIFEST = HERE.parent / "bad_inputs.manifest.json"

BASE = {
    "format": "blockmpec-structure", "version": 1, "name": "two-blocks", "friction": 0.65, "dilatancy": 0.0,
    "live_load": {"direction": 1, "factor": 1.0},
    "blocks": [
        {"vertices": [[-1.0, -0.5], [3.0, -0.5], [3.0, 0.0], [-1.0, 0.0]], "fixed": True, "density": 1.0},
        {"vertices": [[0.0, 0.0], [1.0, 0.0], [1.0, 3.0], [0.0, 3.0]], "fixed": False, "density": 1.0},
        {"vertices": [[1.0, 0.0], [2.0, 0.0], [2.0, 3.0], [1.0, 3.0]], "fixed": False, "density": 1.0},
    ],
    "interfaces": [
        {"minus": 0, "plus": 1, "start": [0.0, 0.0], "end": [1.0, 0.0], "friction": None, "dilatancy": None},
        {"minus": 0, "plus": 2, "start": [1.0, 0.0], "end": [2.0, 0.0], "friction": None, "dilatancy": None},
        {"minus": 1, "plus": 2, "start": [1.0, 3.0], "end": [1.0, 0.0], "friction": None, "dilatancy": None},
    ],
    "point_loads": [],
    "metadata": {},
}

ENTRIES: list[tuple[str, object, str]] = []  # (name, dict or raw text, expected fragment)


def text(name: str, raw: str, expect: str) -> None:
    ENTRIES.append((name, raw, expect))


def bad(name: str, expect: str, detect: bool = False):
    """Register ``fn(d)`` mutating a copy of BASE (without explicit interfaces when ``detect``)."""
    def wrap(fn):
        d = copy.deepcopy(BASE)
        if detect:
            del d["interfaces"]
        fn(d)
        ENTRIES.append((name, d, expect))
        return fn
    return wrap


def setter(path: str, value, expect: str, detect: bool = False, name: str | None = None) -> None:
    """A file with one field (``a.b.0.c``) set to ``value``."""
    def fn(d):
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        obj = d
        for k in keys[:-1]:
            obj = obj[k]
        obj[keys[-1]] = value
    label = name or f"{path}={json.dumps(value)}"
    bad(label, expect, detect)(fn)


def deleter(path: str, expect: str) -> None:
    def fn(d):
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        obj = d
        for k in keys[:-1]:
            obj = obj[k]
        del obj[keys[-1]]
    bad(f"no-{path}", expect)(fn)


# ------------------------------------------------------------------ not a structure file at all
text("empty-file", "", "not valid JSON")
text("truncated", json.dumps(BASE)[:120], "not valid JSON")
text("trailing-comma", '{"format": "blockmpec-structure", "friction": 0.5, "blocks": [],}', "not valid JSON")
text("python-literals", "{'format': 'blockmpec-structure'}", "not valid JSON")
text("top-level-list", "[1, 2, 3]", "expected a JSON object")
text("top-level-number", "42", "expected a JSON object")
text("top-level-string", '"blockmpec-structure"', "expected a JSON object")
text("top-level-null", "null", "expected a JSON object")
text("nan-friction-literal", json.dumps(BASE).replace('"friction": 0.65', '"friction": NaN'),
     "friction: must be a finite number >= 0")
text("infinite-friction-literal", json.dumps(BASE).replace('"friction": 0.65', '"friction": Infinity'),
     "friction: must be a finite number >= 0")
text("overflowing-coordinate", json.dumps(BASE).replace("[2.0, 3.0]", "[2.0, 1e400]", 1),
     "vertices contain NaN or infinite coordinates")

# ------------------------------------------------------------------ header
deleter("format", "missing required field 'format'")
setter("format", "blockmpec", "field 'format' must be 'blockmpec-structure'")
setter("format", None, "field 'format' must be 'blockmpec-structure'")
setter("version", 2, "unsupported version 2")
setter("version", "1", "unsupported version '1'")
setter("blox", [], "unknown field 'blox'; did you mean 'blocks'?")
setter("fricton", 0.5, "unknown field 'fricton'; did you mean 'friction'?")
setter("interface", [], "unknown field 'interface'; did you mean 'interfaces'?")
setter("pointloads", [], "unknown field 'pointloads'; did you mean 'point_loads'?")
setter("units", "m", "unknown field 'units'")
setter("metadata", [], "field 'metadata' must be an object")
setter("metadata", "none", "field 'metadata' must be an object")

# ------------------------------------------------------------------ material
deleter("friction", "missing required field 'friction'")
setter("friction", "0.6", "friction: expected a number; got '0.6'")
setter("friction", None, "friction: expected a number; got None")
setter("friction", True, "friction: expected a number; got True")
setter("friction", [0.6], "friction: expected a number; got [0.6]")
setter("friction", -0.1, "friction: must be a finite number >= 0; got -0.1")
setter("friction", -1e-300, "friction: must be a finite number >= 0")
setter("dilatancy", 0.9, "dilatancy: tan(psi) = 0.9 exceeds the friction coefficient")
setter("dilatancy", -0.1, "dilatancy: must be a finite number >= 0")
setter("dilatancy", "none", "dilatancy: expected a number")
setter("interfaces.2.friction", -0.5, "interface 2: friction must be a finite number >= 0")
setter("interfaces.2.dilatancy", 0.8, "interface 2 (blocks 1-2): dilatancy tan(psi) = 0.8 exceeds friction")
setter("interfaces.2.friction", "rough", "interfaces[2].friction: expected a number")
setter("interfaces.0.dilatancy", -1.0, "interface 0: dilatancy must be a finite number >= 0")

# ------------------------------------------------------------------ live load
setter("live_load", [1, 1.0], "live_load: expected a JSON object")
setter("live_load", 1.0, "live_load: expected a JSON object")
setter("live_load.dir", 1, "live_load: unknown field 'dir'")
setter("live_load.direction", 0, "live_load.direction must be 1 or -1; got 0")
setter("live_load.direction", 2, "live_load.direction must be 1 or -1; got 2")
setter("live_load.direction", "left", "live_load.direction must be 1 or -1; got 'left'")
setter("live_load.direction", True, "live_load.direction must be 1 or -1; got True")
setter("live_load.direction", -1.5, "live_load.direction must be 1 or -1; got -1.5")
setter("live_load.factor", -1.0, "live_load.factor must be a finite number >= 0; got -1.0")
setter("live_load.factor", -0.0001, "live_load.factor must be a finite number >= 0")
setter("live_load.factor", "1", "live_load.factor: expected a number")
setter("live_load.factor", 0.0, "zero live load")
setter("live_load.factor", None, "live_load.factor: expected a number")

# ------------------------------------------------------------------ blocks: structure of the list
deleter("blocks", "missing required field 'blocks'")
setter("blocks", [], "field 'blocks' must be a non-empty list")
setter("blocks", {}, "field 'blocks' must be a non-empty list")
setter("blocks", "three", "field 'blocks' must be a non-empty list")
setter("blocks.1", [[0, 0], [1, 0], [1, 3]], "blocks[1]: expected a JSON object", name="block-is-a-list")
setter("blocks.1.verts", [], "blocks[1]: unknown field 'verts'; did you mean 'vertices'?")
setter("blocks.1.weight", 2.0, "blocks[1]: unknown field 'weight'")
setter("blocks.1.Fixed", True, "blocks[1]: unknown field 'Fixed'; did you mean 'fixed'?")
deleter("blocks.1.vertices", "blocks[1]: missing required field 'vertices'")
setter("blocks.1.vertices", "square", "blocks[1].vertices: expected a list of [x, y]")
setter("blocks.1.vertices", {"x": [0, 1, 1], "y": [0, 0, 1]}, "blocks[1].vertices: expected a list of [x, y]")
setter("blocks.1.vertices.2", [1.0], "blocks[1].vertices[2]: expected [x, y]")
setter("blocks.1.vertices.2", [1.0, 3.0, 0.0], "blocks[1].vertices[2]: expected [x, y]")
setter("blocks.1.vertices.2", ["1", 3.0], "blocks[1].vertices[2]: expected a number")
setter("blocks.1.vertices.2", [None, 3.0], "blocks[1].vertices[2]: expected a number")
setter("blocks.1.vertices.2", {"x": 1, "y": 3}, "blocks[1].vertices[2]: expected [x, y]")
setter("blocks.1.fixed", "no", "blocks[1].fixed: expected true or false")
setter("blocks.1.fixed", 0, "blocks[1].fixed: expected true or false")
setter("blocks.1.density", -1.0, "block 1: density must be a finite number > 0; got -1.0")
setter("blocks.1.density", 0.0, "block 1: density must be a finite number > 0; got 0.0")
setter("blocks.2.density", "heavy", "blocks[2].density: expected a number")
setter("blocks.2.density", None, "blocks[2].density: expected a number")

# ------------------------------------------------------------------ blocks: geometry
setter("blocks.1.vertices", [[0, 0], [1, 0]], "block 1: vertices must have shape (k, 2) with k >= 3", detect=True)
setter("blocks.1.vertices", [], "block 1: vertices must have shape (k, 2) with k >= 3", detect=True)
setter("blocks.1.vertices", [[0, 0], [1, 0], [2, 0]], "block 1: polygon is degenerate", detect=True)
setter("blocks.1.vertices", [[0, 0], [1, 0], [1, 0], [0, 0]], "block 1: polygon is degenerate", detect=True,
       name="all-on-a-line")
setter("blocks.1.vertices", [[0, 3], [1, 3], [1, 0], [0, 0]], "block 1: vertices are in clockwise order",
       detect=True)
setter("blocks.1.vertices", [[0, 0], [1, 0], [1, 3], [0, 3], [0.5, 3.5], [0.5, 2.5]],
       "block 1: polygon is self-intersecting", detect=True)
setter("blocks.1.vertices", [[0, 0], [1, 0], [1, 3], [1, 3], [0, 3]], "block 1: two consecutive vertices coincide",
       detect=True)
setter("blocks.1.vertices", [[0, 0], [1, 0], [1, 3], [0, 3], [1, 0]], "block 1", detect=True,
       name="self-crossing")
setter("blocks.1.vertices", [[0, 0], [1e-300, 0], [1e-300, 3e-300], [0, 3e-300]],
       "block 1: its size 3.16e-300 is", detect=True, name="block-of-subnormal-size")
setter("blocks.1.vertices", [[0, 0], [1e-120, 0], [1e-120, 3e-120], [0, 3e-120]],
       "block sizes in one structure must lie within a factor 1e+100", detect=True, name="block-1e-120-on-unit-blocks")
setter("blocks.0.vertices", [[-1e308, -0.5], [1e308, -0.5], [1e308, 0.0], [-1e308, 0.0]],
       "block 0: its extent overflows the floating-point range", detect=True)
setter("blocks.2.vertices", [[0.5, 0.0], [1.5, 0.0], [1.5, 3.0], [0.5, 3.0]], "blocks 1 and 2 overlap", detect=True)
setter("blocks.2.vertices", [[0.0, 0.0], [1.0, 0.0], [1.0, 3.0], [0.0, 3.0]], "blocks 1 and 2 overlap", detect=True,
       name="duplicate-block")
setter("blocks.2.vertices", [[10.0, 10.0], [11.0, 10.0], [11.0, 13.0], [10.0, 13.0]], "block 2 touches no other block",
       detect=True)
setter("blocks.2.vertices", [[1.0, 0.5], [2.0, 0.5], [2.0, 3.5], [1.0, 3.5]], "", detect=True,
       name="raised-block-kept-by-side-contact")  # replaced below: must be a valid file, see VALID
setter("blocks.0.fixed", False, "no block is fixed: mark at least one block", detect=True)
for i in (1, 2):
    setter(f"blocks.{i}.fixed", True, "", detect=True, name=f"block-{i}-fixed")  # replaced below


@bad("every-block-fixed", "every block is fixed: there is nothing that can collapse", detect=True)
def _(d):
    for b in d["blocks"]:
        b["fixed"] = True


@bad("floating-pair", "blocks [3, 4] are not connected to any fixed block", detect=True)
def _(d):
    d["blocks"] += [{"vertices": [[10, 10], [11, 10], [11, 11], [10, 11]]},
                    {"vertices": [[11, 10], [12, 10], [12, 11], [11, 11]]}]


@bad("density-overflow-between-blocks", "densities in one structure must lie within a factor 1e+100", detect=True)
def _(d):
    d["blocks"][1]["density"] = 1e-300
    d["blocks"][2]["density"] = 1e300


# ------------------------------------------------------------------ interfaces
setter("interfaces", {}, "field 'interfaces' must be a list")
setter("interfaces", "auto", "field 'interfaces' must be a list")
setter("interfaces.0", [0, 1], "interfaces[0]: expected a JSON object", name="interface-is-a-list")
setter("interfaces.0.minnus", 0, "interfaces[0]: unknown field 'minnus'; did you mean 'minus'?")
setter("interfaces.0.normal", [0, 1], "interfaces[0]: unknown field 'normal'")
deleter("interfaces.0.minus", "interfaces[0]: missing required field 'minus'")
deleter("interfaces.1.end", "interfaces[1]: missing required field 'end'")
setter("interfaces.0.minus", 7, "interface 0: minus block 7 does not exist (there are 3 blocks)")
setter("interfaces.0.plus", -1, "interface 0: plus block -1 does not exist")
setter("interfaces.0.plus", 0, "interface 0: minus and plus block are the same block 0")
setter("interfaces.0.minus", 0.0, "interfaces[0].minus: expected a block index")
setter("interfaces.0.minus", "0", "interfaces[0].minus: expected a block index")
setter("interfaces.0.plus", True, "interfaces[0].plus: expected a block index")
setter("interfaces.0.start", [0.0], "interfaces[0].start: expected [x, y]")
setter("interfaces.0.end", "1,0", "interfaces[0].end: expected [x, y]")
setter("interfaces.0.start", [0.0, 1.0], "interface 0: start point [0.0, 1.0] is not on the boundary")
setter("interfaces.0.end", [5.0, 0.0], "interface 0: end point [5.0, 0.0] is not on the boundary")
setter("interfaces.0.end", [0.0, 0.0], "interface 0: segment has zero length")
setter("interfaces.2.start", [1.0, 0.0], "interface 2: segment has zero length", name="interface-2-zero-length")


@bad("reversed-interface", "interface 2: its normal (end - start rotated by +90 degrees) points from block 2")
def _(d):
    it = d["interfaces"][2]
    it["start"], it["end"] = it["end"], it["start"]


@bad("swapped-minus-plus", "interface 0: its normal")
def _(d):
    it = d["interfaces"][0]
    it["minus"], it["plus"] = it["plus"], it["minus"]


@bad("interface-between-non-touching-blocks", "is not on the boundary of its")
def _(d):
    d["blocks"].append({"vertices": [[5, 5], [6, 5], [6, 6], [5, 6]]})
    d["interfaces"].append({"minus": 0, "plus": 3, "start": [5, 5], "end": [6, 5]})


@bad("block-without-interfaces-listed", "block 2 touches no other block")
def _(d):
    d["interfaces"] = d["interfaces"][:1]


# ------------------------------------------------------------------ point loads
def load(**kw):
    pl = {"block": 2, "point": [1.5, 3.0], "force": [0.0, -1.0], "kind": "dead"}
    pl.update(kw)
    return [pl]


setter("point_loads", {}, "field 'point_loads' must be a list")
setter("point_loads", [[2, [1.5, 3], [0, -1]]], "point_loads[0]: expected a JSON object", name="point-load-is-a-list")
setter("point_loads", load(block=3), "point load 0: block 3 does not exist (there are 3 blocks)")
setter("point_loads", load(block=-1), "point load 0: block -1 does not exist")
setter("point_loads", load(block="2"), "point_loads[0].block: expected a block index")
setter("point_loads", load(block=2.0), "point_loads[0].block: expected a block index")
setter("point_loads", load(point=[1.5]), "point_loads[0].point: expected [x, y]")
setter("point_loads", load(force=["0", "-1"]), "point_loads[0].force: expected a number")
setter("point_loads", load(kind="wind"), "point_loads[0].kind: expected \"dead\" or \"live\"; got 'wind'")
setter("point_loads", load(kind=None), "point_loads[0].kind: expected \"dead\" or \"live\"; got None")
setter("point_loads", load(magnitude=3), "point_loads[0]: unknown field 'magnitude'")
setter("point_loads", load(point=[1.5, 4.0]), "point load 0: its point [1.5, 4.0] lies outside block 2")
setter("point_loads", load(point=[0.5, 1.0]), "point load 0: its point [0.5, 1.0] lies outside block 2",
       name="point-load-in-the-wrong-block")
setter("point_loads", load(point=[1e6, 1e6]), "lies outside block 2", name="point-load-far-away")
setter("point_loads", load(point=[2.001, 1.5]), "lies outside block 2", name="point-load-just-outside")
setter("point_loads", load(force=[0.0, -1e308], kind="dead"), "", name="huge-point-load")  # replaced below


@bad("point-load-overflows-against-weights", "block 2: its load is not finite")
def _(d):
    for b in d["blocks"]:
        b["density"] = 1e-300
    d["point_loads"] = load(force=[0.0, -1e300])


@bad("density-1e-120-next-to-unit-density", "block 2: density 1e-120 is 2e-120 times the median density")
def _(d):
    d["blocks"][0]["density"] = 1.0
    d["blocks"][2]["density"] = 1e-120


@bad("zero-live-load-and-only-dead-point-loads", "zero live load")
def _(d):
    d["live_load"]["factor"] = 0.0
    d["point_loads"] = load(kind="dead")


@bad("zero-live-load-live-point-load-on-fixed-block", "zero live load")
def _(d):
    d["live_load"]["factor"] = 0.0
    d["point_loads"] = load(block=0, point=[-0.5, -0.25], force=[1.0, 0.0], kind="live")


@bad("zero-live-load-zero-live-point-force", "zero live load")
def _(d):
    d["live_load"]["factor"] = 0.0
    d["point_loads"] = load(force=[0.0, 0.0], kind="live")


# files that are *valid* (kept out of the corpus; they are the controls of the tests)
VALID = {"raised-block-kept-by-side-contact", "block-1-fixed", "block-2-fixed", "huge-point-load"}


def slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "-", name).strip("-").lower()[:60]


def main() -> None:
    HERE.mkdir(parents=True, exist_ok=True)
    for old in HERE.glob("*.json"):
        old.unlink()
    manifest = []
    seen = set()
    for n, (name, content, expect) in enumerate(e for e in ENTRIES if e[0] not in VALID):
        fname = f"{n:03d}-{slug(name)}.json"
        assert fname not in seen
        seen.add(fname)
        raw = content if isinstance(content, str) else json.dumps(content, indent=1) + "\n"
        (HERE / fname).write_text(raw)
        manifest.append({"file": fname, "expect": expect})
    MANIFEST.write_text(json.dumps(manifest, indent=1) + "\n")
    print(f"{len(manifest)} bad inputs written to {HERE}")


if __name__ == "__main__":
    main()
