"""What one handle read costs a shader on this driver, by where the handles live.

``python benchmarks/handle_reads.py [--points 66049] [--handles 1024]``

One compute pass evaluates an inverse-distance sum over every handle at each point (the
shape of MLS's handle loop), reading the handles from a storage buffer, a uniform block,
a texture, a storage buffer through ``readFirstInvocationARB`` (where the driver has
GL_ARB_shader_ballot) and a work group's tile in shared memory. Prints nanoseconds per
handle and point (median of 5). On Mesa llvmpipe the uniform block is 2x the storage
buffer, and shared-memory tiles are slower still (docs/performance.md).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import glmls
from glmls.gl import bindings
from glmls.gl.shaders import common_defines, define_value

SOURCE = """
#version 430
#extension GL_ARB_shader_ballot : enable
layout(local_size_x = 64) in;
layout(std430, binding = BIND_HANDLES) readonly buffer Hs { vec4 hs[]; };
layout(std140, binding = BIND_HANDLES_BLOCK) uniform Hu { vec4 hu[HANDLES]; };
layout(binding = BIND_HANDLE_TEXTURE) uniform sampler2D u_tex;
layout(std430, binding = BIND_DEFORMED) writeonly buffer O { vec2 o[]; };
uniform int u_n;
uniform int u_points;
shared vec4 tile[64];

vec4 handle(int i) {
#if MODE == 1
    return hu[i];
#elif MODE == 2
    return texelFetch(u_tex, ivec2(i, 0), 0);
#elif MODE == 3
    return hs[readFirstInvocationARB(i)];
#else
    return hs[i];
#endif
}

void main() {
    uint g = gl_GlobalInvocationID.x;
    vec2 v = vec2(float(g % 257u), float(g / 257u)) / 257.0;
    vec2 acc = vec2(0.0);
    float W = 0.0;
#if MODE == 4
    for (int t = 0; t < u_n; t += 64) {
        barrier();
        tile[gl_LocalInvocationID.x] = hs[t + int(gl_LocalInvocationID.x)];
        barrier();
        for (int k = 0; k < 64; ++k) {
            vec4 h = tile[k];
#else
    for (int i = 0; i < u_n; ++i) {
        {
            vec4 h = handle(i);
#endif
            vec2 d = h.xy - v;
            float w = 1.0 / (dot(d, d) + 1e-3);
            W += w;
            acc += w * h.zw;
        }
    }
    if (int(g) < u_points) {
        o[g] = acc / W;
    }
}
"""
MODES = {
    0: "storage buffer",
    1: "uniform block",
    2: "texture",
    3: "readFirstInvocation",
    4: "shared tile",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=66049)
    parser.add_argument("--handles", type=int, default=1024, help="a multiple of 64, <= 1024")
    args = parser.parse_args()
    n = args.handles
    if n % 64 or not 64 <= n <= 1024:
        parser.error("--handles must be a multiple of 64 from 64 to 1024")
    gl = glmls.gl.get_context()
    gl.make_current()  # raw moderngl calls below: glmls binds its context only in its calls
    ctx = gl.mgl
    handles = np.random.default_rng(0).random((n, 4), dtype=np.float32)
    groups = (args.points + 63) // 64
    buffers = [ctx.buffer(handles.tobytes()), ctx.buffer(reserve=groups * 64 * 8)]
    texture = ctx.texture((n, 1), 4, handles.tobytes(), dtype="f4")
    buffers[0].bind_to_storage_buffer(bindings.HANDLES.index)
    buffers[0].bind_to_uniform_block(bindings.HANDLES_BLOCK.index)
    buffers[1].bind_to_storage_buffer(bindings.DEFORMED.index)
    texture.use(bindings.HANDLE_TEXTURE.index)
    table = "".join(f"#define {k} {define_value(v)}\n" for k, v in common_defines().items())
    for mode, name in MODES.items():
        if mode == 3 and "GL_ARB_shader_ballot" not in ctx.extensions:
            continue
        header = f"#version 430\n{table}#define MODE {mode}\n#define HANDLES {n}"
        program = ctx.compute_shader(SOURCE.replace("#version 430", header, 1))
        program["u_n"] = n
        if "u_points" in program:
            program["u_points"] = args.points
        times = []
        for _ in range(6):
            ctx.finish()
            start = time.perf_counter()
            program.run(groups)
            ctx.finish()
            times.append(time.perf_counter() - start)
        ns = np.median(times[1:]) / (args.points * n) * 1e9
        print(f"{name:20s} {ns:5.2f} ns per handle and point")
        program.release()
    for obj in (*buffers, texture):
        obj.release()
    gl.unbind()


if __name__ == "__main__":
    main()
