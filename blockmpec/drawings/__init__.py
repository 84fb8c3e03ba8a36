"""Structures from drawings and images, and results drawn back into them.

>>> import blockmpec as bm
>>> from blockmpec.drawings import read_structure, export_drawing
>>> wall = read_structure("survey.dxf", fixed_layer="base", units="mm")   # doctest: +SKIP
>>> res = bm.solve(wall, "static-lp")                                      # doctest: +SKIP
>>> export_drawing(wall, res, "collapse.dxf", source="survey.dxf")          # doctest: +SKIP

Readers (one per kind of file, chosen by the suffix in :func:`read_structure`):

* ``.dxf``: :func:`blockmpec.drawings.dxf.read_dxf` (closed polylines and loops of lines in world
  coordinates, block references followed; a ``fixed`` layer);
* ``.svg``: :func:`blockmpec.drawings.svg.read_svg` (closed shapes and loops of lines through their
  transformations; class ``fixed``; SVG's ``y`` axis points down and is turned up);
* ``.png``, ``.tif``, ``.tiff``, ``.bmp``, ``.npy``: :func:`blockmpec.drawings.image.read_image`
  (labelled or binary images; needs ``pip install 'blockmpec[image]'``).

Every error names the file and the entity (DXF handle and layer, SVG id, image label).  The
structure's ``metadata["drawing"]`` records the file's frame (scale, ``y`` direction), the entity of
each block, the summary line of what was read and left out (``summary``, counts in ``read``) and the
warnings (``warnings``; each also a :class:`DrawingWarning`); ``metadata["snapping"]`` what was snapped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from blockmpec.drawings._common import DrawingWarning
from blockmpec.drawings.export import export_drawing
from blockmpec.errors import OptionError
from blockmpec.geometry import Structure

#: File suffix -> ``(module, reader)`` of blockmpec.drawings.
READERS = {
    ".dxf": ("dxf", "read_dxf"),
    ".svg": ("svg", "read_svg"),
    ".png": ("image", "read_image"),
    ".tif": ("image", "read_image"),
    ".tiff": ("image", "read_image"),
    ".bmp": ("image", "read_image"),
    ".npy": ("image", "read_image"),
}

#: Suffixes read as drawings or images (lower case).
SUFFIXES = tuple(READERS)


def _suffix(path: str | Path) -> str:
    text = str(path)
    return text.lower() if text.startswith(".") and text.count(".") == 1 else Path(text).suffix.lower()


def is_drawing(path: str | Path) -> bool:
    """Whether ``path`` names a file that :func:`read_structure` reads (by its suffix)."""
    return _suffix(path) in READERS


def reader(path: str | Path):
    """The reader function for ``path``'s suffix."""
    import importlib

    suffix = _suffix(path)
    if suffix not in READERS:
        raise OptionError(f"{path}: not a drawing or image this version reads (suffixes: {', '.join(SUFFIXES)})")
    module, name = READERS[suffix]
    return getattr(importlib.import_module(f"blockmpec.drawings.{module}"), name)


def read_structure(path: str | Path, **options: Any) -> Structure:
    """The structure drawn in ``path`` (DXF, SVG or image, by its suffix), with the reader's options.

    Parameters
    ----------
    path : path
        ``.dxf``, ``.svg``, ``.png``, ``.tif``, ``.tiff``, ``.bmp`` or ``.npy``.
    **options
        The reader's keyword arguments (:func:`~blockmpec.drawings.dxf.read_dxf`,
        :func:`~blockmpec.drawings.svg.read_svg`, :func:`~blockmpec.drawings.image.read_image`),
        e.g. ``mu``, ``units``, ``fixed_layer``, ``pixel_size``.

    Raises
    ------
    OptionError
        Unknown suffix or option (the valid ones listed), or a bad option value.
    StructureFileError, GeometryError, StructureError
        A bad file, each naming the file and the entity.
    """
    from blockmpec.drawings._common import check_options

    read = reader(path)
    check_options(read, options, path)
    return read(path, **options)


def reader_options(path: str | Path) -> dict[str, Any]:
    """Option name -> default of the reader of ``path``'s suffix (or of a suffix such as ``".dxf"``)."""
    import inspect

    return {k: p.default for k, p in inspect.signature(reader(path)).parameters.items() if k != "path"}


__all__ = ["READERS", "SUFFIXES", "DrawingWarning", "export_drawing", "is_drawing", "read_structure", "reader", "reader_options"]
