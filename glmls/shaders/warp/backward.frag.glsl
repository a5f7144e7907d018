// Backward mapping: every output pixel samples the source at the point s that
// warp/inverse.comp.glsl found for it (outside the image: by the border rule). Needs a
// viewport of the output's size in pixels.
#include "warp/target.glsl"
#include "warp/sample.glsl"

layout(binding = BIND_COORDS) uniform sampler2D u_coords;   // (s.x, s.y, residual, covered)

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 p = warp_target_pixel();
    vec4 c = texelFetch(u_coords, p, 0);
    if (c.w < 0.5) {
        discard;   // no source point (constant border: none inside the image)
    }
    out_color = warp_sample(c.xy);
}
