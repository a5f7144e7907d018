"""Loading, composing and compiling the GLSL files in ``shaders/``.

Shaders are plain files shipped inside the wheel (``glmls/shaders``); in a source checkout
they are read from the top-level ``shaders/`` folder. A program is a list of files
concatenated after a ``#version`` line and the ``#define`` lines of its configuration, so that
one MLS implementation (``mls_core.glsl``) serves every pass.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

GLSL_VERSION = "#version 430 core"


@functools.cache
def shader_root() -> Traversable:
    """The folder holding the GLSL files (packaged copy first, then the source checkout)."""
    packaged = resources.files("glmls").joinpath("shaders")
    if packaged.is_dir():
        return packaged
    source = Path(__file__).resolve().parent.parent / "shaders"
    if source.is_dir():
        return source
    raise FileNotFoundError(
        "glmls shaders not found: neither glmls/shaders (installed wheel) nor "
        f"{source} (source checkout) exists; reinstall glmls"
    )


@functools.cache
def load_source(name: str) -> str:
    """The text of one shader file, e.g. ``load_source("mls_core.glsl")``."""
    path = shader_root().joinpath(name)
    if not path.is_file():
        raise FileNotFoundError(f"no shader named {name!r} in {shader_root()}")
    return path.read_text(encoding="utf-8")


def _define_value(value: object) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value)
    raise TypeError(f"#define values must be bool or int, got {value!r}")


def compose(parts: Iterable[str], defines: Mapping[str, object] | None = None) -> str:
    """One GLSL source: ``#version``, the defines, then each file with a ``#line`` marker.

    ``#line 1 K`` makes a compiler error point at line numbers of part K (0-based, in order).
    """
    lines = [GLSL_VERSION]
    for key, value in sorted((defines or {}).items()):
        lines.append(f"#define {key} {_define_value(value)}")
    for index, name in enumerate(parts):
        lines.append(f"#line 1 {index}")
        lines.append(load_source(name))
    return "\n".join(lines) + "\n"
