// The squares of method "paper-quads" of a batch of images scanned in one dispatch: one
// invocation per square of every image's lattice of pixel centres (square c of image k is
// item k * squares + c), each doing what warp/paper_quads.comp.glsl does for a single image
// (warp/paper_scan.glsl, the same keys, fold rule and source points), its vertices read from
// the chunk's mesh table (batch/mesh.glsl), its keys and (WARP_PAPER_STAGE 1, linear) source
// points written into image k's rows k * H .. k * H + H - 1 of the atlas of output canvases
// (batch/paper_quads.frag.glsl fills it). The image is the item's, not a work group layer:
// the pieces of large squares on llvmpipe take gl_WorkGroupID.z (common/pieces.glsl).
layout(local_size_x = LOCAL_SIZE) in;

#include "common/groups.glsl"
#include "batch/mesh.glsl"
#include "warp/paper_scan.glsl"

uniform int u_images;   // images in the batch
uniform int u_offset;   // first item of this dispatch

void main() {
    int squares_x = u_mesh_dims.x - 1;
    int squares = squares_x * (u_mesh_dims.y - 1);
    int item = u_offset + int(dispatch_item());
    int k = item / squares;
    if (k >= u_images) {
        return;
    }
    int square = item - k * squares;
    int sy = square / squares_x;
    int sx = square - sy * squares_x;
    ivec2 s00 = ivec2(sx, sy);
    vec2 q[4];   // 00, 10, 11, 01
    q[0] = batch_vertex_px(k, s00);
    q[1] = batch_vertex_px(k, s00 + ivec2(1, 0));
    q[2] = batch_vertex_px(k, s00 + ivec2(1, 1));
    q[3] = batch_vertex_px(k, s00 + ivec2(0, 1));
    paper_scan(q, s00, uint(square), k);
}
