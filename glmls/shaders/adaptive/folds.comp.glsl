// Where the deformed adaptive mesh may cover a pixel twice, on the GPU, from the vertices the
// scan reads (glmls.imaging.adaptive.folds.check_folds and hot_tiles are the float64 numpy
// references): one invocation per triangle. A triangle not of the mesh's orientation
// (u_orientation: +1 where f keeps it, -1 for a mirror), or nearly degenerate (twice its
// area within 1e-5 of its longest side squared: room for float32's rounding, which the
// scan's own area then cannot turn over; adaptive/mesh.glsl's adaptive_turned), is
// counted, and the 8 x 8 px tiles its pixel box (one pixel wider against rounding) reaches
// are marked hot, for adaptive/scan.comp.glsl's ADAPTIVE_HOT pass. A triangle with a vertex that is not finite or past 1e9 px draws
// nothing in the scan: it is not counted.
layout(local_size_x = LOCAL_SIZE) in;

#include "warp/coverage.glsl"
#include "adaptive/mesh.glsl"

uniform int u_count;          // triangles
uniform int u_offset;         // first triangle of this dispatch

void main() {
    int t = u_offset + int(gl_GlobalInvocationID.x);
    if (t >= u_count) {
        return;
    }
    uvec4 ids = adaptive_triangle(t);
    vec2 a = adaptive_vertex(ids.x).xy;
    vec2 b = adaptive_vertex(ids.y).xy;
    vec2 c = adaptive_vertex(ids.z).xy;
    if (!within_pixels(vec4(a, b), vec4(c, c))) {
        return;
    }
    if (!adaptive_turned(a, b, c, edge(a, b, c))) {
        return;
    }
    atomicAdd(adaptive_reversed, 1u);
    ivec2 first = ivec2(floor(min(min(a, b), c))) - 1;
    ivec2 last = ivec2(ceil(max(max(a, b), c))) + 1;
    if (any(lessThan(last, ivec2(0))) || any(greaterThanEqual(first, u_target_size))) {
        return;
    }
    first = clamp(first, ivec2(0), u_target_size - 1) >> HOT_SHIFT;
    last = clamp(last, ivec2(0), u_target_size - 1) >> HOT_SHIFT;
    for (int ty = first.y; ty <= last.y; ++ty) {
        for (int tx = first.x; tx <= last.x; ++tx) {
            atomicOr(adaptive_hot[u_hot_bits + ty * u_hot_words + (tx >> 5)], 1u << (tx & 31));
        }
    }
}
