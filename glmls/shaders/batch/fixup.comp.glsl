// The pixels of a batch's atlas that more than one triangle reached (listed by
// batch/cells.comp.glsl with WARP_CELLS_FUSED) get the winning triangle's source texel, as
// warp/cells_fixup.comp.glsl does for a single image: atlas pixel i is image k = i / (W H)'s,
// its source texel in the sources' atlas at rows k * source H... Where more pixels were
// listed than the list holds, every pixel is redone. Indirect dispatch, sized by the scan.
layout(local_size_x = LOCAL_SIZE) in;

uniform ivec2 u_source_size;  // W, H of one source image
#include "warp/cells_packed.glsl"
#include "warp/cells_key.glsl"

layout(std430, binding = BIND_WINNER) readonly buffer WarpWinner {
    uint warp_winner[];   // per atlas pixel, row-major: the shown triangle's key, 0 = none
};
uniform ivec2 u_target_size;  // W, H of one image's output canvas
uniform int u_images;

void main() {
    uint j = dispatch_item();
    uint pixels = uint(u_target_size.x * u_target_size.y);
    bool all_pixels = warp_fixup_count > uint(u_fixup_capacity);
    if (j >= (all_pixels ? pixels * uint(u_images) : warp_fixup_count)) {
        return;
    }
    uint i = all_pixels ? j : warp_fixups[j];
    uint id = warp_winner[i];
    if (id == 0u) {
        return;   // uncovered (all pixels redone): the background stays
    }
    int k = int(i / pixels);
    ivec2 s = warp_key_source_pixel(id) + ivec2(0, k * u_source_size.y);
    int width = u_target_size.x;
    warp_store(ivec2(int(i) % width, int(i) / width), warp_source_texel(s));
}
