"""Sphinx configuration of glmls's documentation site.

Build it with ``bash scripts/docs.sh`` (or ``sphinx-build -W --keep-going -b html docs
build/docs``). The guides are Markdown (MyST), the API reference comes from the numpydoc
docstrings through autosummary, and the gallery is made by sphinx-gallery running the scripts
in ``demos/`` (their pictures are picked up by ``gallery_images.py``). Everything builds
offline: no intersphinx, no remote fonts, images or analytics.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS))  # gallery_images
sys.path.insert(0, str(ROOT))  # glmls from the source tree when it is not installed

import glmls  # noqa: E402

# torchvision loads triton, whose LLVM crashes a process in which llvmpipe's LLVM is already
# loaded (glmls.augment.torchvision.check_import_order). The gallery makes GL contexts, and
# the API pages import the adapters (albumentations imports torch; reading its members can
# load triton), in an order that depends on what an incremental build rereads: load it first.
try:
    import glmls.augment.torchvision
except ImportError:  # the torch extra is not installed: nothing loads triton
    pass

project = "glmls"
author = "the glmls authors"
copyright = "the glmls authors"
version = release = glmls.__version__

extensions = [
    "myst_parser",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx_copybutton",
    "sphinx_design",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "images/*.md", "**/README.md"]
templates_path = ["_templates"]

# --- Markdown guides -----------------------------------------------------------------------
myst_enable_extensions = ["dollarmath", "deflist", "colon_fence"]
myst_heading_anchors = 3  # `[text](#a-heading)` links inside and between guides

# --- API reference -------------------------------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
# no "inherited-members" here: a default that is not text overrides the directive's own
# option, and the class_inherited template (glmls.app's pages) shows what a class inherits
autodoc_default_options = {"members": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
numpydoc_show_class_members = False  # the class template lists the members itself
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# every cross-reference must resolve: a role naming something the site does not document is
# an error (write it as a literal). The adapters' bases live in their libraries' own sites,
# which this offline build does not link.
nitpicky = True
nitpick_ignore = [
    ("py:class", "albumentations.core.transforms_interface.DualTransform"),
    ("py:class", "torchvision.transforms.v2._transform.Transform"),
]

_LITERAL = re.compile(r"(``.*?``|:\w+:`[^`]*`|`[^`]*`_?)")


def _escape_bars(app, what, name, obj, options, lines) -> None:
    """Docstrings write absolute values and norms as plain text, ``|x - mean|``; reST reads a
    ``|word|`` as a substitution. Bars outside literals, roles and tables are escaped."""
    for i, line in enumerate(lines):
        if "|" not in line or line.lstrip().startswith(("| ", "+-", "+=")):
            continue
        parts = _LITERAL.split(line)
        parts[::2] = [part.replace("|", "\\|") for part in parts[::2]]
        lines[i] = "".join(parts)


def _public_classes() -> set[type]:
    """The classes that the API reference documents: those in the public modules' __all__."""
    import glmls.files
    import glmls.volume

    modules = (glmls, glmls.analysis, glmls.augment, glmls.data, glmls.files, glmls.gl)
    modules += (glmls.mls3, glmls.reference, glmls.volume)
    found = set()
    for module in modules:
        for name in module.__all__:
            value = getattr(module, name)
            if isinstance(value, type):
                found.add(value)
    return found


def _public_bases(app, name, obj, options, bases) -> None:
    """A class's "Bases:" line names what a reader can look up: a base that is glmls's own
    but not documented (a private ``_TextPreset``, the MLS's ``ForkSafe``) is replaced by its
    own bases, up to documented classes or ``object``."""
    public = _public_classes()

    def shown(base: object) -> list[object]:
        if not isinstance(base, type) or not base.__module__.startswith("glmls"):
            return [base]
        if base in public:
            return [base]
        return [b for parent in base.__bases__ for b in shown(parent)]

    kept = list(dict.fromkeys(b for base in bases for b in shown(base)))
    if len(kept) > 1 and object in kept:
        kept.remove(object)
    bases[:] = kept


def setup(app) -> None:
    app.connect("autodoc-process-docstring", _escape_bars, priority=400)
    app.connect("autodoc-process-bases", _public_bases)


# --- Gallery -------------------------------------------------------------------------------
sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "demos"),
    "gallery_dirs": "gallery",
    "filename_pattern": r".*\.py$",  # run every demo ...
    "ignore_pattern": r"window_benchmark\.py$",  # ... but the one that needs a window
    "image_scrapers": ("gallery_images",),
    "reset_argv": "gallery_images.demo_arguments",
    "reset_modules": (),
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "show_memory": False,
    # the timing pages load jQuery and DataTables from CDNs: the site would not be offline
    "write_computation_times": False,
    "plot_gallery": "True",
    "abort_on_example_error": False,
}

# --- HTML ----------------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"glmls {release}"
html_static_path = ["_static"]
html_css_files = ["glmls.css"]
html_logo = None
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "navbar_align": "left",
    "header_links_before_dropdown": 6,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
    "icon_links": [],
}
html_sidebars = {"index": [], "getting-started": []}
html_show_sourcelink = False
html_copy_source = False
copybutton_prompt_text = r">>> |\.\.\. |\$ "
copybutton_prompt_is_regexp = True
