"""A tracer of GPU memory hazards: commands that touch what an earlier shader stored, with no
``glMemoryBarrier`` between them.

A shader's stores to storage buffers and images (atomics included) are not ordered with the
GL commands after it: a later dispatch or draw that reads them, an indirect dispatch taking
its sizes from them, a buffer or texture read-back, a copy, a framebuffer read or a draw onto
the texture all need a ``memory_barrier`` in between (the bit of how they read it). Nor are
they ordered with what earlier commands still read or render: a dispatch that stores where an
earlier one reads (a scratch buffer reused), or onto a texture a draw rendered, needs one
too. Mesa's llvmpipe runs every command to its end, in order, so a missing barrier shows
nowhere there; GPUs overlap consecutive dispatches and keep shader stores in caches.

:func:`tracing` patches moderngl's classes for its ``with`` block and follows, per moderngl
context, what each command binds: the storage buffers, uniform blocks, texture and image
units each program declares (its source, recorded when it is compiled inside the block,
tells the ``readonly`` and ``writeonly`` ones: a program compiled before counts each storage
block as read and written), the indirect buffer, the vertex and index buffers, the bound
framebuffer's attachments. Each :class:`Hazard` names both commands and where glmls issued
them.

What a command stores is what it changed: each resource it may store to (its program's
source says which bytes) is read back before and after it (llvmpipe runs it to its end
meanwhile), so an indirect dispatch of no work group, or a branch not taken, stores
nothing. What a command reads is what its program may read (the members its code names):
static. Atomics against atomics are no hazard (they are performed in order). The dispatches
of one ``run_1d`` or ``run_groups`` call (``glmls.gl.dispatch``: one dispatch split at the
work-group cap, each part its own items) are one command.
"""

from __future__ import annotations

import contextlib
import os
import re
import sys
import traceback
from collections.abc import Iterator
from dataclasses import dataclass, field

import moderngl
import numpy as np
from glsl_usage import END, Access, preprocess, units, usage

from glmls.gl import bindings
from glmls.gl.shaders import ShaderLibrary

__all__ = ["BITS", "Hazard", "Tracer", "tracing"]

_WHOLE = ((0, END),)
#: moderngl's own read-backs, for the contents before and after a command.
_ORIGINAL_WRITE = moderngl.Buffer.write
_ORIGINAL_READS = {
    kind: kind.read
    for kind in (moderngl.Buffer, moderngl.Texture, moderngl.Texture3D, moderngl.TextureArray)
}

#: glMemoryBarrier's bits, by the way of reading (or writing) that each one orders.
BITS = {
    "vertex": 0x1,
    "element": 0x2,
    "uniform": 0x4,
    "texture_fetch": 0x8,
    "image": 0x20,
    "command": 0x40,
    "pixel_buffer": 0x80,
    "texture_update": 0x100,
    "buffer_update": 0x200,
    "framebuffer": 0x400,
    "storage": 0x2000,
}
ALL_BITS = 0xFFFFFFFF

_PACKAGE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "glmls")
_TEXTURES = (moderngl.Texture, moderngl.Texture3D, moderngl.TextureArray, moderngl.TextureCube)
_IMAGE_UNITS = 8  # GL 4.3's least GL_MAX_IMAGE_UNITS
_IMAGE_TYPES = range(0x904C, 0x906D)  # GL_IMAGE_1D .. GL_UNSIGNED_INT_IMAGE_2D_MULTISAMPLE_ARRAY
_SAMPLER_TYPES = (
    set(range(0x8B5D, 0x8B65))  # GL_SAMPLER_1D .. GL_SAMPLER_2D_RECT_SHADOW
    | set(range(0x8DC0, 0x8DC6))  # array, buffer and shadow samplers
    | set(range(0x8DC9, 0x8DD9))  # integer and unsigned samplers
    | set(range(0x9108, 0x910E))  # multisample samplers
)


#: kind -> index -> the glmls binding's name
_ROLES: dict[str, dict[int, str]] = {kind: {} for kind in bindings.KINDS}
for _binding in bindings.ALL:
    _ROLES[_binding.kind][_binding.index] = _binding.name


@dataclass(frozen=True)
class Hazard:
    """``later`` touches ``resource`` (``how``: the barrier bit it needs) after ``earlier``
    stored to it, or stores to it after ``earlier`` read or rendered it, no barrier between."""

    kind: str  # "read after store", "write after store", "store after access"
    resource: str
    how: str
    earlier: str
    later: str

    def __str__(self) -> str:
        return (
            f"{self.kind}: {self.resource} ({self.how})\n"
            f"  earlier {self.earlier}\n  later   {self.later}"
        )


def _key(obj: object) -> tuple[str, int]:
    kind = "buffer" if isinstance(obj, moderngl.Buffer) else type(obj).__name__.lower()
    return (kind, obj.glo)


#: The functions of glmls that split one dispatch into several at the work-group cap.
_SPLITTERS = {("dispatch.py", "run_1d"), ("dispatch.py", "run_groups")}


def _splitter():
    """The frame of the glmls function that splits one dispatch, where it issued this one
    (kept, so that no later call's frame takes its id): its parts are one command."""
    frame = sys._getframe(3)  # _splitter, Tracer.shader, the patched run, its caller
    code = frame.f_code
    if (os.path.basename(code.co_filename), code.co_name) in _SPLITTERS:
        return frame
    return None


def _where(helpers: bool = False) -> str:
    """Where glmls issued the command: its innermost frame past the dispatch helpers
    (``glmls/gl/dispatch.py``; in them too with ``helpers``), file:line (function)."""
    for frame in reversed(traceback.extract_stack()[:-2]):
        if frame.filename.startswith(_PACKAGE) and (
            helpers or not frame.filename.endswith("dispatch.py")
        ):
            path = os.path.relpath(frame.filename, os.path.dirname(_PACKAGE))
            return f"{path}:{frame.lineno} ({frame.name})"
    return "outside glmls"


# -- programs ----------------------------------------------------------------------------------


@dataclass
class _Program:
    """What a program's commands touch: storage block binding, uniform block binding, image
    unit -> :class:`Access`; the sampler units."""

    label: str
    storage: dict[int, Access] = field(default_factory=dict)
    uniform: set[int] = field(default_factory=set)
    samplers: set[int] = field(default_factory=set)
    images: dict[int, Access] = field(default_factory=dict)

    @classmethod
    def of(cls, program: moderngl.Program | moderngl.ComputeShader) -> _Program:
        cached = program.__dict__.get("_barrier_trace")
        if cached is not None:
            return cached
        source = program.__dict__.get("_barrier_trace_source")
        # a program compiled before the tracer: every resource read and stored, whole
        everything = Access(_WHOLE, _WHOLE)
        found = usage(source) if source is not None else {}
        bound = units(source) if source is not None else {}
        words = None if source is None else set(re.findall(r"\w+", preprocess(source)[0]))
        info = cls(program.__dict__.get("_barrier_trace_entry") or f"program {program.glo}")
        for name, member in program._members.items():
            if isinstance(member, moderngl.StorageBlock):
                access = found.get(name, everything)
                if access.reads or access.stores:
                    info.storage[member.binding] = access
            elif isinstance(member, moderngl.UniformBlock):
                if found.get(name, everything).reads:
                    info.uniform.add(member.binding)
            elif isinstance(member, moderngl.Uniform) and member.gl_type in _IMAGE_TYPES:
                access = found.get(name.split("[")[0], everything)
                unit = bound.get(name.split("[")[0])
                if unit is None:  # no source, or no binding in it: every unit
                    for unit in range(_IMAGE_UNITS):
                        info.images[unit] = access
                elif access.reads or access.stores:
                    info.images[unit] = access
            elif isinstance(member, moderngl.Uniform) and member.gl_type in _SAMPLER_TYPES:
                if words is None or name.split("[")[0] in words:
                    info.samplers.add(bound.get(name.split("[")[0], member.value))
        program.__dict__["_barrier_trace"] = info
        return info


# -- the state of one context ----------------------------------------------------------------


def _shifted(access: Access, offset: int) -> Access:
    """``access`` of a block bound from byte ``offset`` of its buffer."""

    def shift(ranges):
        return tuple((start + offset, end + offset) for start, end in ranges)

    return Access(shift(access.reads), shift(access.stores), shift(access.atomic))


def _same(identity, other) -> bool:
    """Are two commands parts of one dispatch (:func:`_splitter`)?"""
    return identity[0] == other[0] and identity[1] == other[1] and identity[2] is other[2]


def _hits(changed: np.ndarray | None, ranges, atomic=(), other_atomic=()) -> bool:
    """Do the bytes ``changed`` meet ``ranges``, leaving out those both ``atomic`` and
    ``other_atomic`` (atomics are performed in order, barrier or not)?"""
    if changed is None:
        return False
    if atomic and other_atomic:
        changed = changed & ~(_mask(len(changed), atomic) & _mask(len(changed), other_atomic))
    return any(changed[start : min(end, len(changed))].any() for start, end in ranges)


def _mask(size: int, ranges) -> np.ndarray:
    mask = np.zeros(size, bool)
    for start, end in ranges:
        mask[start : min(end, size)] = True
    return mask


@dataclass
class _Entry:
    """A shader command's use of one resource since the last barrier: the bytes it read
    (static) and those it changed (seen), each split into atomic-only and not."""

    command: str
    identity: object
    reads: np.ndarray
    changed: np.ndarray
    atomic: np.ndarray
    bits: int = 0  # the barrier bits issued since


@dataclass
class _State:
    storage: dict[int, tuple[str, int]] = field(default_factory=dict)
    uniform: dict[int, tuple[str, int]] = field(default_factory=dict)
    textures: dict[int, tuple[str, int]] = field(default_factory=dict)
    images: dict[int, tuple[tuple[str, int], bool, bool]] = field(default_factory=dict)
    entries: dict[tuple[str, int], list[_Entry]] = field(default_factory=dict)
    names: dict[tuple[str, int], str] = field(default_factory=dict)
    objects: dict[tuple[str, int], object] = field(default_factory=dict)


class Tracer:
    """The hazards met while installed (:func:`tracing`), in order."""

    def __init__(self, ignore: tuple[str, ...] = ()) -> None:
        #: barriers left out of the model: those issued at these "glmls/path.py:line"
        self.ignore = set(ignore)
        self.hazards: list[Hazard] = []
        self.commands = 0
        self._states: dict[int, _State] = {}
        self._saved: list[tuple[type, str, object]] = []
        self._entries: dict[str, str] = {}

    def _state(self, ctx: moderngl.Context) -> _State:
        return self._states.setdefault(id(ctx), _State())

    def _name(self, state: _State, obj: object, role: str | None = None) -> tuple[str, int]:
        """The key of ``obj``, whose name (kept for the report) says where it was last bound:
        ``role``."""
        key = _key(obj)
        name = state.names.get(key)
        if name is None or role is not None:
            if isinstance(obj, moderngl.Buffer):
                name = f"buffer {obj.glo} ({obj.size} bytes)"
            else:
                name = f"{key[0]} {obj.glo} {tuple(obj.size)}"
            state.names[key] = name + (f" bound as {role}" if role else "")
        return key

    def _size(self, state: _State, key: tuple[str, int]) -> int:
        """A buffer's bytes; 1 for a texture (tracked whole)."""
        obj = state.objects[key]
        return obj.size if isinstance(obj, moderngl.Buffer) else 1

    def _contents(self, state: _State, key: tuple[str, int]) -> np.ndarray | None:
        """What the resource holds now, as bytes (None where it cannot be read)."""
        obj = state.objects[key]
        try:
            if isinstance(obj, moderngl.Buffer):
                data = _ORIGINAL_READS[moderngl.Buffer](obj)
            elif isinstance(obj, moderngl.Texture) and obj.samples:
                return None
            else:
                data = _ORIGINAL_READS[type(obj)](obj)
        except moderngl.Error:
            return None
        return np.frombuffer(data, np.uint8)

    def _poison(self, state: _State, key, ranges, read: bool):
        """Before a command that may store to ``ranges`` of a resource: (its contents,
        what they are made for the command). Where the command does not read the buffer,
        those ranges are changed first (each byte's bits flipped by 0xA5), so that stores of
        the values already there show too; a texture is taken as stored whole."""
        obj = state.objects[key]
        if not isinstance(obj, moderngl.Buffer):
            return None, None
        held = self._contents(state, key)
        if held is None or read:
            return held, held
        poisoned = held.copy()
        poisoned[_mask(len(held), ranges)] ^= 0xA5
        _ORIGINAL_WRITE(obj, poisoned.tobytes())
        return held, poisoned

    def _changes(self, state: _State, key, held, poisoned) -> np.ndarray | None:
        """The bytes of a resource the command stored to (whole words; a texture: one
        byte, True); a poisoned buffer gets its other bytes back."""
        obj = state.objects[key]
        if not isinstance(obj, moderngl.Buffer):
            return np.ones(1, bool)
        after = self._contents(state, key)
        if held is None or after is None:
            return np.ones(obj.size, bool)
        pad = -len(after) % 4
        differ = np.concatenate([after != poisoned, np.zeros(pad, bool)])
        changed = np.repeat(differ.reshape(-1, 4).any(axis=1), 4)[: len(after)]
        if poisoned is not held:
            _ORIGINAL_WRITE(obj, np.where(changed, after, held).tobytes())
        return changed if changed.any() else None

    # -- the model -----------------------------------------------------------------------------

    def _flag(self, kind, state, key, how, earlier, later) -> None:
        self.hazards.append(Hazard(kind, state.names.get(key, str(key)), how, earlier, later))

    def transfer(self, ctx, label, reads=(), writes=()) -> None:
        """A command that is no shader: ``reads`` and ``writes``, each (resource, byte
        ranges, the barrier bit that orders it after shader stores). (Shader stores after
        it need none: GL orders its own operations before the commands that follow.)"""
        state = self._state(ctx)
        self.commands += 1
        command = f"{label} at {_where()}"
        for kind, uses in (("read after store", reads), ("write after store", writes)):
            for key, ranges, how in uses:
                for entry in state.entries.get(key, ()):
                    if not entry.bits & BITS[how] and _hits(entry.changed, ranges):
                        self._flag(kind, state, key, how, entry.command, command)

    def shader(self, ctx, program, label, extra=(), framebuffer=(), empty=False):
        """A dispatch or draw of ``program`` about to run, with ``extra`` reads (resource,
        byte ranges, bit: the indirect command, vertices, indices) and, for a draw, the
        attachments of its ``framebuffer``; ``empty``: an indirect dispatch of no work group.
        Returns the function to call once it ran."""
        state = self._state(ctx)
        info = _Program.of(program)
        self.commands += 1
        command = f"{label} {info.label} at {_where()}"
        uses = []  # (resource, Access in the resource's bytes, bit)
        for binding, access in info.storage.items():
            bound = state.storage.get(binding)
            if bound is not None:
                key, offset = bound
                uses.append((key, _shifted(access, offset), "storage"))
        for binding in info.uniform:
            if binding in state.uniform:
                uses.append((state.uniform[binding], Access(_WHOLE), "uniform"))
        for unit in info.samplers:
            if unit in state.textures:
                uses.append((state.textures[unit], Access(_WHOLE), "texture_fetch"))
        for unit, access in info.images.items():
            if unit in state.images:
                key, read, write = state.images[unit]
                access = Access(
                    access.reads if read else (), access.stores if write else (), access.atomic
                )
                uses.append((key, access, "image"))
        uses += [(key, Access(ranges), how) for key, ranges, how in extra]
        if empty:  # no work group: it reads its size, nothing else
            uses = uses[-len(extra) :]
        # one dispatch split at the work-group cap: its parts are one command
        splitter = _splitter() if label == "dispatch" else None
        if splitter is None:
            identity = ("command", self.commands, None)
        else:
            identity = (id(program), tuple(sorted(key for key, _, _ in uses)), splitter)
        for key, access, how in uses:
            for entry in state.entries.get(key, ()):
                if _same(entry.identity, identity) or entry.bits & BITS[how]:
                    continue
                if _hits(entry.changed, access.reads, entry.atomic, access.atomic):
                    self._flag("read after store", state, key, how, entry.command, command)
        framebuffer = [k for k in framebuffer if k is not None]
        for key in framebuffer:  # drawn onto: after image stores, a framebuffer barrier
            for entry in state.entries.get(key, ()):
                if not entry.bits & BITS["framebuffer"] and _hits(entry.changed, _WHOLE):
                    self._flag(
                        "draw after store", state, key, "framebuffer", entry.command, command
                    )
        stored: dict[tuple[str, int], list] = {}
        read = {key for key, access, _ in uses if access.reads}
        for key, access, _ in uses:
            if access.stores:
                stored.setdefault(key, []).extend(access.stores)
        before = {
            key: self._poison(state, key, ranges, key in read) for key, ranges in stored.items()
        }

        def ran() -> None:
            changes = {key: self._changes(state, key, *held) for key, held in before.items()}
            for key, access, _ in uses:
                changed = changes.get(key) if access.stores else None
                if changed is not None:
                    for entry in state.entries.get(key, ()):
                        if _same(entry.identity, identity) or entry.bits:
                            continue
                        atomic = entry.atomic if access.atomic else ()
                        if _hits(changed, entry.reads, atomic, access.atomic) or (
                            entry.changed is not None
                            and _hits(changed & entry.changed, _WHOLE, atomic, access.atomic)
                        ):
                            self._flag(
                                "store after access", state, key, "any", entry.command, command
                            )
                entry = _Entry(command, identity, access.reads, changed, access.atomic)
                state.entries.setdefault(key, []).append(entry)
            for key in framebuffer:
                state.entries.setdefault(key, []).append(
                    _Entry(command, identity, _WHOLE, None, ())
                )

        return ran

    def barrier(self, ctx: moderngl.Context, bits: int) -> None:
        state = self._state(ctx)
        for key in list(state.entries):
            kept = []
            for entry in state.entries[key]:
                entry.bits |= bits
                if entry.changed is not None and entry.bits & ALL_BITS != ALL_BITS:
                    kept.append(entry)
            if kept:
                state.entries[key] = kept
            else:
                del state.entries[key]

    def forget(self, obj: object) -> None:
        """A resource released: its glo may name another one next."""
        state = self._state(obj.ctx)
        key = _key(obj)
        state.entries.pop(key, None)
        state.objects.pop(key, None)

    # -- patching moderngl ---------------------------------------------------------------------

    def _patch(self, owner: type, name: str, wrapper) -> None:
        original = getattr(owner, name)
        self._saved.append((owner, name, original))
        setattr(owner, name, wrapper(original))

    def _before(self, owner: type, name: str, note) -> None:
        """Call ``note(obj, *args, **kwargs)`` before each ``owner.name``."""

        def wrapper(original):
            def call(obj, *args, **kwargs):
                note(obj, *args, **kwargs)
                return original(obj, *args, **kwargs)

            return call

        self._patch(owner, name, wrapper)

    def install(self) -> None:
        """Patch moderngl's classes (and the shader loader, for the programs' entry files)."""
        tracer = self

        def key(obj, role=None):
            state = tracer._state(obj.ctx)
            found = tracer._name(state, obj, role)
            state.objects[found] = obj
            return found

        def compose(original):
            def compose_(library, entry, *args, **kwargs):
                composed = original(library, entry, *args, **kwargs)
                tracer._entries[composed.text] = entry
                return composed

            return compose_

        def compiled(original):
            def compile_(ctx, *args, **kwargs):
                program = original(ctx, *args, **kwargs)
                texts = [a for a in (*args, *kwargs.values()) if isinstance(a, str)]
                program.__dict__["_barrier_trace_source"] = "\n".join(texts)
                entries = [tracer._entries.get(text) for text in texts]
                program.__dict__["_barrier_trace_entry"] = "+".join(e for e in entries if e)
                return program

            return compile_

        self._patch(ShaderLibrary, "compose", compose)
        self._patch(moderngl.Context, "compute_shader", compiled)
        self._patch(moderngl.Context, "program", compiled)

        # -- bindings
        def bind_storage(buffer, binding=0, offset=0, size=-1):
            found = key(buffer, _ROLES["storage"].get(binding))
            tracer._state(buffer.ctx).storage[binding] = (found, offset)

        def bind_uniform(buffer, binding=0, offset=0, size=-1):
            found = key(buffer, _ROLES["uniform"].get(binding))
            tracer._state(buffer.ctx).uniform[binding] = found

        def use_texture(texture, location=0):
            found = key(texture, _ROLES["texture"].get(location))
            tracer._state(texture.ctx).textures[location] = found

        def bind_image(texture, unit, read=True, write=True, level=0, format=0):
            found = key(texture, _ROLES["image"].get(unit))
            tracer._state(texture.ctx).images[unit] = (found, read, write)

        self._before(moderngl.Buffer, "bind_to_storage_buffer", bind_storage)
        self._before(moderngl.Buffer, "bind_to_uniform_block", bind_uniform)
        for kind in _TEXTURES:
            self._before(kind, "use", use_texture)
            self._before(kind, "bind_to_image", bind_image)

        # -- transfers
        def span(offset, size):
            return ((offset, END if size < 0 else offset + size),)

        def buffer_read(buffer, size=-1, offset=0):
            tracer.transfer(
                buffer.ctx, "buffer read", [(key(buffer), span(offset, size), "buffer_update")]
            )

        def buffer_read_into(buffer, out, size=-1, offset=0, write_offset=0):
            tracer.transfer(
                buffer.ctx, "buffer read_into", [(key(buffer), span(offset, size), "buffer_update")]
            )

        def buffer_write(buffer, data, offset=0):
            size = memoryview(data).nbytes
            tracer.transfer(
                buffer.ctx,
                "buffer write",
                writes=[(key(buffer), span(offset, size), "buffer_update")],
            )

        def buffer_clear(buffer, size=-1, offset=0, chunk=None):
            tracer.transfer(
                buffer.ctx,
                "buffer clear",
                writes=[(key(buffer), span(offset, size), "buffer_update")],
            )

        def buffer_orphan(buffer, size=-1):
            tracer.transfer(
                buffer.ctx, "buffer orphan", writes=[(key(buffer), _WHOLE, "buffer_update")]
            )

        def copy_buffer(ctx, dst, src, size=-1, read_offset=0, write_offset=0):
            tracer.transfer(
                ctx,
                "copy_buffer",
                [(key(src), span(read_offset, size), "buffer_update")],
                [(key(dst), span(write_offset, size), "buffer_update")],
            )

        self._before(moderngl.Buffer, "read", buffer_read)
        self._before(moderngl.Buffer, "read_into", buffer_read_into)
        self._before(moderngl.Buffer, "write", buffer_write)
        self._before(moderngl.Buffer, "clear", buffer_clear)
        self._before(moderngl.Buffer, "orphan", buffer_orphan)
        self._before(moderngl.Context, "copy_buffer", copy_buffer)

        def texture_read(texture, *args, **kwargs):
            tracer.transfer(texture.ctx, "texture read", [(key(texture), _WHOLE, "texture_update")])

        def texture_read_into(texture, out, *args, **kwargs):
            writes = []
            if isinstance(out, moderngl.Buffer):  # a pixel pack into it
                writes.append((key(out), _WHOLE, "pixel_buffer"))
            reads = [(key(texture), _WHOLE, "texture_update")]
            tracer.transfer(texture.ctx, "texture read_into", reads, writes)

        def texture_write(texture, data, *args, **kwargs):
            reads = []
            if isinstance(data, moderngl.Buffer):  # a pixel unpack from it
                reads.append((key(data), _WHOLE, "pixel_buffer"))
            writes = [(key(texture), _WHOLE, "texture_update")]
            tracer.transfer(texture.ctx, "texture write", reads, writes)

        def mipmaps(texture, *args, **kwargs):
            found = [(key(texture), _WHOLE, "texture_update")]
            tracer.transfer(texture.ctx, "build_mipmaps", found, found)

        for kind in _TEXTURES:
            self._before(kind, "read", texture_read)
            self._before(kind, "read_into", texture_read_into)
            self._before(kind, "write", texture_write)
            self._before(kind, "build_mipmaps", mipmaps)

        def attached(framebuffer) -> list[tuple[str, int]]:
            found = (
                *(getattr(framebuffer, "_color_attachments", None) or ()),
                getattr(framebuffer, "_depth_attachment", None),
            )
            return [key(a) for a in found if isinstance(a, _TEXTURES)]

        def framebuffer_read(framebuffer, *args, **kwargs):
            reads = [(k, _WHOLE, "framebuffer") for k in attached(framebuffer)]
            tracer.transfer(framebuffer.ctx, "framebuffer read", reads)

        def framebuffer_read_into(framebuffer, out, *args, **kwargs):
            reads = [(k, _WHOLE, "framebuffer") for k in attached(framebuffer)]
            writes = (
                [(key(out), _WHOLE, "pixel_buffer")] if isinstance(out, moderngl.Buffer) else []
            )
            tracer.transfer(framebuffer.ctx, "framebuffer read_into", reads, writes)

        def framebuffer_clear(framebuffer, *args, **kwargs):
            writes = [(k, _WHOLE, "framebuffer") for k in attached(framebuffer)]
            tracer.transfer(framebuffer.ctx, "framebuffer clear", writes=writes)

        def context_clear(ctx, *args, **kwargs):
            writes = [(k, _WHOLE, "framebuffer") for k in attached(ctx.fbo)]
            tracer.transfer(ctx, "clear", writes=writes)

        def copy_framebuffer(ctx, dst, src):
            reads = [(k, _WHOLE, "framebuffer") for k in attached(src)]
            if isinstance(dst, _TEXTURES):
                writes = [(key(dst), _WHOLE, "texture_update")]
            else:
                writes = [(k, _WHOLE, "framebuffer") for k in attached(dst)]
            tracer.transfer(ctx, "copy_framebuffer", reads, writes)

        self._before(moderngl.Framebuffer, "read", framebuffer_read)
        self._before(moderngl.Framebuffer, "read_into", framebuffer_read_into)
        self._before(moderngl.Framebuffer, "clear", framebuffer_clear)
        self._before(moderngl.Context, "clear", context_clear)
        self._before(moderngl.Context, "copy_framebuffer", copy_framebuffer)

        def barrier(ctx, barriers=ALL_BITS, by_region=False):
            if not tracer.ignore or _where(helpers=True).split(" ")[0] not in tracer.ignore:
                tracer.barrier(ctx, barriers)

        self._before(moderngl.Context, "memory_barrier", barrier)

        def release(obj):
            if not isinstance(obj.mglo, moderngl.InvalidObject):
                tracer.forget(obj)

        for kind in (moderngl.Buffer, *_TEXTURES):
            self._before(kind, "release", release)

        # -- dispatches and draws: the check before, the contents seen after
        def run(original):
            def run_(program, *args, **kwargs):
                ran = tracer.shader(program.ctx, program, "dispatch")
                result = original(program, *args, **kwargs)
                ran()
                return result

            return run_

        def run_indirect(original):
            def run_(program, buffer, offset=0):
                extra = [(key(buffer), ((offset, offset + 12),), "command")]
                groups = np.frombuffer(
                    _ORIGINAL_READS[moderngl.Buffer](buffer, 12, offset), np.uint32
                )
                empty = int(np.prod(groups, dtype=np.uint64)) == 0
                ran = tracer.shader(program.ctx, program, "indirect dispatch", extra, empty=empty)
                result = original(program, buffer, offset)
                ran()
                return result

            return run_

        self._patch(moderngl.ComputeShader, "run", run)
        self._patch(moderngl.ComputeShader, "run_indirect", run_indirect)

        def vertices(vao) -> list:
            found = []
            for content in vao._content or ():
                if isinstance(content[0], moderngl.Buffer):
                    found.append((key(content[0]), _WHOLE, "vertex"))
            if isinstance(vao._index_buffer, moderngl.Buffer):
                found.append((key(vao._index_buffer), _WHOLE, "element"))
            return found

        def render(original):
            def render_(vao, *args, **kwargs):
                drawn = attached(vao.ctx.fbo)
                ran = tracer.shader(vao.ctx, vao.program, "draw", vertices(vao), drawn or [None])
                result = original(vao, *args, **kwargs)
                ran()
                return result

            return render_

        def render_indirect(original):
            def render_(vao, buffer, *args, **kwargs):
                extra = [*vertices(vao), (key(buffer), _WHOLE, "command")]
                drawn = attached(vao.ctx.fbo)
                ran = tracer.shader(vao.ctx, vao.program, "indirect draw", extra, drawn or [None])
                result = original(vao, buffer, *args, **kwargs)
                ran()
                return result

            return render_

        self._patch(moderngl.VertexArray, "render", render)
        self._patch(moderngl.VertexArray, "render_indirect", render_indirect)

    def uninstall(self) -> None:
        while self._saved:
            owner, name, original = self._saved.pop()
            setattr(owner, name, original)

    def report(self) -> str:
        """The hazards, each once (by where its two commands were issued), with a count."""
        counts: dict[tuple, int] = {}
        first: dict[tuple, Hazard] = {}
        for hazard in self.hazards:
            key = (hazard.kind, hazard.how, hazard.earlier, hazard.later)
            counts[key] = counts.get(key, 0) + 1
            first.setdefault(key, hazard)
        return "\n".join(f"[{counts[k]}x] {first[k]}" for k in counts)


@contextlib.contextmanager
def tracing(ignore: tuple[str, ...] = ()) -> Iterator[Tracer]:
    """A :class:`Tracer` installed on moderngl's classes for the ``with`` block; ``ignore``:
    barrier calls it leaves out, "glmls/path.py:line" (is each needed?)."""
    tracer = Tracer(ignore)
    tracer.install()
    try:
        yield tracer
    finally:
        tracer.uninstall()
