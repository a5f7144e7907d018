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
// (volume_listed takes such a voxel next to a fold only, whose other sheet shows next to
// it), else the 5 x 5 x 5.
int volume_start_count(vec4 own, float accept) {
    return volume_converged(own, accept) ? VOLUME_NEAR_COUNT : VOLUME_NEIGHBOUR_COUNT;
}

// Whether the point of neighbour ``k`` of voxel v is a start: found (however near v's own
// it lies, where v's Newton converged outside the volume: next to a fold's edge the sheets
// lie close together). Its point in ``near``.
bool volume_neighbour_start(ivec3 v, int k, out vec4 near) {
    int at = volume_window_index(v + VOLUME_NEIGHBOUR[k]);
    near = volume_neighbours[max(at, 0)];
    return at >= 0 && near.w >= 0.0;
}

// A voxel without a point is listed for the fold pass where its own Newton did not converge,
// and, where it converged (outside the volume), where the point of one of its face
// neighbours lies farther than this (voxels) from where the points about them put it: the
// straight line through the points of the voxels on either side of it along that axis
// (second differences). Where f does not fold, f's inverse is smooth and those points lie
// on that line within this, however much it stretches a voxel (the background about the
// image of a volume that f shrinks eightfold); a fold's other sheet does not.
const float VOLUME_FACE_APART = 2.0;

// Whether v's point is a preimage of f (found, or Newton converged outside the volume).
bool volume_has_point(vec4 point, float accept) {
    return point.w >= 0.0 || volume_converged(point, accept);
}

// The point of the voxel at ``at`` in the window, and whether it has one (-1: none).
bool volume_point_at(int at, float accept, out vec3 point) {
    vec4 p = volume_neighbours[max(at, 0)];
    point = p.xyz;
    return at >= 0 && volume_has_point(p, accept);
}

// Whether the face neighbour v + e has a found point off the line its neighbours along e
// give (VOLUME_FACE_APART's rule); ``own``: v's point. The line through v - e and v where
// v - e has a point, else through v and v + 2e; with neither, v's own point.
bool volume_point_apart(ivec3 v, ivec3 e, vec4 own, float accept) {
    int at = volume_window_index(v + e);
    vec4 near = volume_neighbours[max(at, 0)];
    vec3 back, ahead;
    bool behind = volume_point_at(volume_window_index(v - e), accept, back);
    bool beyond = volume_point_at(volume_window_index(v + 2 * e), accept, ahead);
    vec3 expected = behind ? 2.0 * own.xyz - back : beyond ? 0.5 * (own.xyz + ahead) : own.xyz;
    return at >= 0 && near.w >= 0.0 && distance(near.xyz, expected) > VOLUME_FACE_APART;
}

// Whether v (``own``, its point: not found, w < 0) is listed (VOLUME_FACE_APART's rule).
// Eighteen reads, no loop.
bool volume_listed(ivec3 v, vec4 own, float accept) {
    bvec3 after = bvec3(volume_point_apart(v, ivec3(1, 0, 0), own, accept),
                        volume_point_apart(v, ivec3(0, 1, 0), own, accept),
                        volume_point_apart(v, ivec3(0, 0, 1), own, accept));
    bvec3 before = bvec3(volume_point_apart(v, ivec3(-1, 0, 0), own, accept),
                         volume_point_apart(v, ivec3(0, -1, 0), own, accept),
                         volume_point_apart(v, ivec3(0, 0, -1), own, accept));
    return !volume_converged(own, accept) || any(after) || any(before);
}
