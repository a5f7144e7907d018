"""What the TIFF readers (:mod:`.images`, :mod:`.volumes`, :mod:`.profiles`) share: the
files' first four bytes, and tifffile's log records held back while a file is read, since
glmls reports a corrupt file itself, in one line."""

from __future__ import annotations

import contextlib
import logging
import os
import threading
from collections.abc import Iterator

__all__ = ["TIFF_SIGNATURES", "quiet_tifffile"]

#: The first four bytes of a TIFF (little- and big-endian) or BigTIFF file.
TIFF_SIGNATURES = (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+")

_lock = threading.Lock()
_depth = 0
_level = logging.NOTSET


@contextlib.contextmanager
def quiet_tifffile() -> Iterator[None]:
    """Within the block, tifffile's logger passes nothing on; after the last of nested or
    concurrent blocks (reads on other threads) its level is as it was.

    Examples
    --------
    >>> import logging
    >>> with quiet_tifffile():
    ...     logging.getLogger("tifffile").isEnabledFor(logging.CRITICAL)
    False
    >>> logging.getLogger("tifffile").isEnabledFor(logging.CRITICAL)
    True
    """
    global _depth, _level
    logger = logging.getLogger("tifffile")
    with _lock:
        if _depth == 0:
            _level = logger.level
            logger.setLevel(logging.CRITICAL + 1)
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                logger.setLevel(_level)


def _after_fork_in_child() -> None:
    """Reads that other threads of the parent were doing at the fork never end here: the
    lock is made anew (else every read here could wait for ever) and the level put back."""
    global _lock, _depth
    _lock = threading.Lock()
    if _depth:
        logging.getLogger("tifffile").setLevel(_level)
        _depth = 0


os.register_at_fork(after_in_child=_after_fork_in_child)
