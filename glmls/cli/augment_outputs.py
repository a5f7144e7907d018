"""The outputs of ``glmls augment`` as one set: renamed into place from their temporary
names together, and replacing the set of an earlier run in the same folder, so that the
folder never mixes the images of two runs."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from ..files.atomic import umask
from ..files.images import WRITABLE
from ..gl.signals import signals_held
from .inputs import say

__all__ = ["former_outputs", "remove_former", "rename_all"]


def former_outputs(
    folder: Path, labels_name: str, written: set[str], read: list[Path]
) -> list[Path]:
    """The images of an earlier run in ``folder`` that this one does not write over: those
    that its labels file (``labels_name``) names (an entry with ``source`` and ``params``, a
    file of a format glmls writes), less the names this run writes (``written``) and the
    files it reads (``read``: its inputs, its labels). None where there is no labels file
    or it is not one that ``glmls augment`` wrote."""
    try:
        former = json.loads((folder / labels_name).read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):
        return []
    if not isinstance(former, dict):
        return []
    read_files = {path.resolve() for path in read}
    stale = []
    for name, entry in former.items():
        path = folder / name
        if (
            isinstance(entry, dict)
            and {"source", "params"} <= entry.keys()
            and name == path.name
            and name not in written
            and not name.startswith(".")
            and path.suffix.lower() in WRITABLE
            and path.is_file()
            and path.resolve() not in read_files
        ):
            stale.append(path)
    return stale


def _identities(paths: list[Path]) -> set[tuple[int, int]]:
    """(device, inode) of those of ``paths`` that exist: the files themselves, whatever names
    lead to them (on a case-insensitive file system ``A.png`` is ``a.png``)."""
    found = set()
    for path in paths:
        try:
            status = path.stat()
        except OSError:
            continue
        found.add((status.st_dev, status.st_ino))
    return found


def remove_former(
    args: argparse.Namespace, stale: list[Path], labels_name: str, kept: list[Path] = ()
) -> None:
    """Remove the images of an earlier run that this one's set replaces, saying how many;
    one that cannot be removed is named on stderr. A name that leads to one of ``kept`` (the
    files this run wrote and read) stays: on a case-insensitive file system an earlier run's
    ``A_000.png`` is this run's ``a_000.png``."""
    removed = 0
    keep = _identities(list(kept))
    with signals_held():
        for path in stale:
            try:
                status = path.stat()
            except OSError:
                continue
            if (status.st_dev, status.st_ino) in keep:
                continue
            try:
                path.unlink()
                removed += 1
            except FileNotFoundError:
                pass
            except OSError as error:
                print(
                    f"glmls augment: {path}: an image of an earlier run, not removed: "
                    f"{error.strerror or error}",
                    file=sys.stderr,
                )
    if removed:
        say(
            args,
            f"glmls augment: removed {removed} image{'s' * (removed != 1)} of an earlier run "
            f"that its {labels_name} named",
        )


def rename_all(written: list[tuple[str, str]]) -> None:
    """Rename every temporary file onto its final name (with the user's umask), Ctrl-C and
    SIGTERM held back until the last one (then raised): a set renamed in part would pass for
    a whole one. Where one rename fails, the outputs renamed before it and the temporary
    files not renamed yet are removed and an ``OSError`` names the output."""
    with signals_held():
        for k, (temporary, final) in enumerate(written):
            try:
                os.chmod(temporary, 0o666 & ~umask())
                os.replace(temporary, final)
            except OSError as error:
                for _, renamed in written[:k]:
                    Path(renamed).unlink(missing_ok=True)
                for name, _ in written[k:]:
                    Path(name).unlink(missing_ok=True)
                raise OSError(f"{final}: cannot write: {error.strerror or error}") from None
