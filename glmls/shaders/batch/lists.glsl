// Which images of a batch's chunk each fused scan takes (batch/check.comp.glsl, stage 2):
// the embeddings (BATCH_CELLS_PASS 1) and the others (2), each scan an indirect dispatch of
// one invocation per cell of its images, sized as the images are listed.
layout(std430, binding = BIND_BATCH_LISTS) buffer BatchLists {
    uvec4 batch_groups[2];   // the two scans' work groups (x, y, z, 0); (0, 1, 1, 0) before
    uvec4 batch_listed;      // x, y: the images listed for each
    uint batch_list[];       // the embeddings from 0, the others from u_images
};
