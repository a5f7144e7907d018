// Backward mapping: every output pixel samples the source at the point s that
// warp/inverse.comp.glsl found for it. Needs a viewport of the output's size in pixels.
#include "warp/target.glsl"
#include "warp/sample.glsl"

layout(binding = BIND_COORDS) uniform sampler2D u_coords;   // (s.x, s.y, residual, covered)

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    vec4 c = texelFetch(u_coords, p, 0);
    if (c.w < 0.5) {
        discard;   // no source point inside the image: the background stays
    }
    out_color = warp_fetch(c.xy, ivec2(0), textureSize(u_source, 0) - 1);
}
