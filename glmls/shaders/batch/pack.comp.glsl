// The atlas of a batch's output canvases (an RGBA8 texture read as r32ui, texel i of a table's
// layout being pixel i; batch/bytes.glsl, filled with the background before the scans) as the
// caller's bytes: four pixels an invocation, their first BATCH_CHANNELS bytes packed one after
// the other into BATCH_CHANNELS words (the (N, H, W, C) uint8 array, row k * H + y of the atlas
// being image k's row y), and with BATCH_LABELS the next byte of each (a label that rode as
// the channel after the image's) into one word from word u_labels_at: one read-back of the
// chunk into the caller's arrays, no channel dropped on the host. Four pixels of C bytes are
// exactly C words, so every shift is a constant.
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"
#include "common/table.glsl"

layout(r32ui, binding = BIND_TEXEL_SOURCE) readonly uniform uimage2D batch_atlas_image;
layout(std430, binding = BIND_BATCH_OUTPUT) writeonly buffer BatchOutput {
    uint batch_out[];
};
uniform uint u_quads;       // groups of four pixels
uniform int u_offset;       // first item of this dispatch
#if BATCH_LABELS
uniform uint u_labels_at;   // the labels' first word
#endif

void main() {
    uint j = uint(u_offset) + dispatch_item();
    if (j >= u_quads) {
        return;
    }
    // four consecutive texels of one row (the table's width is a multiple of four)
    ivec2 at4 = table_texel(int(4u * j));
    uvec4 t = uvec4(imageLoad(batch_atlas_image, at4).x,
                    imageLoad(batch_atlas_image, at4 + ivec2(1, 0)).x,
                    imageLoad(batch_atlas_image, at4 + ivec2(2, 0)).x,
                    imageLoad(batch_atlas_image, at4 + ivec2(3, 0)).x);
    uint at = uint(BATCH_CHANNELS) * j;
#if BATCH_CHANNELS == 4
    batch_out[at] = t.x;
    batch_out[at + 1u] = t.y;
    batch_out[at + 2u] = t.z;
    batch_out[at + 3u] = t.w;
#elif BATCH_CHANNELS == 3
    uvec4 c = t & 0xFFFFFFu;
    batch_out[at] = c.x | c.y << 24u;
    batch_out[at + 1u] = c.y >> 8u | c.z << 16u;
    batch_out[at + 2u] = c.z >> 16u | c.w << 8u;
#elif BATCH_CHANNELS == 2
    uvec4 c = t & 0xFFFFu;
    batch_out[at] = c.x | c.y << 16u;
    batch_out[at + 1u] = c.z | c.w << 16u;
#else
    uvec4 c = t & 0xFFu;
    batch_out[at] = c.x | c.y << 8u | c.z << 16u | c.w << 24u;
#endif
#if BATCH_LABELS
    uvec4 l = (t >> uint(8 * BATCH_CHANNELS)) & 0xFFu;
    batch_out[u_labels_at + j] = l.x | l.y << 8u | l.z << 16u | l.w << 24u;
#endif
}
