// Where a deformed mesh folds, for the fast scan (warp/cells.comp.glsl, WARP_CELLS_FAST and
// WARP_CELLS_HOT) and its test (warp/cells_check.comp.glsl): the list of the cells that are
// not strictly positive (the first u_folded_capacity of them; more, and the keyed scan
// redraws every cell); a map of the target in tiles of 2^u_hot_shift pixels on a side, one
// bit each, set near those cells; one bit per block of BLOCK x BLOCK cells, set where one of
// its cells is one; and the list of the blocks whose pixels reach a hot tile (the only cells
// the keyed scan redraws). All live in warp_check_data (warp/cells_packed.glsl) after a
// small header; the includer declares u_target_size and u_mesh_dims.

#define BLOCK 8                    // cells on a side of a block (BLOCK^2 == LOCAL_SIZE)
#define WARP_CHECK_LIST_GROUPS 0   // x, y, z work groups of the keyed scan of the blocks
#define WARP_CHECK_LISTED 4        // how many blocks are listed
#define WARP_CHECK_BLOCK_GROUPS 5  // x, y, z work groups of the listing of the blocks
#define WARP_CHECK_MARK_GROUPS 8   // x, y, z work groups of the marking of the listed cells
#define WARP_CHECK_HOT 12          // the bits: u_hot_words per row of tiles, rows top down

uniform int u_hot_shift;         // log2 of the tiles' side in pixels
uniform int u_hot_words;         // uints per row of tiles
uniform int u_folded_blocks;     // where the bits of the blocks with such cells start
uniform int u_folded_list;       // where the list of cells not strictly positive starts
uniform int u_folded_capacity;   // its length
uniform int u_block_list;        // where the list of blocks starts

// Do only the cells near the folded ones need keys? The boundary is simple and the folded
// cells are all listed.
bool warp_check_local() {
    return warp_check_boundary_simple() && warp_check_folded <= uint(u_folded_capacity);
}

// The block of cell c (row-major over the blocks).
int warp_block(ivec2 c) {
    int blocks_x = (u_mesh_dims.x - 1 + BLOCK - 1) / BLOCK;
    return (c.y / BLOCK) * blocks_x + c.x / BLOCK;
}

// The bits l..h (0 <= l <= h < 32) of a word.
uint warp_bit_range(int l, int h) {
    return (0xFFFFFFFFu >> uint(31 - (h - l))) << uint(l);
}

// Mark the tiles of pixels first - 1 .. last + 1 (within the target) hot: the margin covers
// pixel centres that rounding puts on the other side of an edge.
void warp_mark_hot(ivec2 first, ivec2 last) {
    ivec2 a = max(first - 1, ivec2(0)) >> u_hot_shift;
    ivec2 b = min(last + 1, u_target_size - 1) >> u_hot_shift;
    for (int y = a.y; y <= b.y; ++y) {
        for (int w = a.x >> 5; w <= b.x >> 5; ++w) {
            int l = max(a.x - 32 * w, 0);
            int h = min(b.x - 32 * w, 31);
            atomicOr(warp_check_data[WARP_CHECK_HOT + y * u_hot_words + w], warp_bit_range(l, h));
        }
    }
}

// Do the pixels first .. last (within the target, first <= last) reach a hot tile?
bool warp_reaches_hot(ivec2 first, ivec2 last) {
    ivec2 a = first >> u_hot_shift;
    ivec2 b = last >> u_hot_shift;
    uint found = 0u;
    for (int y = a.y; y <= b.y; ++y) {
        for (int w = a.x >> 5; w <= b.x >> 5; ++w) {
            int l = max(a.x - 32 * w, 0);
            int h = min(b.x - 32 * w, 31);
            found |= warp_check_data[WARP_CHECK_HOT + y * u_hot_words + w] & warp_bit_range(l, h);
        }
    }
    return found != 0u;
}
