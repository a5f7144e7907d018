// The source points that Newton's passes found around an output slab's voxels, for the
// backward method's fold pass (volume/fold_list.comp.glsl, volume/folds.comp.glsl): the
// window, the slab's box of voxels grown by VOLUME_REACH on every side within the canvas,
// whose voxels hold (x, y, z, w) as volume/newton.comp.glsl stored them, w >= 0 the residual
// where found. Every neighbour within VOLUME_REACH of a slab voxel that the canvas holds lies
// in it, whatever slab the voxel is in.

layout(std430, binding = BIND_VOLUME_NEIGHBOURS) readonly buffer VolumeNeighbours {
    vec4 volume_neighbours[];
};

uniform ivec3 u_window_first;   // the window's first voxel (x, y, z) of the canvas
uniform ivec3 u_window_size;    // its W, H and slices

// The neighbours whose points are starts: the 5 x 5 x 5 about a voxel, nearest first (the
// first VOLUME_NEAR_COUNT are the 3 x 3 x 3).
const int VOLUME_REACH = 2;
const int VOLUME_NEIGHBOUR_COUNT = 124;
const int VOLUME_NEAR_COUNT = 26;
const ivec3 VOLUME_NEIGHBOUR[VOLUME_NEIGHBOUR_COUNT] = ivec3[](
    ivec3(1, 0, 0), ivec3(-1, 0, 0), ivec3(0, 1, 0), ivec3(0, -1, 0), ivec3(0, 0, 1),
    ivec3(0, 0, -1), ivec3(1, 1, 0), ivec3(-1, 1, 0), ivec3(1, -1, 0), ivec3(-1, -1, 0),
    ivec3(1, 0, 1), ivec3(-1, 0, 1), ivec3(1, 0, -1), ivec3(-1, 0, -1), ivec3(0, 1, 1),
    ivec3(0, -1, 1), ivec3(0, 1, -1), ivec3(0, -1, -1), ivec3(1, 1, 1), ivec3(-1, 1, 1),
    ivec3(1, -1, 1), ivec3(-1, -1, 1), ivec3(1, 1, -1), ivec3(-1, 1, -1), ivec3(1, -1, -1),
    ivec3(-1, -1, -1), ivec3(2, 0, 0), ivec3(-2, 0, 0), ivec3(0, 2, 0), ivec3(0, -2, 0),
    ivec3(0, 0, 2), ivec3(0, 0, -2), ivec3(2, 1, 0), ivec3(-2, 1, 0), ivec3(2, -1, 0),
    ivec3(-2, -1, 0), ivec3(1, 2, 0), ivec3(-1, 2, 0), ivec3(1, -2, 0), ivec3(-1, -2, 0),
    ivec3(2, 0, 1), ivec3(-2, 0, 1), ivec3(2, 0, -1), ivec3(-2, 0, -1), ivec3(0, 2, 1),
    ivec3(0, -2, 1), ivec3(0, 2, -1), ivec3(0, -2, -1), ivec3(1, 0, 2), ivec3(-1, 0, 2),
    ivec3(1, 0, -2), ivec3(-1, 0, -2), ivec3(0, 1, 2), ivec3(0, -1, 2), ivec3(0, 1, -2),
    ivec3(0, -1, -2), ivec3(2, 1, 1), ivec3(-2, 1, 1), ivec3(2, -1, 1), ivec3(-2, -1, 1),
    ivec3(2, 1, -1), ivec3(-2, 1, -1), ivec3(2, -1, -1), ivec3(-2, -1, -1), ivec3(1, 2, 1),
    ivec3(-1, 2, 1), ivec3(1, -2, 1), ivec3(-1, -2, 1), ivec3(1, 2, -1), ivec3(-1, 2, -1),
    ivec3(1, -2, -1), ivec3(-1, -2, -1), ivec3(1, 1, 2), ivec3(-1, 1, 2), ivec3(1, -1, 2),
    ivec3(-1, -1, 2), ivec3(1, 1, -2), ivec3(-1, 1, -2), ivec3(1, -1, -2), ivec3(-1, -1, -2),
    ivec3(2, 2, 0), ivec3(-2, 2, 0), ivec3(2, -2, 0), ivec3(-2, -2, 0), ivec3(2, 0, 2),
    ivec3(-2, 0, 2), ivec3(2, 0, -2), ivec3(-2, 0, -2), ivec3(0, 2, 2), ivec3(0, -2, 2),
    ivec3(0, 2, -2), ivec3(0, -2, -2), ivec3(2, 2, 1), ivec3(-2, 2, 1), ivec3(2, -2, 1),
    ivec3(-2, -2, 1), ivec3(2, 2, -1), ivec3(-2, 2, -1), ivec3(2, -2, -1), ivec3(-2, -2, -1),
    ivec3(2, 1, 2), ivec3(-2, 1, 2), ivec3(2, -1, 2), ivec3(-2, -1, 2), ivec3(2, 1, -2),
    ivec3(-2, 1, -2), ivec3(2, -1, -2), ivec3(-2, -1, -2), ivec3(1, 2, 2), ivec3(-1, 2, 2),
    ivec3(1, -2, 2), ivec3(-1, -2, 2), ivec3(1, 2, -2), ivec3(-1, 2, -2), ivec3(1, -2, -2),
    ivec3(-1, -2, -2), ivec3(2, 2, 2), ivec3(-2, 2, 2), ivec3(2, -2, 2), ivec3(-2, -2, 2),
    ivec3(2, 2, -2), ivec3(-2, 2, -2), ivec3(2, -2, -2), ivec3(-2, -2, -2));

// A neighbour's point farther from the voxel's than this many times their spacing, plus a
// voxel, shows another sheet of f (a fold): where f does not fold, it is the inverse's
// Lipschitz bound (as in 2D, warp/inverse.comp.glsl).
const float VOLUME_SHEET = 4.0;

// The index in the window of canvas voxel v, -1 outside it (past the canvas).
int volume_window_index(ivec3 v) {
    ivec3 w = v - u_window_first;
    bool inside = all(greaterThanEqual(w, ivec3(0))) && all(lessThan(w, u_window_size));
    return inside ? (w.z * u_window_size.y + w.y) * u_window_size.x + w.x : -1;
}

// Whether v's own Newton converged (``own``, its point: not found, w < 0, a residual within
// ``accept``): its preimage lies outside the volume (constant border).
bool volume_converged(vec4 own, float accept) {
    return -1.0 - own.w <= accept;
}

// How many of v's neighbours may give starts: where v's own Newton converged, the 3 x 3 x 3
// (a fold's other sheet shows next to it; the background about a volume that f shrinks has
// many such voxels, each then scanning a few), else the 5 x 5 x 5.
int volume_start_count(vec4 own, float accept) {
    return volume_converged(own, accept) ? VOLUME_NEAR_COUNT : VOLUME_NEIGHBOUR_COUNT;
}

// Whether the point of neighbour ``k`` of voxel v, ``own`` (v's: not found, w < 0), is a
// start: found, and, where v's Newton converged, on another sheet of f. Its point in
// ``near``.
bool volume_neighbour_start(ivec3 v, vec4 own, int k, float accept, out vec4 near) {
    int at = volume_window_index(v + VOLUME_NEIGHBOUR[k]);
    near = volume_neighbours[max(at, 0)];
    float apart = length(vec3(VOLUME_NEIGHBOUR[k]));
    bool sheet = !volume_converged(own, accept) ||
                 distance(near.xyz, own.xyz) > VOLUME_SHEET * apart + 1.0;
    return at >= 0 && near.w >= 0.0 && sheet;
}

// A voxel without a point is listed for the fold pass where its own Newton did not converge,
// and, where it converged (outside the volume), where one of its face neighbours has a point
// farther than this from its own (voxels): where f does not fold, a face neighbour's point
// lies as far as f's inverse stretches a voxel (and most of the background about the
// volume's image has no face neighbour with a point).
const float VOLUME_FACE_APART = 2.0;

// Whether voxel q has a point farther than VOLUME_FACE_APART from ``own``.
bool volume_point_apart(ivec3 q, vec4 own) {
    int at = volume_window_index(q);
    vec4 near = volume_neighbours[max(at, 0)];
    return at >= 0 && near.w >= 0.0 && distance(near.xyz, own.xyz) > VOLUME_FACE_APART;
}

// Whether v (``own``, its point: not found, w < 0) is listed (VOLUME_FACE_APART's rule).
// Six reads, no loop.
bool volume_listed(ivec3 v, vec4 own, float accept) {
    bvec3 after = bvec3(volume_point_apart(v + ivec3(1, 0, 0), own),
                        volume_point_apart(v + ivec3(0, 1, 0), own),
                        volume_point_apart(v + ivec3(0, 0, 1), own));
    bvec3 before = bvec3(volume_point_apart(v - ivec3(1, 0, 0), own),
                         volume_point_apart(v - ivec3(0, 1, 0), own),
                         volume_point_apart(v - ivec3(0, 0, 1), own));
    return !volume_converged(own, accept) || any(after) || any(before);
}
