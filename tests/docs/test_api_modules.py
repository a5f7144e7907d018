"""The API reference's package pages (``.. automodule::`` in docs/api/*.rst) name in their
docstrings only modules that the reference documents, so that each such name is a link: a
package of its own page, or a module of which an autosummary entry documents a name
(``albumentations.MLSDeform`` under ``glmls.augment``)."""

from __future__ import annotations

import importlib
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
