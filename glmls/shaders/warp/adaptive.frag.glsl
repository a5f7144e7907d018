// Fills each target pixel from the adaptive mesh's triangle that warp/adaptive.comp.glsl
// found shown there (the first in scan order): the source point is the triangle's linear
// interpolation of its vertices' source points at the pixel centre, sampled by
// warp/sample.glsl (nearest: the source pixel containing the point; linear: bilinear; past
// the image by the border rule). Drawn as one full-viewport triangle; the viewport has the
// target's size. Pixels no triangle covers are discarded (the background stays).
//
//   WARP_OUTPUT_COORDS 1: write (s.x, s.y, 1, 0) instead of the colour.
#include "warp/target.glsl"
#include "warp/sample.glsl"

layout(std430, binding = BIND_DEFORMED) readonly buffer AdaptiveVertices {
    vec4 adaptive_vertex[];   // (output x, y, source x, y), pixels
};
layout(std430, binding = BIND_POINTS) readonly buffer AdaptiveTriangles {
    uint adaptive_index[];
};
layout(std430, binding = BIND_WINNER) readonly buffer AdaptiveWinner {
    uint adaptive_winner[];
};

uniform int u_triangles;

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    uint id = adaptive_winner[p.y * u_target_size.x + p.x];
    if (id == 0u) {
        discard;
    }
    int t = u_triangles - int(id);
    vec4 a = adaptive_vertex[adaptive_index[3 * t]];
    vec4 b = adaptive_vertex[adaptive_index[3 * t + 1]];
    vec4 c = adaptive_vertex[adaptive_index[3 * t + 2]];
    vec2 x = vec2(p);
    float area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    float lb = ((x.x - a.x) * (c.y - a.y) - (x.y - a.y) * (c.x - a.x)) / area;
    float lc = ((b.x - a.x) * (x.y - a.y) - (b.y - a.y) * (x.x - a.x)) / area;
    vec2 s = a.zw + (b.zw - a.zw) * lb + (c.zw - a.zw) * lc;
#if WARP_OUTPUT_COORDS
    out_color = vec4(s, 1.0, 0.0);
#else
    out_color = warp_sample(s);
#endif
}
