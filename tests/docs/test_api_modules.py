"""The API reference's package pages (``.. automodule::`` in docs/api/*.rst) name in their
docstrings only modules that the reference documents, so that each such name is a link: a
package of its own page, or a module of which an autosummary entry documents a name
(``albumentations.MLSDeform`` under ``glmls.augment``); and every name in the ``__all__`` of
such a package is on a page."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import re
from pathlib import Path

API = Path(__file__).resolve().parents[2] / "docs" / "api"
AUTOMODULE = re.compile(r"^\.\. automodule:: ([\w.]+)", re.M)
ENTRY = re.compile(r"^   ([A-Za-z_][\w.]*)$", re.M)
MOD_ROLE = re.compile(r":mod:`(?:[^`<]*<)?~?([\w.]+)>?`")


def documented_modules() -> tuple[list[str], set[str]]:
    pages, modules = [], set()
    for page in sorted(API.glob("*.rst")):
        text = page.read_text()
        for package in AUTOMODULE.findall(text):
            pages.append(package)
            modules.add(package)
            for entry in ENTRY.findall(text):
                parts = entry.split(".")
                for n in range(1, len(parts)):
                    modules.add(".".join([package, *parts[:n]]))
    return pages, modules


def test_the_package_pages_name_documented_modules():
    pages, modules = documented_modules()
    assert "glmls.augment" in pages and "glmls.augment.albumentations" in modules
    undocumented = []
    for package in pages:
        doc = importlib.import_module(package).__doc__ or ""
        for name in MOD_ROLE.findall(doc):
            target = package + name if name.startswith(".") else name
            if target not in modules:
                undocumented.append(f"{package}: {name}")
    assert not undocumented, undocumented


DATA = re.compile(r"^\.\. data:: (\w+)$", re.M)


def documented_objects() -> tuple[set[str], list[object]]:
    """The qualified names that the API pages document (autosummary entries and ``.. data::``
    constants, each under its page's package), and the objects they name."""
    names = set()
    for page in sorted(API.glob("*.rst")):
        text = page.read_text()
        for package in AUTOMODULE.findall(text):
            names.update(f"{package}.{entry}" for entry in ENTRY.findall(text))
            names.update(f"{package}.{constant}" for constant in DATA.findall(text))
    objects = []
    for name in sorted(names):
        parts = name.split(".")
        if parts[:3] in (
            ["glmls", "augment", "albumentations"],
            ["glmls", "augment", "torchvision"],
        ):
            continue  # adapters, imported only on their own (torchvision before GL: README)
        for split in range(len(parts) - 1, 0, -1):  # the longest module: glmls.mls3 of MLS3
            if importlib.util.find_spec(".".join(parts[:split])) is None:
                continue
            target = importlib.import_module(".".join(parts[:split]))
            for part in parts[split:]:
                target = getattr(target, part)
            objects.append(target)
            break
    return names, objects


def test_every_public_name_is_in_the_reference():
    """Every name in the ``__all__`` of a package that has a page is on a page: under its own
    name, or the same object under another (``glmls.files.imread`` is ``glmls.imread``)."""
    pages, _ = documented_modules()
    names, objects = documented_objects()
    assert "glmls.files.read_handle_set" in names and "glmls.volume.VOLUME_METHODS" in names
    assert "glmls.app" in pages and "glmls.app.VolumeApp" in names
    missing = []
    for package in pages:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.ismodule(obj) or f"{package}.{name}" in names:
                continue
            if not any(obj is other for other in objects):
                missing.append(f"{package}.{name}")
    assert not missing, missing
