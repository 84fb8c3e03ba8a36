"""Exception types raised by blockmpec.

Every error raised for bad input names *what* is wrong and *where* (which block,
interface, field or option), and what was expected.
"""

from __future__ import annotations


class BlockmpecError(Exception):
    """Base class of every error blockmpec raises on purpose."""


class GeometryError(BlockmpecError, ValueError):
    """A block or interface has invalid geometry (shape, orientation, overlap...)."""


class StructureError(BlockmpecError, ValueError):
    """A structure is invalid as a whole (no support, floating block, bad material...)."""


class StructureFileError(BlockmpecError, ValueError):
    """A JSON structure file is malformed: missing, misspelled or mistyped field."""


class OptionError(BlockmpecError, ValueError):
    """A case parameter or solver option is unknown or has an invalid value."""


class UnknownNameError(BlockmpecError, KeyError):
    """A case or method name is not registered."""

    def __str__(self) -> str:  # KeyError quotes its message; we do not want that
        return str(self.args[0]) if self.args else ""


class SolverUnavailableError(BlockmpecError, ImportError):
    """A solver's backend library is not installed."""


class PrecisionWarning(UserWarning):
    """Input whose floating-point resolution is coarse against its own size (e.g. a unit block
    1e15 from the origin, whose coordinates are resolved only to 0.125): digits the author meant
    may already be lost in the input, which no computation can recover."""


class PluginWarning(UserWarning):
    """A method plug-in (an entry point of the group ``blockmpec.methods``) that could not be loaded: its module
    failed to import, it is not a :class:`~blockmpec.method.SolverBase` subclass, or its name is taken.  The message
    is one line naming the entry point, its distribution and the reason; every other method still works."""
