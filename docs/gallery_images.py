"""sphinx-gallery hooks for the scripts in ``demos/``.

The demos are plain command-line scripts that write their pictures with Pillow (PNG or JPEG)
into ``demos/out/`` (or ``out/`` under the folder they run in). sphinx-gallery runs each one
in ``demos/``; :func:`demo_arguments` is called just before a demo starts and remembers which
pictures are already there, and the scraper that :func:`_get_sg_image_scraper` returns shows
every picture written or rewritten since, one under the other, in the order they were written.
"""

from __future__ import annotations

import ast
import shutil
from pathlib import Path

from sphinx_gallery.scrapers import figure_rst

#: the picture types the demos write
SUFFIXES = (".png", ".jpg", ".jpeg")

#: command-line arguments per demo in the gallery (the rest run with their defaults): the
#: handle-scaling timings at a gallery-sized image and handle counts
ARGUMENTS = {
    "handle_scaling.py": [
        "--size", "256", "--max-seconds", "0.5", "--no-capacities",
        "--counts", "4,16,64,256,1024,4096,16384",
    ],
}  # fmt: skip

#: the pictures shown for demos that write more than they are about (the report's single
#: pictures are parts of the two figures)
PICTURES = {"paper_figures_6_7.py": ("fig6.png", "fig7.png")}

_before: dict[Path, int] = {}  # picture -> mtime_ns when the current demo started
_shown: dict[Path, int] = {}  # picture -> mtime_ns when it was last shown


def _watched(src_file: Path) -> list[Path]:
    folders = {src_file.parent / "out", Path.cwd() / "out"}
    return [
        path
        for folder in folders
        if folder.is_dir()
        for path in folder.rglob("*")
        if path.suffix.lower() in SUFFIXES and path.is_file()
    ]


def _snapshot(src_file: Path) -> dict[Path, int]:
    return {path.resolve(): path.stat().st_mtime_ns for path in _watched(src_file)}


def demo_arguments(gallery_conf, script_vars) -> list[str]:
    """sphinx-gallery's ``reset_argv``: the demo's arguments, and the state before it runs.

    The demos find their output folder from ``__file__`` and their ``--help`` text in
    ``__doc__``; sphinx-gallery leaves the first unset and the second empty, so both are set
    here as ``python demos/NAME.py`` sets them.
    """
    src_file = Path(script_vars["src_file"]).resolve()
    names = script_vars["example_globals"]
    names["__file__"] = str(src_file)
    names["__doc__"] = ast.get_docstring(ast.parse(src_file.read_text(encoding="utf-8")))
    _before.clear()
    _before.update(_snapshot(src_file))
    _shown.clear()
    return list(ARGUMENTS.get(src_file.name, []))


def scrape(block, block_vars, gallery_conf) -> str:
    """The pictures the demo wrote since it started (or since the last block), as rST."""
    src_file = Path(block_vars["src_file"]).resolve()
    now = _snapshot(src_file)
    new = [
        path
        for path, mtime in now.items()
        if _before.get(path) != mtime and _shown.get(path) != mtime
    ]
    shown = PICTURES.get(src_file.name)
    if shown is not None:
        new = [path for path in new if path.name in shown]
    new.sort(key=lambda path: (now[path], path.name))
    images = []
    for path, target in zip(new, block_vars["image_path_iterator"], strict=False):
        target = Path(target).with_suffix(path.suffix.lower())
        shutil.copyfile(path, target)
        _shown[path] = now[path]
        images.append(target)
    return "".join(figure_rst([image], gallery_conf["src_dir"]) for image in images)


def _get_sg_image_scraper():
    """sphinx-gallery's entry point for a scraper named by its module."""
    return scrape
