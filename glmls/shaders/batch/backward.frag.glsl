// Samples a batch's sources (the layers of one texture array) at the atlas of backward maps
// that warp/inverse.comp.glsl (MLS_BATCH) found, image k's rows k * H .. k * H + H - 1: as
// warp/backward.frag.glsl samples a single image, by the border rule WARP_BORDER past the
// image.
#include "common/border.glsl"

layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
layout(binding = BIND_COORDS) uniform sampler2D u_coords;   // (s.x, s.y, residual, covered)

uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform ivec2 u_source_size;  // W, H of the source images

#include "batch/sample.glsl"

layout(location = 0) out vec4 out_color;

void main() {
    ivec2 atlas = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(u_coords, atlas, 0);
    if (c.w < 0.5) {
        discard;   // no source point (constant border: none inside the image)
    }
    int k = atlas.y / u_target_size.y;
    vec2 s = c.xy;
#if WARP_LINEAR
    out_color = batch_sample(s, k);
#else
    ivec2 p = border_pixel(ivec2(floor(s + 0.5)), u_source_size);
    out_color = texelFetch(u_sources, ivec3(p, k), 0);
#endif
}
