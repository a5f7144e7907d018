// Colours a batch's splatted points (batch/splat.vert.glsl) from layer v_image of the
// sources, as warp/mesh.frag.glsl (WARP_SPLAT) colours one image's: the source pixel itself
// (nearest), or the bilinear sample at its centre (which is that pixel's value), read past
// the image by the border rule WARP_BORDER (the lattice then has a margin, u_lattice_offset).
// The label images and the numbers of the pixels drawn: batch/forward_targets.glsl.
#include "common/lattice.glsl"

layout(binding = BIND_SOURCE) uniform sampler2DArray u_sources;
uniform ivec2 u_source_size;  // W, H of the source images

#include "batch/sample.glsl"

flat in ivec2 v_pixel;
flat in int v_image;

#include "batch/forward_targets.glsl"

void main() {
    ivec2 p = v_pixel + u_lattice_offset;
#if WARP_LINEAR
    out_color = batch_sample(vec2(v_pixel) + vec2(u_lattice_offset), v_image);
#else
    out_color = batch_texel(p, v_image);
#endif
    forward_store_labels(p, v_image);
}
