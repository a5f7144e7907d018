"""Writing output files whole or not at all, with the permissions of any other new file."""

from __future__ import annotations

import contextlib
import os
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path

from .parsing import as_path

__all__ = ["atomic_write", "missing_folders", "remove_leftovers", "same_file", "umask"]

_umask_lock = threading.Lock()


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether ``a`` and ``b`` name one file: the same file where both exist (a link, another
    spelling of the name), else the same absolute path.

    Examples
    --------
    >>> from glmls.files.atomic import same_file
    >>> same_file("out/../a.png", "a.png"), same_file("a.png", "b.png")
    (True, False)
    """
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


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
    """A temporary path beside ``path``, renamed onto it when the block succeeds.

    The output is written whole or not at all: the block writes the temporary file (its
    folders made as needed), which replaces ``path`` only when the block ends without an
    exception, and is removed otherwise. The file gets the user's umask (``0666 & ~umask``,
    as ``open()`` would give).

    Parameters
    ----------
    path : str or os.PathLike
        The output file.

    Yields
    ------
    pathlib.Path
        The temporary file to write, in ``path``'s folder, with ``path``'s suffix.

    Raises
    ------
    OSError
        When the file cannot be written (full disk, no permission), naming ``path``, not
        the temporary.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> from glmls.files import atomic_write
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "out" / "table.csv"
    >>> with atomic_write(path) as tmp:
    ...     _ = tmp.write_text("x,y\\n1,2\\n")
    >>> path.read_text()
    'x,y\\n1,2\\n'
    >>> try:
    ...     with atomic_write(path) as tmp:
    ...         _ = tmp.write_text("half")
    ...         raise KeyboardInterrupt
    ... except KeyboardInterrupt:
    ...     pass
    >>> path.read_text(), sorted(p.name for p in path.parent.iterdir())
    ('x,y\\n1,2\\n', ['table.csv'])
    """
    path = as_path(path)
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


def missing_folders(paths: Iterable[str | os.PathLike]) -> list[Path]:
    """The folders above ``paths`` that do not exist yet (the deepest first): those that
    writing them would make, for :func:`remove_leftovers` to take away after a failure."""
    missing: dict[Path, None] = {}
    for path in paths:
        for folder in Path(path).parents:
            if folder.exists():
                break
            missing[folder] = None
    return sorted(missing, key=lambda folder: len(folder.parts), reverse=True)


def remove_leftovers(paths: Iterable[str | os.PathLike], made: Iterable[Path] = ()) -> None:
    """After a failed run: remove the temporary files that :func:`atomic_write` names
    beside each of ``paths`` (``.NAME.XXXXXXXX.SUFFIX``), whoever wrote them (a worker
    process stopped while it wrote one leaves it), then the folders of ``made`` (the
    deepest first, from :func:`missing_folders`) that are left empty. Outputs written
    whole stay, and so do other files."""
    names: dict[Path, set[str]] = {}  # each folder listed once, however many paths it holds
    for path in map(Path, paths):
        names.setdefault(path.parent, set()).add(path.name)
    for folder, wanted in names.items():
        try:
            entries = [entry.name for entry in os.scandir(folder)]
        except OSError:  # no folder (or not one): nothing was written there
            continue
        for entry in entries:
            if _is_temporary(entry, wanted):
                (folder / entry).unlink(missing_ok=True)
    for folder in made:
        with contextlib.suppress(OSError):  # not empty (or gone): it stays
            folder.rmdir()


def _is_temporary(entry: str, names: set[str]) -> bool:
    """Whether ``entry`` is the temporary file of one of ``names``: ``.NAME.XXXXXXXX.SUFFIX``,
    mkstemp's 8 random characters between NAME and NAME's suffix."""
    if not entry.startswith("."):
        return False
    for cut in range(2, len(entry) - 7):  # where the 8 characters begin, after NAME's dot
        name = entry[1 : cut - 1]
        if entry[cut - 1] == "." and name in names and entry[cut + 8 :] == Path(name).suffix:
            return True
    return False
