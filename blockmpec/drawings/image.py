"""Stones from a labelled or binary image: each stone a region of pixels (needs ``blockmpec[image]``).

Kinds of image (``kind="auto"`` tells them apart):

* *labelled*: an integer image (PNG, TIFF or a ``.npy`` array) in which every stone has its own
  value and 0 is background (joints, air); a colour image whose stones have distinct colours
  (black is background) is read as labelled too;
* *binary*: stones white (non-zero) on black joints (``invert=True`` for black stones on white);
  scikit-image labels its 4-connected regions and grows them across the joints, up to
  ``joint_width`` pixels wide, so that neighbouring stones touch.

Each stone's outline follows the edges of its pixels exactly (shapely's union of its pixel rows),
so neighbouring stones share their edges exactly; the outlines are then simplified together
(shapely's ``coverage_simplify``, Visvalingam-Whyatt, removing corners whose triangle is smaller
than ``simplify`` pixels squared), which keeps the shared edges shared and straight pixel edges
exact.  Background holes inside a stone are filled.

Frame: the image's bottom-left corner is the origin, ``x`` to the right, ``y`` *up* (rows count
down), one pixel ``pixel_size`` metres.  Without ``fixed_labels`` a fixed base is added under the
image: the stones of its bottom row rest on it.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from blockmpec.drawings._common import Reading, Stone, build_structure, check_common
from blockmpec.errors import GeometryError, OptionError, SolverUnavailableError, StructureFileError
from blockmpec.geometry import DEFAULT_FRICTION, Structure

#: Image files read (besides ``.npy`` arrays).
IMAGE_SUFFIXES = (".png", ".tif", ".tiff", ".bmp", ".npy")


def _skimage():
    try:
        import skimage.io  # noqa: F401
        import skimage.measure  # noqa: F401
        import skimage.segmentation  # noqa: F401
    except ImportError:
        raise SolverUnavailableError(
            "reading stones from images needs scikit-image: pip install 'blockmpec[image]'") from None
    import skimage

    return skimage


def _load(p: Path) -> np.ndarray:
    if p.suffix.lower() in (".jpg", ".jpeg"):
        raise StructureFileError(f"{p}: JPEG compression changes the labels at the edges of the stones; "
                                 "save the labels as PNG or TIFF")
    if p.suffix.lower() == ".npy":
        try:
            return np.load(p, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise StructureFileError(f"{p}: cannot read as a numpy array ({exc})") from None
    skimage = _skimage()
    if not p.is_file():
        raise StructureFileError(f"{p}: cannot read ({'a folder' if p.is_dir() else 'no such file'})")
    try:
        with warnings.catch_warnings():  # imageio's plug-ins, tried on a file that is no image, warn of themselves
            warnings.simplefilter("ignore", DeprecationWarning)
            return np.asarray(skimage.io.imread(p))
    except Exception as exc:  # imageio and Pillow raise several types, imageio with advice on plug-ins
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        reason = "no image reader recognises its contents" if "backend" in first else first
        raise StructureFileError(f"{p}: not a readable {p.suffix.lstrip('.').upper()} image ({reason})") from None


def _labels(image: np.ndarray, kind: str, invert: bool, p: Path) -> tuple[np.ndarray, bool]:
    """The integer label image (0 background) and whether it came from a binary image."""
    a = np.asarray(image)
    if a.ndim == 3 and a.shape[2] in (3, 4):
        rgb = a[..., :3]
        alpha = a[..., 3] if a.shape[2] == 4 else None
        if np.all(rgb == rgb[..., :1]):
            a = rgb[..., 0] if alpha is None else np.where(alpha > 0, rgb[..., 0], 0)
        else:  # colour labels: one stone per colour, black (or transparent) background
            flat = rgb.reshape(-1, 3)
            colours, index = np.unique(flat, axis=0, return_inverse=True)
            black = np.flatnonzero((colours == 0).all(axis=1))
            label = index.reshape(rgb.shape[:2]) + 1
            if black.size:
                label[label == black[0] + 1] = 0
            if alpha is not None:
                label[alpha == 0] = 0
            a = label
    if a.ndim != 2:
        raise StructureFileError(f"{p}: expected a 2D image (rows x columns) of labels; got shape {a.shape}")
    if not (np.issubdtype(a.dtype, np.integer) or a.dtype == bool):
        if np.issubdtype(a.dtype, np.floating) and np.all(np.isfinite(a)) and np.all(a == np.round(a)):
            a = a.astype(np.int64)
        else:
            raise StructureFileError(f"{p}: expected integer labels or a binary image; got {a.dtype} values")
    values = np.unique(a)
    binary = {"auto": a.dtype == bool or set(values.tolist()) <= {0, 1} or set(values.tolist()) <= {0, 255},
              "binary": True, "labels": False}[kind]
    if binary:
        mask = a != 0
        if invert:
            mask = ~mask
        return _skimage().measure.label(mask, connectivity=1).astype(np.int64), True
    if invert:
        raise OptionError("invert: applies to binary images only")
    return a.astype(np.int64), False


def _close_joints(labels: np.ndarray, width: float) -> np.ndarray:
    """Grow the stones across joints up to ``width`` pixels wide (not into the air around the wall)."""
    from scipy import ndimage

    skimage = _skimage()
    radius = int(math.ceil(width)) + 1
    y, x = np.mgrid[-radius : radius + 1, -radius : radius + 1]
    disk = x * x + y * y <= radius * radius
    mask = labels > 0
    envelope = ndimage.binary_closing(np.pad(mask, radius, mode="edge"), structure=disk)[radius:-radius, radius:-radius] | mask
    grown = skimage.segmentation.expand_labels(labels, distance=width)
    grown[~envelope] = 0
    return grown


def _outlines(labels: np.ndarray) -> tuple[np.ndarray, list]:
    """The stone labels and their pixel-edge outlines (shapely geometries in pixel units, ``y`` up)."""
    import shapely

    h, w = labels.shape
    change = np.ones((h, w), bool)
    change[:, 1:] = labels[:, 1:] != labels[:, :-1]
    rows, starts = np.nonzero(change)
    ends = np.append(starts[1:], w)
    ends[np.append(rows[1:] != rows[:-1], True)] = w  # a run ends at the end of its row
    value = labels[rows, starts]
    keep = value > 0
    rows, starts, ends, value = rows[keep], starts[keep], ends[keep], value[keep]
    boxes = shapely.box(starts, h - rows - 1, ends, h - rows)
    order = np.argsort(value, kind="stable")
    ids, first = np.unique(value[order], return_index=True)
    groups = np.split(order, first[1:])
    return ids, [shapely.union_all(boxes[g]) for g in groups]


def read_image(
    path: str | Path,
    *,
    pixel_size: float | None = None,
    fixed_labels: list | None = None,
    kind: str = "auto",
    invert: bool = False,
    joint_width: float | None = None,
    simplify: float | None = None,
    min_contact: float = 2.0,
    mu: float = DEFAULT_FRICTION,
    dilatancy: float = 0.0,
    density: float = 1.0,
    live_direction: int = 1,
    snap: float = 0.0,
) -> Structure:
    """A structure from a labelled or binary image of stones.

    Parameters
    ----------
    path : path of a ``.png``, ``.tif``, ``.bmp`` image or a ``.npy`` array
    pixel_size : float, optional
        Metres per pixel (default 1, with a :class:`~blockmpec.drawings.DrawingWarning` when the
        stones are then 20 m across or more).
    fixed_labels : list of int, optional
        Labels of the supports; without them a fixed base is added under the image.
    kind : {"auto", "labels", "binary"}
        "auto": binary when the image holds only 0 and 1 (or 0 and 255) or booleans.
    invert : bool
        Binary images: the stones are the black pixels.
    joint_width : float, optional
        Pixels: stones grow across background joints up to this width (default 3 for binary
        images, 0 for labelled ones).
    simplify : float, optional
        Pixels: the tolerance of the Visvalingam-Whyatt simplification (corners whose triangle is
        smaller than about ``simplify**2`` square pixels are removed; 0 keeps every pixel corner).
        Default ``sqrt(d / 2)``, ``d`` the median stone size in pixels (square root of the median
        area; at least 1): the triangles that 1-pixel steps leave along a straight joint of length
        ``d`` are about ``d / 2`` square pixels, and the steps would interlock the stones.
    min_contact : float
        Pixels: contacts shorter than this are dropped (below the image's resolution: two stones
        that meet at a corner, which a picture cannot tell from touching over a pixel or two).
    mu, dilatancy, density, live_direction, snap
        As for :func:`blockmpec.drawings.dxf.read_dxf` (``snap`` is 0 by default: the outlines of
        neighbouring stones already share their edges).

    Raises
    ------
    SolverUnavailableError
        scikit-image is not installed (``pip install 'blockmpec[image]'``).
    StructureFileError, GeometryError, StructureError
        Naming the label of the stone.
    """
    import shapely

    check_common(mu, dilatancy, density, live_direction, snap)
    reading = Reading(unit_missing=None if pixel_size is not None else (
        "no pixel_size given, so read at 1 m per pixel", "give -p pixel_size=METRES_PER_PIXEL"))
    pixel_size = 1.0 if pixel_size is None else pixel_size
    for name, value in (("pixel_size", pixel_size), ("simplify", 0.0 if simplify is None else simplify),
                        ("min_contact", min_contact)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise OptionError(f"{name}: must be a finite number >= 0; got {value!r}")
    if pixel_size <= 0:
        raise OptionError(f"pixel_size: must be > 0 (metres per pixel); got {pixel_size!r}")
    if kind not in ("auto", "labels", "binary"):
        raise OptionError(f"kind: must be 'auto', 'labels' or 'binary'; got {kind!r}")
    if not isinstance(invert, bool):
        raise OptionError(f"invert: expected true or false; got {invert!r}")
    if joint_width is not None and (isinstance(joint_width, bool) or not isinstance(joint_width, (int, float))
                                    or not math.isfinite(joint_width) or joint_width < 0):
        raise OptionError(f"joint_width: must be a finite number >= 0 (pixels); got {joint_width!r}")
    if fixed_labels is not None and (not isinstance(fixed_labels, (list, tuple)) or not all(
            isinstance(v, int) and not isinstance(v, bool) for v in fixed_labels)):
        raise OptionError(f"fixed_labels: expected a list of integer labels; got {fixed_labels!r}")
    p = Path(path)
    if p.suffix.lower() != ".npy":
        _skimage()
    labels, binary = _labels(_load(p), kind, invert, p)
    width = (3.0 if binary else 0.0) if joint_width is None else float(joint_width)
    if width > 0:
        labels = _close_joints(labels, width)
    h, w = labels.shape
    ids, outlines = _outlines(labels)
    if ids.size == 0:
        raise StructureFileError(f"{p}: no stone (every pixel is background)")
    names = [f"label {v}" for v in ids.tolist()]
    for k, g in enumerate(outlines):
        if g.geom_type != "Polygon":
            parts = len(getattr(g, "geoms", []))
            raise GeometryError(f"{p}: {names[k]}: its pixels form {parts} separate regions (touching at most at "
                                "corners); give each stone its own label")
        for hole in g.interiors:
            x, y = shapely.get_coordinates(shapely.point_on_surface(shapely.Polygon(hole)))[0]
            inside = int(labels[int(h - math.floor(y) - 1), int(math.floor(x))])
            if inside > 0:
                raise GeometryError(f"{p}: {names[k]} surrounds label {inside}; a stone must be a simple polygon "
                                    "(split the surrounding stone)")
        outlines[k] = shapely.Polygon(g.exterior)  # background holes filled
    fixed = np.zeros(ids.size, bool)
    if fixed_labels:
        missing = sorted(set(fixed_labels) - set(ids.tolist()))
        if missing:
            raise OptionError(f"fixed_labels: label {missing[0]} is not in {p} (its labels: "
                              f"{ids.min()} ... {ids.max()})")
        fixed = np.isin(ids, fixed_labels)
    else:
        base_height = max(1, round(0.05 * h))
        outlines.append(shapely.box(0, -base_height, w, 0))
        names.append("the base (added under the image)")
        fixed = np.append(fixed, True)
    if simplify is None:
        size = math.sqrt(float(np.median(shapely.area(np.array(outlines[: ids.size], dtype=object)))))
        simplify = max(1.0, math.sqrt(size / 2))
    coverage = shapely.coverage_clean(np.array(outlines, dtype=object), snapping_distance=0.0)
    if simplify > 0:
        coverage = shapely.coverage_simplify(coverage, tolerance=float(simplify))
    stones = []
    for k, g in enumerate(coverage):
        if g.geom_type != "Polygon" or g.is_empty:
            raise GeometryError(f"{p}: {names[k]}: too small for simplify={simplify} pixels (nothing left of it); "
                                "give a smaller simplify")
        q = np.asarray(g.exterior.coords)[:-1]
        stones.append(Stone(q * pixel_size, bool(fixed[k]), names[k]))
    frame = {"format": "image", "scale": float(pixel_size), "flip_y": True, "y_offset": float(h),
             "width_px": int(w), "height_px": int(h), "simplify_px": float(simplify)}
    return build_structure(stones, p, mu=mu, dilatancy=dilatancy, density=density, live_direction=live_direction,
                           snap=snap, frame=frame, min_contact=float(min_contact) * pixel_size, reading=reading,
                           support_hint="no fixed label (give fixed_labels, or none for a base under the image)")
