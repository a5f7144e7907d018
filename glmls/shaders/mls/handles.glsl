// Where the handles live: one of the storages of glmls.engine.storage, chosen by MLS_STORAGE
// (its index in STORAGES). Each defines
//   int mls_handle_count()   and   vec4 mls_handle(int i),
// the handle as (p.x, p.y, q.x, q.y) in scaled coordinates. A batch's lattice pass
// (MLS_BATCH) defines them in mls/batch.glsl.
#ifndef MLS_BATCH
#define MLS_BATCH 0   // 1: a batch's passes (mls/batch.glsl)
#endif
#if MLS_BATCH
#elif MLS_STORAGE == 0
#include "mls/handles_ssbo.glsl"
#elif MLS_STORAGE == 1
#include "mls/handles_ubo.glsl"
#elif MLS_STORAGE == 2
#include "mls/handles_texture.glsl"
#else
#error "unknown MLS_STORAGE"
#endif

// MLS_BLOCKS(F, e): F(i, use) for every handle i < e, sixteen a loop iteration (use: i < e;
// a slot past the end reads handle e - 1 again and gives it no weight). Mesa's llvmpipe ends
// an invocation's loops after 65,535 iterations counted over all of them, leaving the
// handles after that out without a word: a loop of one handle an iteration lost handles from
// ~20,000 on (an evaluation walks them two or three times, a Newton step as often again);
// sixteen an iteration move that sixteenfold at the speed of the plain loop (64 were slower
// on llvmpipe: the larger body). GPUs unroll such loops themselves.
#define MLS_BLOCK_SLOT(F, i, e) F(min(i, (e) - 1), (i) < (e))
#define MLS_BLOCK4(F, i, e) MLS_BLOCK_SLOT(F, i, e) MLS_BLOCK_SLOT(F, (i) + 1, e) \
    MLS_BLOCK_SLOT(F, (i) + 2, e) MLS_BLOCK_SLOT(F, (i) + 3, e)
#define MLS_BLOCK16(F, i, e) MLS_BLOCK4(F, i, e) MLS_BLOCK4(F, (i) + 4, e) \
    MLS_BLOCK4(F, (i) + 8, e) MLS_BLOCK4(F, (i) + 12, e)
#define MLS_BLOCKS(F, e) for (int mls_block = 0; mls_block < (e); mls_block += 16) { \
    MLS_BLOCK16(F, mls_block, e) }
