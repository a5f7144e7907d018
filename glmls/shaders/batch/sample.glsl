// Samples layer k of a batch's sources (one texture array) at point s (source pixels): as
// warp/sample.glsl samples a single image, bilinear weights taken in float32 from s itself
// (not the texture unit's filtering of the normalized coordinate), the four pixels by the
// border rule (constant: clamped to the image, "edges clamped"). Needs u_sources and
// u_source_size.
#include "common/blend.glsl"
#include "common/border.glsl"

vec4 batch_texel(ivec2 p, int k) {
    return texelFetch(u_sources, ivec3(border_pixel(p, u_source_size), k), 0);
}

vec4 batch_sample(vec2 s, int k) {
    vec2 corner = floor(s);
    vec2 t = s - corner;
    ivec2 p = ivec2(corner);
    vec4 top = sample_blend(batch_texel(p, k), batch_texel(p + ivec2(1, 0), k), t.x);
    vec4 bottom =
        sample_blend(batch_texel(p + ivec2(0, 1), k), batch_texel(p + ivec2(1, 1), k), t.x);
    return sample_blend(top, bottom, t.y);
}
