"""Writing output files whole or not at all, with the permissions of any other new file."""

from __future__ import annotations

import contextlib
import os
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_write", "umask"]

_umask_lock = threading.Lock()


def umask() -> int:
    """The process's file-creation mask (read without changing it where Linux says it)."""
    try:
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    with _umask_lock:  # elsewhere: set and restore, the only portable way to read it
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (its folders made as needed); rename it onto
    ``path`` only on success, so that the output is written whole or not at all. The file
    gets the user's umask (``0666 & ~umask``, as ``open()`` would give), and a failure to
    write (full disk, no permission) is an ``OSError`` naming ``path``, not the temporary."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    except OSError as error:
        raise OSError(f"{path}: cannot write: {error.strerror or error}") from None
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~umask())
        os.replace(tmp, path)
    except OSError as error:
        raise OSError(f"{path}: cannot write: {error.strerror or error}") from None
    finally:
        tmp.unlink(missing_ok=True)
