// Scan conversions that walk a primitive's pixels in one invocation (warp/cells.comp.glsl,
// batch/cells.comp.glsl, adaptive/scan.comp.glsl, warp/paper_quads.comp.glsl; the voxels
// of a volume's deformed cell: volume/raster.comp.glsl), on a driver
// that caps an invocation's loop iterations: Mesa's llvmpipe stops all the loops of an
// invocation after 65,535 iterations, without a word (glmls.gl.GLContext.loop_limit), so a
// primitive magnified past that many pixels would be left partly unfilled. There
// SCAN_PIECE_PIXELS (> 0, a define of every compute program, glmls.gl.context) bounds the
// pixels one invocation walks: a primitive whose pixel box holds more is walked in pieces,
// tiles of the box of at most SCAN_PIECE_PIXELS pixels (and as many rows), one per
// invocation. The dispatch over the primitives walks piece 0 of each; a primitive with more
// raises the work groups of a second, indirect dispatch (scan_pieces: x and y those of the
// first, z the most pieces of any primitive less one), in which work group z walks piece
// z + 1 of every primitive (glmls.gl.dispatch.ScanPieces). The pieces' pixels are the
// primitive's, tested and keyed as before: only who walks them changes. A mesh with no
// large primitive dispatches no work group more, and nothing is read back. Without a cap
// (SCAN_PIECE_PIXELS 0: GPU drivers) none of this is compiled.
#ifndef SCAN_PIECE_PIXELS
#define SCAN_PIECE_PIXELS 0
#endif
// Loop iterations a pixel of the includer's walk costs (its loops per pixel, besides the
// walk's own step): its tiles hold SCAN_PIECE_PIXELS / SCAN_PIECE_COST pixels.
#ifndef SCAN_PIECE_COST
#define SCAN_PIECE_COST 1
#endif
#ifndef SCAN_PIECE_ROW_COST
#define SCAN_PIECE_ROW_COST 1
#endif

#if SCAN_PIECE_PIXELS
// The most work groups z the pieces' dispatch may have (GL's least maximum): the pieces
// past it stay undrawn, in a box of more than 65,535 tiles (10^9 pixels for the quads'
// tiles, 1.3 x 10^8 for paper-quads' smaller ones, 2.7 x 10^8 voxels).
#define SCAN_PIECES_MAX 65535

layout(std430, binding = BIND_PIECES) buffer ScanPieces {
    uint scan_pieces_x;   // the pieces' indirect dispatch (x, y, z): (0, 0, 0) before the
    uint scan_pieces_y;   // first dispatch, raised by it
    uint scan_pieces_z;
};
uniform int u_piece_first;   // 0: the dispatch over the primitives, 1: the pieces'

// Piece 0 of a primitive walked in ``pieces`` pieces: the pieces' dispatch takes as many
// work groups as this one, and at least pieces - 1 in z.
void scan_raise_pieces(int pieces) {
    atomicMax(scan_pieces_x, gl_NumWorkGroups.x);
    atomicMax(scan_pieces_y, gl_NumWorkGroups.y);
    atomicMax(scan_pieces_z, uint(min(pieces - 1, SCAN_PIECES_MAX)));
}

// The tiles of the pixel box first..last: their width and height, and how many across and
// down (an empty box: one piece, a tile of no pixel).
ivec4 scan_tiles(ivec2 first, ivec2 last) {
    ivec2 size = last - first + 1;
    if (any(lessThan(size, ivec2(1)))) {
        return ivec4(1, 1, 1, 1);
    }
    const int pixels = SCAN_PIECE_PIXELS / SCAN_PIECE_COST;
    int w = min(size.x, pixels);
    int h = max(pixels / w, 1);
    return ivec4(w, h, (size.x + w - 1) / w, (size.y + h - 1) / h);
}

// How many pieces a primitive with the pixel box first..last is walked in.
int scan_pieces(ivec2 first, ivec2 last) {
    ivec4 tiles = scan_tiles(first, last);
    return tiles.z * tiles.w;
}

// This invocation's piece of the pixel box first..last, which it narrows to the piece's
// tile; false where the primitive has no such piece (an empty box has piece 0 only, as it
// is).
bool scan_piece(inout ivec2 first, inout ivec2 last) {
    int piece = int(gl_WorkGroupID.z) + u_piece_first;
    ivec4 tiles = scan_tiles(first, last);
    int pieces = tiles.z * tiles.w;
    if (piece == 0 && pieces > 1) {
        scan_raise_pieces(pieces);
    }
    if (piece >= pieces) {
        return false;
    }
    if (pieces > 1) {
        int row = piece / tiles.z;
        first += ivec2((piece - row * tiles.z) * tiles.x, row * tiles.y);
        last = min(last, first + tiles.xy - 1);
    }
    return true;
}

// The same for a box of voxels (volume/raster.comp.glsl), in tiles of at most
// SCAN_PIECE_PIXELS / SCAN_PIECE_COST voxels and SCAN_PIECE_PIXELS / SCAN_PIECE_ROW_COST
// rows (the includer's loop iterations per voxel and per row), whole rows where they fit.
bool scan_piece_3d(inout ivec3 first, inout ivec3 last) {
    int piece = int(gl_WorkGroupID.z) + u_piece_first;
    ivec3 size = last - first + 1;
    if (any(lessThan(size, ivec3(1)))) {
        return piece == 0;
    }
    const int voxels = SCAN_PIECE_PIXELS / SCAN_PIECE_COST;
    const int rows = SCAN_PIECE_PIXELS / SCAN_PIECE_ROW_COST;
    ivec3 tile;
    tile.x = min(size.x, voxels);
    int most = max(min(voxels / tile.x, rows), 1);   // rows of a tile
    tile.y = min(size.y, most);
    tile.z = max(most / tile.y, 1);
    ivec3 across = (size + tile - 1) / tile;
    int pieces = across.x * across.y * across.z;
    if (piece == 0 && pieces > 1) {
        scan_raise_pieces(pieces);
    }
    if (piece >= pieces) {
        return false;
    }
    ivec3 at = ivec3(piece % across.x, (piece / across.x) % across.y,
                     piece / (across.x * across.y));
    first += at * tile;
    last = min(last, first + tile - 1);
    return true;
}

// Is this the invocation that walks piece 0 (the one that counts or lists its primitive)?
bool scan_first_piece() {
    return gl_WorkGroupID.z == 0u && u_piece_first == 0;
}
#else
bool scan_piece_3d(inout ivec3 first, inout ivec3 last) {
    return true;
}

int scan_pieces(ivec2 first, ivec2 last) {
    return 1;
}

bool scan_piece(inout ivec2 first, inout ivec2 last) {
    return true;
}

bool scan_first_piece() {
    return true;
}
#endif
