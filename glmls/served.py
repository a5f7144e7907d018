"""The helper process's side of an MLS in a process forked from one that used GL
(:mod:`glmls.forking`): the MLS objects it makes from the handles and settings that the forked
process sends (:func:`serve_forked`), kept for the next calls, and the MLS that an unpickled
or copied one is made as (:func:`made_from`).
"""

from __future__ import annotations

import collections
import pickle

import moderngl

from .gl.context import GLContext
from .mls import MLS

__all__ = ["made_from", "serve_forked"]

#: The helper process's MLS objects, by the pickled state they were made from (newest last).
_SERVED: collections.OrderedDict[bytes, MLS] = collections.OrderedDict()
_SERVED_KEPT = 4


def made_from(state: tuple, ctx: moderngl.Context | GLContext | None = None) -> MLS:
    """A new MLS on ``ctx`` from the handles and settings of ``state``
    (:meth:`MLS._forked_state`): the helper's, an unpickled or a copied one."""
    src, dst, src_segments, dst_segments, config, shape, spacing, storage, bins = state
    return MLS.from_config(
        src,
        dst,
        config,
        src_segments=src_segments,
        dst_segments=dst_segments,
        shape=shape,
        spacing=spacing,
        ctx=ctx,
        storage=storage,
        bins=bins,
    )


def serve_forked(state: tuple, name: str | None, grid: int | None, args: tuple, kwargs: dict):
    """In the helper process of a forked process: ``name`` of the MLS made from ``state``
    (:meth:`MLS._forked_state`; kept for the next calls), or of its inverse of ``grid``;
    nothing but the making when ``name`` is None."""
    key = pickle.dumps(state, pickle.HIGHEST_PROTOCOL)
    m = _SERVED.pop(key, None)
    if m is None:
        m = made_from(state)
    _SERVED[key] = m
    while len(_SERVED) > _SERVED_KEPT:
        _SERVED.popitem(last=False)[1].release()
    if name is None:
        return None
    target = m if grid is None else type(m.inverse)(m, grid=grid)
    return getattr(target, name)(*args, **kwargs)
