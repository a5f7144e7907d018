// The source pixel that a key of warp/paper_scan.glsl names: the key ~(4 k + v) holds the
// winning square's scan index k and its vertex v (00, 10, 11, 01) nearest to the pixel
// centre. Shared by a single image's fill (warp/paper_quads.frag.glsl) and a batch's
// (batch/paper_quads.frag.glsl).
uniform int u_squares_x;   // squares per row of the lattice (points per row - 1)

// The lattice point (before u_lattice_offset) of the vertex that the key ``id`` (not 0)
// names.
ivec2 paper_key_point(uint id) {
    uint key = ~id;
    uint k = key >> 2u;
    uint v = key & 3u;
    uint row = k / uint(u_squares_x);
    ivec2 square = ivec2(int(k - row * uint(u_squares_x)), int(row));
    // v: 0 = (0, 0), 1 = (1, 0), 2 = (1, 1), 3 = (0, 1)
    ivec2 corner = ivec2(v == 1u || v == 2u ? 1 : 0, v >= 2u ? 1 : 0);
    return square + corner;
}
