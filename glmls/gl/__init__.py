"""The OpenGL plumbing: contexts (:class:`GLContext`, :func:`get_context`,
:func:`create_headless`) and the warp pipeline that builds deformed images on one context
(:class:`WarpPipeline`, configured by :class:`PipelineOptions`).

Most users never touch this package: :class:`glmls.MLS` and :func:`glmls.warp` use the shared
headless context of the calling thread. It is for rendering into a context of your own (a
window's), for threads and processes, and for choosing between the pipeline's internal paths.

Beside these, the package holds plumbing that knows nothing of MLS (shader loading, binding
points, cached GL objects, compute dispatches; :doc:`/architecture`). :class:`WarpPipeline`
lives in the imaging layer above and is re-exported here lazily, so that importing this
package never imports the layers built on it.
"""

from __future__ import annotations

from .context import GLContext, create_headless, get_context

__all__ = [
    "GLContext",
    "PipelineOptions",
    "WarpPipeline",
    "create_headless",
    "get_context",
]


def __getattr__(name: str) -> object:
    # PEP 562: the pipeline is built on this package, so it is imported on first use only.
    if name == "WarpPipeline":
        from ..imaging.pipeline import WarpPipeline

        return WarpPipeline
    if name == "PipelineOptions":
        from ..imaging.options import PipelineOptions

        return PipelineOptions
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
