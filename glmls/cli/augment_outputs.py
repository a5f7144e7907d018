"""The outputs of ``glmls augment`` as one set: renamed into place from their temporary
names together, and replacing the set of an earlier run in the same folder, so that the
folder never mixes the images of two runs."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

from ..files.atomic import umask
from ..files.images import WRITABLE
from .inputs import say

__all__ = ["former_outputs", "remove_former", "rename_all", "signals_held"]


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


def remove_former(args: argparse.Namespace, stale: list[Path], labels_name: str) -> None:
    """Remove the images of an earlier run that this one's set replaces, saying how many;
    one that cannot be removed is named on stderr."""
    removed = 0
    with signals_held():
        for path in stale:
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


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM recorded, not acted on, in the block, then raised again with the
    handlers they had (in the main thread, where Python runs signal handlers)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    numbers = (signal.SIGINT, signal.SIGTERM)
    previous = {n: signal.signal(n, lambda number, _: caught.append(number)) for n in numbers}
    try:
        yield
    finally:
        for number, handler in previous.items():  # None: set in C, not restorable
            signal.signal(number, signal.SIG_DFL if handler is None else handler)
        for number in dict.fromkeys(caught):
            signal.raise_signal(number)
