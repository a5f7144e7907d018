"""Running programs: their uniforms, and compute dispatches over many items.

GL caps each dispatch's work-group count (``GL_MAX_COMPUTE_WORK_GROUP_COUNT``, at least
65,535 per axis); larger runs are split into several dispatches, each told where it starts.
The work-group sizes are defines of every program (``LOCAL_SIZE``, ``LOCAL_SIZE_2D``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import moderngl

from . import bindings

__all__ = [
    "LOCAL_SIZE",
    "LOCAL_SIZE_2D",
    "RESCUE_CAPACITY",
    "ScanPieces",
    "SecondPass",
    "fill_buffer",
    "run_1d",
    "run_2d",
    "run_groups",
    "set_uniforms",
]

#: local_size_x of the one-dimensional compute shaders.
LOCAL_SIZE = 64
#: local_size_x and _y of the two-dimensional ones.
LOCAL_SIZE_2D = 8


def set_uniforms(
    program: moderngl.Program | moderngl.ComputeShader, values: Mapping[str, object]
) -> None:
    """Set those of ``values`` that ``program`` uses (compilers drop unused uniforms).

    A value equal to the one last set here is not written again: a warp sets about a hundred
    uniforms, most of them the same every call, and each write is a GL call (~0.6 us on
    llvmpipe, ~2 us through NVIDIA's driver, besides Python's packing). So that what is
    remembered is what the program holds, every uniform write of glmls goes through here
    (``tests/test_architecture.py`` checks it). The names the program does not use are
    remembered too: a call whose values are all as last set does no lookup of members."""
    state = program.__dict__.get(_WRITTEN)
    if state is None:
        state = program.__dict__[_WRITTEN] = ({}, set())
    written, unused = state
    for name, value in values.items():
        key = _plain(value)
        if key is not None and written.get(name, _NOTHING) == key:
            continue
        if name in unused:
            continue
        member = program.get(name, None)  # `name in program` would walk every member
        if member is None:
            unused.add(name)
            continue
        member.value = value
        if key is None:
            written.pop(name, None)
        else:
            written[name] = key


#: The attribute of a program that holds the values :func:`set_uniforms` last wrote, and
#: the names it does not use.
_WRITTEN = "glmls_uniforms"
_SCALARS = (bool, int, float)
_EXACT = frozenset(_SCALARS)
_NOTHING = object()


def _plain(value: object) -> object:
    """``value`` as a comparable Python scalar or tuple of scalars; None for anything else
    (written every time)."""
    # exact Python scalars and pairs of them first (most values: a warp sets ~60 pairs):
    # type tests are cheaper than isinstance
    kind = type(value)
    if kind in _EXACT or (
        kind is tuple
        and len(value) == 2  # type: ignore[arg-type]
        and type(value[0]) in _EXACT  # type: ignore[index]
        and type(value[1]) in _EXACT  # type: ignore[index]
    ):
        return value
    if isinstance(value, _SCALARS):
        return value
    if isinstance(value, (tuple, list)) and all(isinstance(v, _SCALARS) for v in value):
        return tuple(value)
    return None


def run_1d(
    program: moderngl.ComputeShader, count: int, *, max_groups: int, per_invocation: int = 1
) -> None:
    """Run ``program`` on items 0 .. ``count`` - 1, ``per_invocation`` consecutive items per
    invocation, in groups of :data:`LOCAL_SIZE` invocations, at most ``max_groups`` groups per
    dispatch. The shader reads ``u_offset`` (the first item of the dispatch) and ``u_count``
    when it declares them."""
    set_uniforms(program, {"u_count": count})
    items = LOCAL_SIZE * per_invocation
    groups = math.ceil(count / items)
    for first in range(0, groups, max_groups):
        set_uniforms(program, {"u_offset": first * items})
        program.run(group_x=min(max_groups, groups - first))


def run_groups(program: moderngl.ComputeShader, count: int, *, max_groups: int) -> None:
    """Run ``program`` with one work group per item 0 .. ``count`` - 1 (the shader's item is
    ``u_offset`` + its group's number; ``u_count`` tells it the items), at most
    ``max_groups`` groups per dispatch."""
    set_uniforms(program, {"u_count": count})
    for first in range(0, count, max_groups):
        set_uniforms(program, {"u_offset": first})
        program.run(group_x=min(max_groups, count - first))


def fill_buffer(
    gl, buffer: moderngl.Buffer, nbytes: int, *, word: int = 0, offset: int = 0
) -> None:
    """Set ``nbytes`` bytes of ``buffer`` from byte ``offset`` (both multiples of 4) to the
    32-bit ``word``, on the GPU (``common/fill.comp.glsl`` through ``gl``, a
    :class:`~glmls.gl.context.GLContext`). moderngl's ``Buffer.clear`` maps the buffer and
    fills it on the host: through a discrete GPU's bus, and after the buffer's last use (a
    64 MiB clear took 0.24 s on an H200 machine). The buffer is left unbound."""
    if nbytes % 4 or offset % 4:
        raise ValueError(f"fill_buffer fills whole words: got {nbytes} bytes at offset {offset}")
    if nbytes <= 0:
        return
    vec4 = nbytes % 16 == 0 and offset % 16 == 0
    unit = 16 if vec4 else 4
    program = gl.compute("common/fill.comp.glsl", {"FILL_VEC4": vec4})
    buffer.bind_to_storage_buffer(bindings.FILL.index)
    set_uniforms(program, {"u_first": offset // unit, "u_word": word})
    gl.mgl.memory_barrier()
    run_1d(program, nbytes // unit, max_groups=gl.limits["max_work_groups_x"], per_invocation=4)
    gl.mgl.memory_barrier()


def run_2d(program: moderngl.ComputeShader, dims: tuple[int, int], *, max_groups: int) -> None:
    """Run ``program`` on a ``dims`` = (columns, rows) lattice in 8 x 8 groups, one dispatch
    (``u_dims`` tells the shader the lattice); ``ValueError`` past ``max_groups`` per axis."""
    groups = (math.ceil(dims[0] / LOCAL_SIZE_2D), math.ceil(dims[1] / LOCAL_SIZE_2D))
    if max(groups) > max_groups:
        raise ValueError(f"lattice of {dims[0]} x {dims[1]} points is too large for one dispatch")
    set_uniforms(program, {"u_dims": dims})
    program.run(group_x=groups[0], group_y=groups[1])


class ScanPieces:
    """The second dispatch of a scan conversion on a driver that caps an invocation's loop
    iterations (``common/pieces.glsl``): the pieces of the primitives too large for one
    invocation, in an indirect dispatch that the first sized (no work group where there are
    none; nothing is read back). Where ``gl.piece_pixels`` is 0 (no loop limit: GPU
    drivers) it does nothing.

    Around the dispatches over the primitives of ``program``: :meth:`start` before them,
    :meth:`finish` after them, with the ``u_offset`` of each if there were several.
    """

    def __init__(self, gl) -> None:
        self._gl = gl
        self.active = gl.piece_pixels > 0

    def start(self, program: moderngl.ComputeShader) -> None:
        """Clear the pieces' dispatch size and bind it; ``program`` walks piece 0 of each
        primitive."""
        if not self.active:
            return
        buffer = self._gl.shared(_PIECES, lambda: self._gl.mgl.buffer(reserve=16))
        buffer.write(_NO_PIECES)
        buffer.bind_to_storage_buffer(bindings.PIECES.index)
        set_uniforms(program, {"u_piece_first": 0})

    def finish(self, program: moderngl.ComputeShader, offsets: tuple[int, ...] = ()) -> None:
        """Dispatch the other pieces of ``program``'s primitives: once, or once per
        ``u_offset`` in ``offsets`` (those of the dispatches over the primitives)."""
        if not self.active:
            return
        gl = self._gl
        buffer = gl.shared(_PIECES, lambda: gl.mgl.buffer(reserve=16))
        buffer.bind_to_storage_buffer(bindings.PIECES.index)
        gl.mgl.memory_barrier()  # the sizes, before the indirect dispatch reads them
        set_uniforms(program, {"u_piece_first": 1})
        for offset in offsets or (None,):
            if offset is not None:
                set_uniforms(program, {"u_offset": offset})
            program.run_indirect(buffer)
        set_uniforms(program, {"u_piece_first": 0})

    def run_1d(self, program: moderngl.ComputeShader, count: int, *, max_groups: int) -> None:
        """:func:`run_1d` over ``count`` primitives, one per invocation, with their pieces."""
        self.start(program)
        run_1d(program, count, max_groups=max_groups)
        items = LOCAL_SIZE
        offsets = tuple(first * items for first in range(0, math.ceil(count / items), max_groups))
        self.finish(program, offsets)


#: The shared object of :class:`ScanPieces` (its indirect dispatch's sizes), and their value
#: before a scan: no work group.
_PIECES = "scan pieces"
_NO_PIECES = bytes(16)


#: The most items a :class:`SecondPass` lists (8 bytes each: 8 MiB); past it they are
#: counted, not listed, and keep the first pass's result.
RESCUE_CAPACITY = 1 << 20
_RESCUE = "second pass"
#: Its list's header before a first pass: an indirect dispatch of (0, 1, 1) work groups, and
#: no item.
_NO_RESCUE = bytes(4) + (1).to_bytes(4, "little") * 2 + bytes(4)
#: The shared object of :meth:`SecondPass.finish_runs` (the later runs' indirect dispatches,
#: one per run), and the bytes of one dispatch's (x, y, z).
_RESCUE_RUNS = "second pass runs"
_DISPATCH_BYTES = 12


class SecondPass:
    """A second pass over the few items a first left undone (``warp/inverse.comp.glsl``:
    the pixels whose Newton ended above the residual accepted, or, with the constant border,
    at a point just outside the image, where a fold may give another preimage inside), in an
    indirect dispatch the first sized: the first appends each such item to a list
    (``common/second_pass.glsl``, ``BIND_RESCUE``: the dispatch's (x, y, z) work groups, the
    count, then the items, ``RESCUE_CAPACITY`` at most) and raises x by one work group per
    ``LOCAL_SIZE`` items;
    the second runs one invocation per item, none where there is none, and nothing is read
    back. A branch in the first pass would cost every item on a CPU renderer, which runs a
    branch's code under its lanes' mask whatever the mask.

    :meth:`start` before the first pass's dispatches, :meth:`finish` with the second's
    program after them (with its own uniforms set).

    ``buffer``: the list's own buffer, for a first pass that lists more than
    ``RESCUE_CAPACITY`` items or larger ones (``volume/newton.comp.glsl``: every voxel of a
    slab may need the second pass), ``capacity`` items; by default one of this context's,
    shared. The programs get ``u_rescue_capacity`` and ``u_max_groups`` (the most work groups
    of a dispatch: a second pass past it walks its items with that stride)."""

    def __init__(
        self, gl, buffer: moderngl.Buffer | None = None, capacity: int = RESCUE_CAPACITY
    ) -> None:
        self._gl = gl
        self._own = buffer
        self._uniforms = {
            "u_rescue_capacity": capacity,
            "u_max_groups": gl.limits["max_work_groups_x"],
        }

    def _buffer(self) -> moderngl.Buffer:
        if self._own is not None:
            return self._own
        gl = self._gl
        return gl.shared(_RESCUE, lambda: gl.mgl.buffer(reserve=16 + 8 * RESCUE_CAPACITY))

    def start(self, program: moderngl.ComputeShader) -> None:
        """Clear the list and bind it for ``program``, the first pass."""
        buffer = self._buffer()
        buffer.write(_NO_RESCUE)
        buffer.bind_to_storage_buffer(bindings.RESCUE.index)
        set_uniforms(program, self._uniforms)

    def finish(self, program: moderngl.ComputeShader) -> None:
        """Run ``program``, the second pass, over the listed items."""
        buffer = self._buffer()
        buffer.bind_to_storage_buffer(bindings.RESCUE.index)
        self._gl.mgl.memory_barrier()  # the list and its size, before the dispatch reads them
        set_uniforms(program, self._uniforms)
        program.run_indirect(buffer)

    def finish_runs(self, program: moderngl.ComputeShader, runs: int) -> None:
        """Run ``program``, the second pass, ``runs`` times over the listed items, its
        ``u_run`` 1, 2, ...: run r + 1 over the whole list where run r marked an item done
        (``second_pass_done``, with ``SECOND_PASS_RUNS``), else over none (an indirect
        dispatch of no work group, ``BIND_RESCUE_RUNS``): later runs cost nothing once a run
        changes nothing."""
        gl = self._gl
        dispatches = gl.shared(
            (_RESCUE_RUNS, runs), lambda: gl.mgl.buffer(reserve=_DISPATCH_BYTES * runs)
        )
        dispatches.write(_NO_RESCUE[:_DISPATCH_BYTES] * runs)
        dispatches.bind_to_storage_buffer(bindings.RESCUE_RUNS.index)
        for run in range(1, runs + 1):
            set_uniforms(program, {"u_run": run})
            if run == 1:
                self.finish(program)
                continue
            self._buffer().bind_to_storage_buffer(bindings.RESCUE.index)
            gl.mgl.memory_barrier()  # the run before's results and its raise of this dispatch
            program.run_indirect(dispatches, offset=_DISPATCH_BYTES * (run - 2))
