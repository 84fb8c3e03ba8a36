"""Progress output of a run: ``verbose=True`` logs it, and the backends' own logs follow.

:func:`blockmpec.solve` runs a method inside :func:`verbose` with its ``verbose`` option; engines log their
progress on ``logging.getLogger(__name__)`` at INFO and switch their backends' logs on when
:func:`verbose_enabled` is true (which a user also gets by setting the ``blockmpec`` loggers to INFO).
"""

from __future__ import annotations

import contextlib
import logging


@contextlib.contextmanager
def verbose(enabled: bool):
    """With ``verbose``: the ``blockmpec`` loggers at INFO, printed to stderr, for the run (backends read
    :func:`verbose_enabled` to switch their own logs on)."""
    if not enabled:
        yield
        return
    logger = logging.getLogger("blockmpec")
    handler = logging.StreamHandler()
    handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def verbose_enabled() -> bool:
    """True while a run logs its progress (``verbose=True``, or the user set the ``blockmpec`` loggers to INFO):
    the backends' own logs (HiGHS's ``output_flag``, Ipopt's ``print_level``) follow it."""
    return logging.getLogger("blockmpec").isEnabledFor(logging.INFO)
