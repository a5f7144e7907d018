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
