// Newton's method on f for the backward method's passes over the voxels of an output slab
// (volume/newton.comp.glsl, volume/folds.comp.glsl): the slab's voxels and the points they
// show, and Newton as a machine that takes one evaluation of f at a time (source voxels).
// Needs WARP_NEWTON_STEPS and WARP_BORDER (0: constant).

#include "volume/field.glsl"
#include "volume/slab.glsl"
#include "mls3/newton.glsl"

// Each voxel's source point (x, y, z, w), w >= 0 the residual where found
layout(std430, binding = BIND_VOLUME_COORDS) buffer VolumeCoords {
    vec4 volume_coords[];
};

uniform vec3 u_frame_origin; // source voxels that the output's voxel (0, 0, 0) shows
uniform ivec3 u_slab_first;  // the slab's first output voxel (x, y, z)
uniform ivec3 u_volume_size; // W, H, D of the source
uniform float u_tolerance;
uniform float u_accept;
uniform float u_max_step;

// f's Jacobian by forward differences of a quarter voxel (the MLS Jacobian is not M)
const float VOLUME_NEWTON_H = 0.25;

struct VolumeNewton {
    vec3 s;           // the iterate
    vec3 start;       // the point the last step started from
    vec3 fs;          // f(s)
    vec3 r;           // f(s) - u
    mat3 slope;       // the inverse Jacobian the steps take
    mat3 jacobian;    // f's own, being measured
    float residual;   // |f(s) - u|
    float last;       // the residual at start
    bool guided;      // slope is set
    bool fresh;       // slope is f's inverse Jacobian at an iterate
    int steps;
    int halvings;
    int probe;        // the next evaluation: 0 f at s; 1, 2, 3 at s + h along x, y, z
};

VolumeNewton volume_newton_begin(vec3 s, bool guided, mat3 slope) {
    VolumeNewton n;
    n.s = s;
    n.start = s;
    n.fs = vec3(0.0);
    n.r = vec3(0.0);
    n.slope = slope;
    n.jacobian = mat3(0.0);
    n.residual = 0.0;
    n.last = 1e30;
    n.guided = guided;
    n.fresh = false;
    n.steps = 0;
    n.halvings = 0;
    n.probe = 0;
    return n;
}

// where the next evaluation of f is
vec3 volume_newton_point(VolumeNewton n) {
    return n.s + VOLUME_NEWTON_H * vec3(equal(ivec3(n.probe - 1), ivec3(0, 1, 2)));
}

// Takes fx = f(volume_newton_point(n)); true where Newton ends.
bool volume_newton_take(inout VolumeNewton n, vec3 fx, vec3 u) {
    if (n.probe == 0) {
        n.fs = fx;
        n.r = fx - u;
        n.residual = length(n.r);
        if (n.residual <= u_tolerance) {
            return true;
        }
        if (n.residual > n.last && n.halvings < WARP_NEWTON_STEPS) {
            n.s = 0.5 * (n.start + n.s);   // the step overshot: half of it
            ++n.halvings;
            return false;
        }
        if (n.steps == WARP_NEWTON_STEPS) {
            return true;
        }
        if (!n.guided || (n.residual > 0.5 * n.last && !n.fresh)) {
            // no guess, or the slope converges slowly: f's Jacobian here instead
            n.probe = 1;
            return false;
        }
        n.fresh = false;
    } else {
        n.jacobian[n.probe - 1] = (fx - n.fs) / VOLUME_NEWTON_H;
        if (n.probe < 3) {
            ++n.probe;
            return false;
        }
        n.probe = 0;
        if (!(abs(determinant(n.jacobian)) > 1e-9)) {
            return true;   // singular (a fold's edge): keep the best point so far
        }
        n.slope = inverse(n.jacobian);
        n.guided = true;
        n.fresh = true;
    }
    n.last = n.residual;
    n.start = n.s;
    vec3 step = n.slope * n.r;
    float len = length(step);
    n.s -= len > u_max_step ? step * (u_max_step / len) : step;
    ++n.steps;
    return false;
}

// Where the last step's halvings did not bring the residual back down, the point before.
void volume_newton_end(inout VolumeNewton n) {
    if (n.residual > n.last) {
        n.s = n.start;
        n.residual = n.last;
    }
}

vec3 volume_target(int i) {
    return u_frame_origin + vec3(volume_voxel(i) + u_slab_first);
}

// The largest |coordinate| of v.
float volume_far(vec3 v) {
    vec3 a = abs(v);
    return max(a.x, max(a.y, a.z));
}

// Whether s lies where the border shows a source voxel: in the volume's closed box, within
// Newton's tolerance, with the constant border (a preimage on its face, where a quarter turn
// or a scale by 1/2 puts some, is in whatever side rounding leaves it); anywhere with the
// others.
bool volume_in_box(vec3 s) {
#if WARP_BORDER == 0
    return all(greaterThanEqual(s, vec3(-0.5 - u_tolerance))) &&
           all(lessThanEqual(s, vec3(u_volume_size) - 0.5 + u_tolerance));
#else
    return true;
#endif
}
