"""set_uniforms: unused names skipped, repeated values not written again, changed ones
written, and values it cannot compare (arrays) always written."""

from __future__ import annotations

import numpy as np

from glmls.gl import bindings
from glmls.gl.dispatch import set_uniforms

OUT = bindings.DEFORMED
CODE = f"""#version 430
layout(local_size_x = 1) in;
uniform int u_a;
uniform vec2 u_b;
layout(std430, binding = {OUT.index}) buffer Out {{ vec4 result; }};
void main() {{ result = vec4(float(u_a), u_b, 1.0); }}
"""


def test_set_uniforms_writes_what_changed(gl, monkeypatch):
    with gl:
        program = gl.mgl.compute_shader(CODE)
        out = gl.mgl.buffer(reserve=16)
        try:
            writes = []
            uniform = type(program["u_a"])  # moderngl's Uniform: count the writes
            original = uniform.value.fset

            def spy(self, value):
                writes.append((self.name, value))
                original(self, value)

            monkeypatch.setattr(uniform, "value", uniform.value.setter(spy))

            def result(values):
                writes.clear()
                set_uniforms(program, values)
                out.bind_to_storage_buffer(OUT.index)
                program.run()
                gl.mgl.memory_barrier()
                return np.frombuffer(out.read(), np.float32)[:3].tolist(), list(writes)

            assert result({"u_a": 3, "u_b": (1.5, 2.0), "u_unused": 9}) == (
                [3.0, 1.5, 2.0],
                [("u_a", 3), ("u_b", (1.5, 2.0))],
            )
            assert result({"u_a": 3, "u_b": [1.5, 2.0]}) == ([3.0, 1.5, 2.0], [])  # repeats
            assert result({"u_a": 4, "u_b": (1.5, 2.0)}) == ([4.0, 1.5, 2.0], [("u_a", 4)])
            assert result({"u_unused": 10, "u_a": 4})[1] == []  # still unused, still the same
            vector = np.array([0.5, 0.25], np.float32)  # not compared: written each time
            for _ in range(2):
                values, written = result({"u_b": vector})
                assert values == [4.0, 0.5, 0.25] and [n for n, _ in written] == ["u_b"]
            assert result({"u_b": (0.5, 0.25)})[1] == [("u_b", (0.5, 0.25))]
        finally:
            program.release()
            out.release()
