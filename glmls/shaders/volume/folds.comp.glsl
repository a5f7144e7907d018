// The backward method's fold pass, its second stage (glmls.volume.folds): one invocation per
// voxel that volume/fold_list.comp.glsl listed (BIND_RESCUE), a voxel u that Newton's passes
// (volume/newton.comp.glsl) left without a source point, next to a fold: there Newton from
// the cells' guess and from u may both end on another sheet of f than u's preimage, or
// converge to a preimage outside the volume where another lies inside. Newton runs from the
// points of u's neighbours that those passes found (volume/neighbours.glsl: nearest first;
// where u's own Newton converged, only the 3 x 3 x 3), f's own Jacobian at each step, until
// one ends at a preimage (a residual within u_accept, inside the volume's box with the
// constant border); that point is stored, else u keeps what the first stage copied. The
// window holds the passes' points only, never this pass's: a voxel's result does not depend
// on the order its neighbours run in, nor on the slab it falls in.
// All the starts run in one flat loop of one evaluation of f an iteration, at most
// mls3_evaluations.

// one evaluation of f inlined, many made: the float64 moments sixteen handles an iteration
#define MLS3_FULL_BLOCK 16

layout(local_size_x = LOCAL_SIZE) in;

#include "volume/newton.glsl"
#include "volume/neighbours.glsl"

#define SECOND_PASS_ITEM uint
#include "common/second_pass.glsl"

// The start after neighbour ``k`` (-1: before the first) of voxel v, whose own point is
// ``own``: its index into ``k`` and its point into ``start``; false where none is left.
bool volume_next_start(inout int k, ivec3 v, vec4 own, out vec3 start) {
    vec4 near = vec4(0.0);
    bool found = false;
    int count = volume_start_count(own, u_accept);
    while (!found && k + 1 < count) {
        ++k;
        found = volume_neighbour_start(v, k, near);
    }
    start = near.xyz;
    return found;
}

void main() {
    // every listed voxel, however many the dispatch's work groups (at most u_max_groups)
    uint stride = second_pass_stride();
    int items = int((second_pass_listed() + stride - 1u) / stride);
    int most = VOLUME_NEIGHBOUR_COUNT * (5 * WARP_NEWTON_STEPS + 1);
    int budget = max(mls3_evaluations(most * max(items, 1)) / max(items, 1), 1);
    for (uint item = gl_GlobalInvocationID.x; item < second_pass_listed(); item += stride) {
        int i = int(second_pass_items[item]);
        ivec3 v = volume_voxel(i) + u_slab_first;
        vec3 u = u_frame_origin + vec3(v);
        vec4 own = volume_neighbours[volume_window_index(v)];
        int k = -1;
        vec3 start;
        bool running = volume_next_start(k, v, own, start);
        VolumeNewton n = volume_newton_begin(start, false, mat3(1.0));
        bool found = false;
        for (int e = 0; running && e < budget; ++e) {
            bool done = volume_newton_take(n, volume_f(volume_newton_point(n)), u);
            if (done || e + 1 == budget) {
                volume_newton_end(n);
                found = n.residual <= u_accept && volume_in_box(n.s);
                running = !found && volume_next_start(k, v, own, start);
                if (running) {
                    n = volume_newton_begin(start, false, mat3(1.0));
                }
            }
        }
        if (found) {
            volume_coords[i] = vec4(n.s, n.residual);
        }
    }
}
