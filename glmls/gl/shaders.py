"""Loading and composing the GLSL files in ``glmls/shaders`` (``common/``, ``mls/``, ``warp/``,
``adaptive/``, ``draw/``).

A program's stage is one entry file; its ``#include "folder/file.glsl"`` lines (paths from the
shader root) are resolved here, each file at most once per program, an include cycle being an
error. The composed source is ``#version``, then a ``#define`` for every binding point of
:mod:`glmls.gl.bindings`, the work-group sizes of :mod:`glmls.gl.dispatch` and the program's own
configuration, then the files.

Compile errors name the file and line: the loader keeps, for every line of the composed
source, the file and line it came from, and rewrites the driver's locations (Mesa's
``0:12(5)``, NVIDIA's ``0(12)``, ``ERROR: 0:12:`` elsewhere) with them. (Drivers disagree on
``#line``'s source-string numbers, Mesa ignores them, so the map is the loader's.)

With the environment variable ``GLMLS_DUMP_SHADERS`` set to a folder, every stage compiled
is also written there (:func:`dump`; ``tools/check_shaders.py`` runs the Khronos reference
compiler on them).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from importlib.resources.abc import Traversable

from . import bindings
from .dispatch import LOCAL_SIZE, LOCAL_SIZE_2D
from .tables import TABLE_SHIFT

__all__ = [
    "GLSL_VERSION",
    "ComposedSource",
    "ShaderCompileError",
    "ShaderLibrary",
    "common_defines",
    "define_value",
    "dump",
    "library",
]

GLSL_VERSION = "#version 430 core"
_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*(//.*)?$')
_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: Where drivers put source 0's line numbers: Mesa "0:12(5)", NVIDIA "0(12)", others
#: "ERROR: 0:12:".
_LOCATIONS = (
    (re.compile(r"(?<![\w.])0:(\d+)\((\d+)\)"), "{file}:{line}({col})"),
    (re.compile(r"(?<![\w.:])0\((\d+)\)"), "{file}({line})"),
    (re.compile(r"((?:ERROR|WARNING): )0:(\d+):"), "{prefix}{file}:{line}:"),
)
_STAGES = ("compute_shader", "vertex_shader", "fragment_shader", "geometry_shader")
_SUFFIXES = dict(zip(_STAGES, ("comp", "vert", "frag", "geom"), strict=True))


class ShaderCompileError(RuntimeError):
    """A glmls shader failed to compile or link; the message names file and line."""


def define_value(value: object) -> str:
    """A ``#define`` value: bool (0/1), int, finite float (a GLSL float literal) or an
    identifier (e.g. a GLSL function name); ``TypeError``/``ValueError`` otherwise."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        return str(value) if value >= 0 else f"({value})"
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"#define values must be finite, got {value!r}")
        text = repr(value)  # round-trips; always has a '.' or an exponent: a float literal
        return text if value >= 0 else f"({text})"
    if isinstance(value, str) and _IDENTIFIER.fullmatch(value):
        return value
    raise TypeError(f"#define values must be bool, int, float or an identifier, got {value!r}")


@dataclass(frozen=True)
class ComposedSource:
    """One stage's GLSL: ``text``, and for each of its lines (1-based) the file and line it
    came from (``"<defines>"`` for the prologue); ``entry``, its entry file."""

    text: str
    origins: tuple[tuple[str, int], ...]
    entry: str = ""

    def locate(self, line: int) -> tuple[str, int]:
        if 1 <= line <= len(self.origins):
            return self.origins[line - 1]
        return ("<composed>", line)

    def explain(self, message: str) -> str:
        """``message`` with the driver's line numbers replaced by file:line."""

        def mesa(match: re.Match) -> str:
            file, line = self.locate(int(match.group(1)))
            return f"{file}:{line}({match.group(2)})"

        def nvidia(match: re.Match) -> str:
            file, line = self.locate(int(match.group(1)))
            return f"{file}({line})"

        def other(match: re.Match) -> str:
            file, line = self.locate(int(match.group(2)))
            return f"{match.group(1)}{file}:{line}:"

        for (pattern, _), replace in zip(_LOCATIONS, (mesa, nvidia, other), strict=True):
            message = pattern.sub(replace, message)
        return message


def common_defines() -> dict[str, object]:
    """What every glmls program is compiled with: the binding points (``BIND_*``), the
    work-group sizes the dispatches assume (``LOCAL_SIZE``, ``LOCAL_SIZE_2D``) and the
    tables' layout (``TABLE_SHIFT``, :mod:`.tables`)."""
    return bindings.defines() | {
        "LOCAL_SIZE": LOCAL_SIZE,
        "LOCAL_SIZE_2D": LOCAL_SIZE_2D,
        "TABLE_SHIFT": TABLE_SHIFT,
    }


class ShaderLibrary:
    """The GLSL files under ``root`` and their composition (see the module docstring).

    ``common``: defines every composed source gets (by default :func:`common_defines`).
    """

    def __init__(self, root: Traversable, *, common: Mapping[str, object] | None = None):
        self.root = root
        self.common = dict(common_defines() if common is None else common)
        self.source = functools.cache(self._read)

    def _read(self, name: str) -> str:
        path = self.root
        for part in name.split("/"):
            path = path.joinpath(part)
        if not path.is_file():
            raise FileNotFoundError(f"no shader named {name!r} in {self.root}")
        return path.read_text(encoding="utf-8")

    def compose(self, entry: str, defines: Mapping[str, object] | None = None) -> ComposedSource:
        """The source of the stage whose entry file is ``entry``, with ``defines``."""
        lines = [GLSL_VERSION]
        merged = self.common | dict(defines or {})
        for key in sorted(merged):
            if not _IDENTIFIER.fullmatch(key):
                raise ValueError(f"#define names must be identifiers, got {key!r}")
            lines.append(f"#define {key} {define_value(merged[key])}")
        origins = [("<defines>", k + 1) for k in range(len(lines))]
        self._expand(entry, lines, origins, seen=set(), stack=())
        _check_conditions(lines, origins)
        return ComposedSource("\n".join(lines) + "\n", tuple(origins), entry)

    def _expand(self, name, lines, origins, *, seen: set[str], stack: tuple[str, ...]) -> None:
        if name in stack:
            raise ShaderCompileError("#include cycle: " + " -> ".join((*stack, name)))
        if name in seen:
            return  # each file once per program
        seen.add(name)
        for number, line in enumerate(self.source(name).splitlines(), 1):
            match = _INCLUDE.match(line)
            if match is None:
                lines.append(line)
                origins.append((name, number))
                continue
            try:
                self._expand(match.group(1), lines, origins, seen=seen, stack=(*stack, name))
            except FileNotFoundError as error:
                raise FileNotFoundError(f"{name}:{number}: {error}") from None

    def explain(self, message: str, stages: Mapping[str, ComposedSource]) -> str:
        """A driver's compile log with each stage's lines mapped to file:line (moderngl
        heads each stage's log with its name, e.g. ``fragment_shader``)."""
        parts = re.split(r"^(" + "|".join(_STAGES) + r")$", message, flags=re.MULTILINE)
        out, current = [parts[0]], None
        for part in parts[1:]:
            if part in _STAGES:
                current = part
                out.append(part)
            else:
                source = stages.get(current or "")
                out.append(source.explain(part) if source is not None else part)
        if len(parts) == 1 and len(stages) == 1:
            return next(iter(stages.values())).explain(message)
        return "".join(out)


_DIRECTIVE = re.compile(r"^\s*#\s*(define|undef|ifdef|ifndef|if|elif|else|endif)\b\s*(.*)$")
_DEFINED = re.compile(r"\bdefined\s*(?:\(\s*(\w+)\s*\)|(\w+))")
_TOKEN = re.compile(r"\s*(\d+[uU]?|[A-Za-z_]\w*|&&|\|\||==|!=|<=|>=|[-+*/%<>()!~])")
_PYTHON = {"&&": " and ", "||": " or ", "!": " not ", "/": "//"}


class _Conditions:
    """The preprocessor's state while :func:`_check_conditions` walks a composed source."""

    def __init__(self) -> None:
        self.macros: dict[str, str] = {}
        self.stack: list[tuple[bool, bool]] = []  # (group active, a branch was taken)

    @property
    def active(self) -> bool:
        return all(active for active, _ in self.stack)

    def value(self, expression: str, where: str) -> bool:
        """``expression`` of a #if in an active group, its macros expanded; an undefined
        macro is an error."""
        text = _DEFINED.sub(
            lambda m: "1" if (m.group(1) or m.group(2)) in self.macros else "0", expression
        )
        for _ in range(8):  # macros defined as other macros
            words = [w for w in _IDENTIFIER.findall(text) if not w.isdigit()]
            missing = [w for w in words if w not in self.macros]
            if missing:
                raise ShaderCompileError(
                    f"{where}: #if uses {missing[0]}, which is not defined: pass it as a "
                    "define of the program (or give it a default with #ifndef)"
                )
            if not words:
                break
            text = _IDENTIFIER.sub(lambda m: self.macros.get(m.group(), m.group()), text)
        tokens, position = [], 0
        while position < len(text.rstrip()):
            match = _TOKEN.match(text, position)
            if match is None:
                return True  # beyond this check (e.g. float literals): the driver decides
            token = match.group(1).rstrip("uU")
            tokens.append(_PYTHON.get(token, token))
            position = match.end()
        try:  # only numbers, operators and parentheses are left: C's meaning in Python
            return bool(eval("".join(tokens), {"__builtins__": {}}))
        except Exception:
            return True


def _check_conditions(lines: list[str], origins: list[tuple[str, int]]) -> None:
    """A ``#if`` on a macro that is not defined is an error in the GLSL specification (no
    default of 0, unlike C): Mesa lets it pass, NVIDIA's compiler does not. Catch it here,
    on every driver, naming the file and line (groups the preprocessor skips are not
    evaluated, as a compiler would not)."""
    state = _Conditions()
    for line, (name, number) in zip(lines, origins, strict=True):
        match = _DIRECTIVE.match(line)
        if match is None:
            continue
        kind, rest = match.group(1), match.group(2).split("//")[0].strip()
        where = f"{name}:{number}"
        if kind in ("define", "undef"):
            if state.active:
                word = _IDENTIFIER.match(rest)
                if word is not None and kind == "define":
                    state.macros[word.group()] = rest[word.end() :].strip() or "1"
                elif word is not None:
                    state.macros.pop(word.group(), None)
        elif kind in ("if", "ifdef", "ifndef"):
            taken = False
            if state.active:
                if kind == "if":
                    taken = state.value(rest, where)
                else:
                    taken = (rest in state.macros) == (kind == "ifdef")
            state.stack.append((taken, taken))
        elif not state.stack:
            raise ShaderCompileError(f"{where}: #{kind} without #if")
        elif kind == "elif":
            _, done = state.stack.pop()
            outer = state.active
            taken = not done and outer and state.value(rest, where)
            state.stack.append((taken, done or taken))
        elif kind == "else":
            _, done = state.stack.pop()
            state.stack.append((not done, True))
        else:
            state.stack.pop()


def dump(stages: Mapping[str, ComposedSource], folder: str) -> None:
    """Write each stage's source to ``folder`` as ``ENTRY.HASH.SUFFIX`` (the entry file's
    path with ``_`` for ``/``, a hash of the text, the stage: ``comp``, ``vert``, ``frag``,
    ``geom``), and beside it ``ENTRY.HASH.SUFFIX.json``: the entry, each line's origin and the
    program's stage files; a source already there is not written again. Each file is written
    whole or not at all (:func:`~glmls.files.atomic_write`): a process stopped while it
    writes, or another writing the same program, leaves no partial source that later runs
    would keep. :class:`~glmls.gl.GLContext` calls it for every program it compiles when
    ``GLMLS_DUMP_SHADERS`` names a folder."""
    from ..files.atomic import atomic_write  # only here: the debugging dump writes files

    os.makedirs(folder, exist_ok=True)
    names = {}
    for stage, source in stages.items():
        digest = hashlib.sha256(source.text.encode()).hexdigest()[:12]
        entry = (source.entry or "shader").removesuffix(".glsl").replace("/", "_")
        names[stage] = f"{entry}.{digest}.{_SUFFIXES[stage]}"
    for stage, source in stages.items():
        path = os.path.join(folder, names[stage])
        if not os.path.exists(path):
            about = {"entry": source.entry, "origins": source.origins, "program": [*names.values()]}
            with atomic_write(path + ".json") as temporary:  # before the source it describes
                temporary.write_text(json.dumps(about), encoding="utf-8")
            with atomic_write(path) as temporary:
                temporary.write_text(source.text, encoding="utf-8")


@functools.cache
def library() -> ShaderLibrary:
    """The shaders shipped inside the package (``glmls/shaders``)."""
    return ShaderLibrary(resources.files("glmls").joinpath("shaders"))
