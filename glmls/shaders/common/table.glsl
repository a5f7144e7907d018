// Read-only arrays in 2-D textures (glmls.gl.tables): item i of a table is texel
// (i & (2^TABLE_SHIFT - 1), i >> TABLE_SHIFT), fetched whole. On llvmpipe a fetch gathers the
// texels of all lanes at once, where a storage buffer's load of a different item per lane
// goes lane by lane and component by component. TABLE_SHIFT is defined in every program.

ivec2 table_texel(int i) {
    return ivec2(i & ((1 << TABLE_SHIFT) - 1), i >> TABLE_SHIFT);
}

#define TABLE_FETCH(table, i) texelFetch(table, table_texel(int(i)), 0)
// Item i of a uint32 table bound as an r32ui image (Tables.bind_image), a uint.
#define TABLE_LOAD(image, i) imageLoad(image, table_texel(int(i))).x
