"""What a GLSL program does with the storage blocks, uniform blocks and images it declares:
which bytes of each it may read, which it may store to, which only atomics touch. Read from
the source (a composed glmls stage), for :mod:`barrier_trace`.

Drivers report every std430 block a program declares as active, used or not, and GL tells
nothing of ``readonly``; so the source decides: the code reachable from ``main`` (functions
and function-like macros), its ``#if`` groups as compiled, the ``readonly`` and
``writeonly`` qualifiers, and, per block member, where std430 places it. A member is stored
where it is assigned (after any subscripts and fields), incremented, the first argument of
an atomic, or passed to a function's ``out``/``inout`` parameter or to a macro that stores
to that parameter; it is atomic-only where every use is the first argument of an atomic (a
macro's included). Runtime branches are not followed: what a program may do is what any of
its invocations could.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["END", "Access", "preprocess", "units", "usage"]

#: The end of a range that runs to the end of the resource.
END = 1 << 62
_WHOLE = ((0, END),)

_DIRECTIVE = re.compile(r"^\s*#\s*(\w+)\s*(.*)$")
_DEFINED = re.compile(r"\bdefined\s*(?:\(\s*(\w+)\s*\)|(\w+))")
_WORD = re.compile(r"[A-Za-z_]\w*")
_COMMENTS = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_BLOCK = re.compile(r"layout\s*\([^)]*\)\s*((?:\w+\s+)*?)buffer\s+(\w+)\s*\{([^}]*)\}\s*(\w*)")
_UNIFORM_BLOCK = re.compile(r"layout\s*\([^)]*\)\s*uniform\s+(\w+)\s*\{([^}]*)\}\s*(\w*)")
_IMAGE = re.compile(
    r"layout\s*\(([^)]*)\)\s*((?:\w+\s+)*?)uniform\s+((?:\w+\s+)*?)\w*image\w+\s+(\w+)"
)
_SAMPLER = re.compile(r"layout\s*\(([^)]*)\)\s*uniform\s+(?:\w+\s+)*?\w*sampler\w*\s+(\w+)")
_FUNCTION = re.compile(r"\b(\w+)\s+(\w+)\s*\(([^()]*)\)\s*\{")
_STORING = re.compile(r"\b(atomic\w+|imageStore|imageAtomic\w+)\s*\(\s*(\w+)")
_ATOMIC = re.compile(r"\b(?:atomic\w+|imageAtomic\w+)\s*\(\s*(\w+)")
_ASSIGNED = re.compile(r"\s*(?:[-+*/%&|^]?=(?!=)|<<=|>>=|\+\+|--)")
_KEYWORDS = {"if", "for", "while", "switch", "return", "else"}
_QUALIFIERS = {"readonly", "writeonly", "coherent", "volatile", "restrict", "highp", "mediump"}
#: std430 (size, alignment) of the member types the layout follows.
_LAYOUT = {
    **{t: (4, 4) for t in ("float", "int", "uint", "bool")},
    **{p + "vec2": (8, 8) for p in ("", "i", "u", "b")},
    **{p + "vec3": (12, 16) for p in ("", "i", "u", "b")},
    **{p + "vec4": (16, 16) for p in ("", "i", "u", "b")},
    "mat2": (16, 8),
    "mat3": (48, 16),
    "mat4": (64, 16),
}


@dataclass(frozen=True)
class Access:
    """A program's use of one resource: byte ranges [start, end) it may read, store to, and
    those only atomics touch."""

    reads: tuple[tuple[int, int], ...] = ()
    stores: tuple[tuple[int, int], ...] = ()
    atomic: tuple[tuple[int, int], ...] = ()


def _evaluate(expression: str, macros: dict[str, str]) -> bool:
    text = _DEFINED.sub(lambda m: "1" if (m.group(1) or m.group(2)) in macros else "0", expression)
    for _ in range(8):
        text = _WORD.sub(lambda m: macros.get(m.group(), "0"), text)
    text = re.sub(r"(\d+)[uU]\b", r"\1", text)
    text = text.replace("&&", " and ").replace("||", " or ").replace("/", "//")
    text = re.sub(r"!(?!=)", " not ", text)
    return bool(eval(text, {"__builtins__": {}}))  # numbers and operators only


def preprocess(source: str) -> tuple[str, dict[str, str], dict[str, tuple[list[str], str]]]:
    """The code of a GLSL ``source`` that its ``#if`` groups keep, without comments or
    directives (macros are not expanded in it); its object-like macros (name -> value) and
    function-like ones (name -> (parameters, body))."""
    macros: dict[str, str] = {}
    functions: dict[str, tuple[list[str], str]] = {}
    stack: list[tuple[bool, bool]] = []  # (group active, a branch was taken)
    kept = []
    text = _COMMENTS.sub(" ", source).replace("\\\n", " ")
    for line in text.splitlines():
        match = _DIRECTIVE.match(line)
        active = all(a for a, _ in stack)
        if match is None:
            if active:
                kept.append(line)
            continue
        kind, rest = match.group(1), match.group(2).strip()
        if kind == "define" and active:
            word = _WORD.match(rest)
            after = rest[word.end() :]
            if after.startswith("("):
                close = after.index(")")
                parameters = [p.strip() for p in after[1:close].split(",")]
                functions[word.group()] = (parameters, after[close + 1 :])
            else:
                macros[word.group()] = after.strip() or "1"
        elif kind == "undef" and active:
            macros.pop(rest, None)
            functions.pop(rest, None)
        elif kind in ("if", "ifdef", "ifndef"):
            if kind == "if":
                taken = active and _evaluate(rest, macros)
            else:
                defined = rest in macros or rest in functions
                taken = active and defined == (kind == "ifdef")
            stack.append((taken, taken))
        elif kind == "elif":
            _, done = stack.pop()
            taken = not done and all(a for a, _ in stack) and _evaluate(rest, macros)
            stack.append((taken, done or taken))
        elif kind == "else":
            _, done = stack.pop()
            stack.append((not done and all(a for a, _ in stack), True))
        elif kind == "endif":
            stack.pop()
    return "\n".join(kept), macros, functions


def _closing(text: str, start: int, pair: str = "{}") -> int:
    """The index just past the bracket that closes the one at ``start``."""
    depth = 0
    for k in range(start, len(text)):
        depth += (text[k] == pair[0]) - (text[k] == pair[1])
        if depth == 0:
            return k + 1
    return len(text)


def _calls(text: str, callables: dict[str, set[int]]) -> list[tuple[str, list[str]]]:
    """Each call in ``text`` of one of ``callables``: (name, its top-level arguments)."""
    found = []
    for match in _WORD.finditer(text):
        if match.group() not in callables:
            continue
        start = match.end()
        while start < len(text) and text[start].isspace():
            start += 1
        if start >= len(text) or text[start] != "(":
            continue
        args, depth, current = [], 0, []
        for char in text[start + 1 : _closing(text, start, "()") - 1]:
            if char == "," and depth == 0:
                args.append("".join(current).strip())
                current = []
                continue
            depth += (char in "([") - (char in ")]")
            current.append(char)
        args.append("".join(current).strip())
        found.append((match.group(), args))
    return found


def _leading(argument: str) -> str | None:
    word = _WORD.match(argument)
    return None if word is None else word.group()


def _stored(text: str, names: set[str], callables: dict[str, set[int]]) -> set[str]:
    """Those of ``names`` that ``text`` stores to (the module docstring); ``callables``:
    function or macro -> the positions of the parameters it stores to."""
    found = {m.group(2) for m in _STORING.finditer(text) if m.group(2) in names}
    for match in _WORD.finditer(text):
        word = match.group()
        if word not in names or word in found:
            continue
        end = match.end()
        while True:
            rest = text[end:].lstrip()
            end = len(text) - len(rest)
            if rest.startswith("["):
                end = _closing(text, end, "[]")
            elif rest.startswith(".") and _WORD.match(rest[1:]):
                end += 1 + len(_WORD.match(rest[1:]).group())
            else:
                break
        if _ASSIGNED.match(text, end) or text[: match.start()].rstrip().endswith(("++", "--")):
            found.add(word)
    for name, args in _calls(text, callables):
        for k in callables[name]:
            if k < len(args) and _leading(args[k]) in names:
                found.add(_leading(args[k]))
    return found


def _atomic_uses(text: str, name: str, atomic_params: dict[str, set[int]]) -> int:
    count = sum(1 for m in _ATOMIC.finditer(text) if m.group(1) == name)
    for macro, args in _calls(text, atomic_params):
        count += sum(1 for k in atomic_params[macro] if k < len(args) and _leading(args[k]) == name)
    return count


def _layout(body: str, macros: dict[str, str]) -> list[tuple[str, int, int]]:
    """The members of a block's ``body``: (name, first byte, end) in std430 (END where
    unknown: a struct, an array of a size not known here, what follows either)."""
    members, offset = [], 0
    for declaration in body.split(";"):
        words = [w for w in _WORD.findall(declaration.split("[")[0]) if w not in _QUALIFIERS]
        if len(words) < 2:
            continue
        kind, name = macros.get(words[0], words[0]), words[-1]
        size, align = _LAYOUT.get(kind, (None, None))
        array = re.search(r"\[\s*(\w*)\s*\]", declaration)
        if size is None or offset is None:
            start = 0 if offset is None else offset
            members.append((name, start, END))
            offset = None
            continue
        start = -(-offset // align) * align
        if array is None:
            members.append((name, start, start + size))
            offset = start + size
            continue
        count = macros.get(array.group(1), array.group(1))
        stride = -(-size // align) * align
        if count.isdigit():
            members.append((name, start, start + int(count) * stride))
            offset = start + int(count) * stride
        else:
            members.append((name, start, END))
            offset = None
    return members


def usage(source: str) -> dict[str, Access]:
    """What the program of GLSL ``source`` does with each storage block, uniform block (by
    block name) and image (by uniform name) that it declares: :class:`Access`."""
    text, macros, function_macros = preprocess(source)
    functions: dict[str, list[tuple[str, list[list[str]]]]] = {}
    for match in _FUNCTION.finditer(text):
        if match.group(2) in _KEYWORDS or match.group(1) in _KEYWORDS:
            continue
        body = text[match.end() - 1 : _closing(text, match.end() - 1)]
        parameters = [p.split() for p in match.group(3).split(",") if p.strip()]
        functions.setdefault(match.group(2), []).append((body, parameters))
    # the code main reaches, through functions and macros
    reached, todo, bodies = set(), ["main"], []
    while todo:
        name = todo.pop()
        if name in reached:
            continue
        reached.add(name)
        found = [body for body, _ in functions.get(name, ())]
        if name in function_macros:
            found.append(function_macros[name][1])
        for body in found:
            bodies.append(body)
            todo.extend(
                w for w in set(_WORD.findall(body)) if w in functions or w in function_macros
            )
    code = "\n".join(bodies)
    words = set(_WORD.findall(code))
    callables: dict[str, set[int]] = {}
    atomic_params: dict[str, set[int]] = {}
    for name, (parameters, body) in function_macros.items():
        stored = _stored(body, set(parameters), {})
        callables[name] = {k for k, p in enumerate(parameters) if p in stored}
        atomic_params[name] = {
            k
            for k, p in enumerate(parameters)
            if p in stored and _atomic_uses(body, p, {}) == len(re.findall(rf"\b{p}\b", body))
        }
    for name, overloads in functions.items():
        for _, parameters in overloads:
            callables.setdefault(name, set()).update(
                k for k, p in enumerate(parameters) if {"out", "inout"} & set(p)
            )
    result = {}
    for match in _BLOCK.finditer(text):
        qualifiers = set(match.group(1).split())
        if match.group(4):  # an instance name: the block as one
            members = [(match.group(4), 0, END)]
        else:
            members = _layout(match.group(3), macros)
        reads, stores, atomic = [], [], []
        for name, start, end in members:
            uses = len(re.findall(rf"\b{name}\b", code))
            if not uses:
                continue
            if "writeonly" not in qualifiers:
                reads.append((start, end))
            if "readonly" not in qualifiers and _stored(code, {name}, callables):
                stores.append((start, end))
            if _atomic_uses(code, name, atomic_params) == uses:
                atomic.append((start, end))
        result[match.group(2)] = Access(tuple(reads), tuple(stores), tuple(atomic))
    for match in _UNIFORM_BLOCK.finditer(text):
        names = (
            {match.group(3)} if match.group(3) else {m[0] for m in _layout(match.group(2), macros)}
        )
        result[match.group(1)] = Access(_WHOLE if names & words else ())
    for match in _IMAGE.finditer(text):
        qualifiers = set((match.group(2) + " " + match.group(3)).split())
        name = match.group(4)
        if name not in words:
            result[name] = Access()
            continue
        uses = len(re.findall(rf"\b{name}\b", code))
        result[name] = Access(
            () if "writeonly" in qualifiers else _WHOLE,
            () if "readonly" in qualifiers else _WHOLE,
            _WHOLE if _atomic_uses(code, name, atomic_params) == uses else (),
        )
    return result


def units(source: str) -> dict[str, int]:
    """The unit of each image and sampler uniform of GLSL ``source`` (by name), from its
    layout's ``binding`` (GL's uniform query does not give an image's everywhere)."""
    text, macros, _ = preprocess(source)
    found = {}
    for match in (*_IMAGE.finditer(text), *_SAMPLER.finditer(text)):
        binding = re.search(r"\bbinding\s*=\s*(\w+)", match.group(1))
        if binding is not None:
            value = binding.group(1)
            for _ in range(8):
                value = macros.get(value, value)
            if value.isdigit():
                found[match.group(match.lastindex)] = int(value)
    return found
