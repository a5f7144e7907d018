"""Every public function and class of glmls has a numpydoc docstring, and its Examples run.

The public names are the functions and classes (exceptions and warnings included) in the
``__all__`` of :mod:`glmls`, :mod:`glmls.analysis`, :mod:`glmls.augment`, :mod:`glmls.files`,
:mod:`glmls.gl`, :mod:`glmls.reference`, :mod:`glmls.data`, :mod:`glmls.mls3`,
:mod:`glmls.volume` and :mod:`glmls.app`. Each docstring parses as numpydoc and passes
:data:`CHECKS` of ``numpydoc.validate``; its Examples (and those of the class's methods) run
as doctests with ``np`` and ``glmls`` imported, on glmls's shared headless context.
"""

from __future__ import annotations

import doctest
import inspect
import io
import typing

import numpy as np
import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc
from numpydoc.validate import validate

import glmls
import glmls.app
import glmls.files
import glmls.volume

MODULES = [
    glmls,
    glmls.analysis,
    glmls.augment,
    glmls.files,
    glmls.gl,
    glmls.reference,
    glmls.data,
    glmls.mls3,
    glmls.volume,
    glmls.app,
]

#: The numpydoc.validate checks every public function passes: a docstring (GL08) with a
#: summary (SS01) on one line (SS06) that ends with a period (SS03); every signature parameter
#: documented (PR01), no documented parameter missing from the signature (PR02), each with a
#: description (PR07); a Returns section when the function returns a value (RT01), Yields
#: for generators (YD01); an Examples section (EX01).
CHECKS = {"GL08", "SS01", "SS03", "SS06", "PR01", "PR02", "PR07", "RT01", "YD01", "EX01"}
#: Those that every public class passes (its parameters are checked against Parameters and
#: Attributes together below: a dataclass documents its fields as either).
CLASS_CHECKS = {"GL08", "SS01", "SS03", "SS06", "EX01"}

_FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def public_names() -> list[tuple[str, object]]:
    """(qualified name, object) for every function and class in the modules' ``__all__``,
    each once (``glmls.imread`` is ``glmls.files.imread``)."""
    found, seen = [], set()
    for module in MODULES:
        for name in module.__all__:
            obj = getattr(module, name)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and id(obj) not in seen:
                seen.add(id(obj))
                found.append((f"{module.__name__}.{name}", obj))
    return found


PUBLIC = public_names()


def _params(names: list[tuple[str, object]]):
    return [pytest.param(obj, id=name) for name, obj in names]


def _is_exception(obj: object) -> bool:
    return inspect.isclass(obj) and issubclass(obj, BaseException)


def _signature_parameters(obj) -> list[str]:
    try:
        signature = inspect.signature(obj)
    except (TypeError, ValueError):
        return []
    skip = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return [
        name
        for name, p in signature.parameters.items()
        if name not in ("self", "cls") and p.kind not in skip
    ]


def _names(section) -> set[str]:
    """The names of a numpydoc Parameters or Attributes section (``src, dst`` are two)."""
    return {part.strip().lstrip("*") for item in section for part in item.name.split(",")}


def _returns_none(func) -> bool:
    """Whether ``func`` returns nothing: annotated ``None``, or ``NoReturn`` (it always raises)."""
    annotation = inspect.signature(func).return_annotation
    return annotation in (None, "None", "NoReturn", typing.NoReturn)


def _public_members(cls) -> list[tuple[str, object]]:
    """Public methods and properties that glmls defines on ``cls`` (inherited ones included)."""
    members = []
    for name in sorted(dir(cls)):
        if name.startswith("_"):
            continue
        raw = inspect.getattr_static(cls, name)
        if isinstance(raw, (staticmethod, classmethod)):
            raw = raw.__func__
        if isinstance(raw, property):
            target = raw.fget
        elif inspect.isfunction(raw):
            target = raw
        else:
            continue
        if (getattr(target, "__module__", "") or "").startswith("glmls"):
            members.append((name, raw))
    return members


def test_the_public_names_are_found():
    names = {name for name, _ in PUBLIC}
    for expected in (
        "glmls.MLSConfig",
        "glmls.ReleasedError",
        "glmls.analysis.tune",
        "glmls.data.astronaut",
        "glmls.files.read_handle_set",
        "glmls.gl.create_headless",
        "glmls.gl.get_context",
        "glmls.reference.mls",
    ):
        assert expected in names
    assert "glmls.TRANSFORMS" not in names  # a constant
    assert "glmls.analysis.VIRIDIS" not in names
    for module in (glmls.reference, glmls.data):
        assert hasattr(module, "__all__"), module.__name__


@pytest.mark.parametrize("obj", _params(PUBLIC))
def test_docstring_is_numpydoc(obj):
    assert obj.__doc__, "no docstring"  # its own: getdoc would fall back on a base class's
    doc = inspect.getdoc(obj)
    problems: list[str] = []
    result = validate(f"{obj.__module__}.{obj.__qualname__}")
    checks = CLASS_CHECKS if inspect.isclass(obj) else CHECKS
    problems += [f"{code}: {message}" for code, message in result["errors"] if code in checks]
    if inspect.isclass(obj):
        parsed = ClassDoc(obj, doc=doc)
        if not _is_exception(obj):
            parameters = _names(parsed["Parameters"])
            documented = parameters | _names(parsed["Attributes"])
            if not documented:
                problems.append("no Parameters or Attributes section")
            takes = _signature_parameters(obj)
            problems += [f"parameter {n!r} is not documented" for n in takes if n not in documented]
            problems += [f"documented {n!r} is not a parameter" for n in parameters - set(takes)]
    else:
        parsed = FunctionDoc(obj, doc=doc)
        takes = _signature_parameters(obj)
        if takes and not parsed["Parameters"]:
            problems.append("no Parameters section")
        if takes and not parsed["Raises"]:
            problems.append("no Raises section")
        if not _returns_none(obj) and not (parsed["Returns"] or parsed["Yields"]):
            problems.append("no Returns or Yields section")
    examples = "\n".join(parsed["Examples"])
    if ">>>" not in examples:
        problems.append("no Examples with >>>")
    assert not problems, "\n".join(problems)


_CLASSES = [(name, obj) for name, obj in PUBLIC if inspect.isclass(obj)]


@pytest.mark.parametrize("cls", _params(_CLASSES))
def test_public_members_are_documented(cls):
    problems = []
    for name, raw in _public_members(cls):
        target = raw.fget if isinstance(raw, property) else raw
        if not target.__doc__:
            problems.append(f"{name}: no docstring")
            continue
        doc = inspect.getdoc(target)
        if isinstance(raw, property):
            continue
        if _signature_parameters(target) and not FunctionDoc(target, doc=doc)["Parameters"]:
            problems.append(f"{name}: no Parameters section")
    assert not problems, "\n".join(problems)


_CALLABLES = [
    (name, cls)
    for name, cls in _CLASSES
    if inspect.isfunction(call := inspect.getattr_static(cls, "__call__", None))
    and (call.__module__ or "").startswith("glmls")
]


@pytest.mark.parametrize("cls", _params(_CALLABLES))
def test_the_call_of_a_transform_is_documented_with_examples(cls):
    """``m(points)`` is the heart of a transform's protocol: its docstring has Parameters,
    Returns and Examples, as the public functions' have (the members above are not asked
    for Examples; names that start with an underscore are not looked at)."""
    doc = FunctionDoc(cls.__call__, doc=inspect.getdoc(cls.__call__))
    missing = [section for section in ("Parameters", "Returns") if not doc[section]]
    if ">>>" not in "\n".join(doc["Examples"]):
        missing.append("Examples")
    assert not missing, missing


def test_the_transforms_are_among_the_callables():
    names = {name for name, _ in _CALLABLES}
    assert {"glmls.MLS", "glmls.InverseMLS", "glmls.analysis.ReferenceDeformation"} <= names


#: The modules whose classes' public methods and properties each carry their own Examples:
#: all of :data:`MODULES` but :mod:`glmls.gl` (the GL plumbing itself).
MEMBER_EXAMPLE_MODULES = [module for module in MODULES if module is not glmls.gl]
#: Members of those classes that are GL plumbing, for the passes of :mod:`glmls.gl`: they need
#: no Examples, but their summary says what they are for.
GL_PLUMBING = {"defines", "kernel", "swapped_kernel", "uniforms"}


def _member_example_classes() -> list[tuple[str, type]]:
    owners = {id(obj) for module in MEMBER_EXAMPLE_MODULES for obj in vars(module).values()}
    return [
        (name, cls)
        for name, cls in _CLASSES
        if id(cls) in owners and not _is_exception(cls) and name.split(".")[1] != "gl"
    ]


_MEMBER_CLASSES = _member_example_classes()


def _target(raw) -> object:
    return raw.fget if isinstance(raw, property) else raw


@pytest.mark.parametrize("cls", _params(_MEMBER_CLASSES))
def test_public_members_have_examples(cls):
    """Every public method and property of a user-facing class has a one-line summary,
    Returns where it returns a value, and Examples (the GL plumbing: a summary that says so)."""
    problems = []
    for name, raw in _public_members(cls):
        target = _target(raw)
        doc = FunctionDoc(target, doc=inspect.getdoc(target) or "")
        summary = " ".join(doc["Summary"])
        if len(doc["Summary"]) != 1:
            problems.append(f"{name}: the summary is not one line")
        if name in GL_PLUMBING:
            if "for GL passes" not in summary:
                problems.append(f"{name}: GL plumbing whose summary does not say 'for GL passes'")
            continue
        if ">>>" not in "\n".join(doc["Examples"]):
            problems.append(f"{name}: no Examples with >>>")
        if not isinstance(raw, property) and not _returns_none(target) and not doc["Returns"]:
            problems.append(f"{name}: no Returns section")
    assert not problems, "\n".join(problems)


def test_the_member_rule_covers_the_classes_a_user_meets_first():
    names = {name for name, _ in _MEMBER_CLASSES}
    expected = {
        "glmls.MLS",
        "glmls.InverseMLS",
        "glmls.HandleSet",
        "glmls.MLSConfig",
        "glmls.WarpOptions",
        "glmls.BatchResult",
        "glmls.augment.Augment",
        "glmls.augment.AugmentResult",
        "glmls.volume.VolumeBounds",
        "glmls.analysis.Canvas",
        "glmls.mls3.MLS3",
        "glmls.app.App",
        "glmls.app.Controller",
        "glmls.app.VolumeApp",
        "glmls.app.VolumeController",
    }
    assert expected <= names, expected - names
    assert not any(name.startswith("glmls.gl.") for name in names)


def _inherited_members() -> list[tuple[str, object]]:
    """Members that the public classes inherit from a base that is not public itself
    (``MLS.config`` is ``ForkSafe.config``): :func:`test_examples_run` does not reach them."""
    public = {id(cls) for _, cls in _CLASSES}
    found, seen = [], set()
    for _, cls in _MEMBER_CLASSES:
        for _, raw in _public_members(cls):
            target = _target(raw)
            owner = next(
                (
                    base
                    for base in cls.__mro__
                    if target.__name__ in vars(base)
                    and _target(vars(base)[target.__name__]) is target
                ),
                cls,
            )
            if id(owner) in public or id(target) in seen:
                continue
            seen.add(id(target))
            found.append((f"{target.__module__}.{target.__qualname__}", target))
    return found


_INHERITED = _inherited_members()


def test_inherited_members_are_found():
    names = {name for name, _ in _INHERITED}
    assert {"glmls.forking.ForkSafe.config", "glmls.forking.ForkSafe.shape"} <= names


def _run_examples(obj, name: str) -> None:
    finder = doctest.DocTestFinder(exclude_empty=True)
    found = finder.find(obj, name=name, globs={"np": np, "glmls": glmls})
    tests = [test for test in found if test.examples]
    assert tests, "no doctest examples"
    runner = doctest.DocTestRunner(optionflags=_FLAGS)
    out = io.StringIO()
    for test in sorted(tests, key=lambda t: t.name):
        runner.run(test, out=out.write)
    results = runner.summarize(verbose=False)
    assert results.failed == 0, out.getvalue()


@pytest.mark.parametrize("member", _params(_INHERITED))
def test_inherited_member_examples_run(member):
    _run_examples(member, f"{member.__module__}.{member.__qualname__}")


@pytest.mark.parametrize("obj", _params(PUBLIC))
def test_examples_run(obj):
    _run_examples(obj, f"{obj.__module__}.{obj.__qualname__}")
