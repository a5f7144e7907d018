// The backward method: for each output voxel u of the slab, the source point s with
// f(s) = u by Newton's method on f (source voxels), from the first guess in the coordinates
// buffer ((x, y, z, w), w >= 0: the cells' piecewise linear inverse covers u) or from u
// itself (and from u where the guess's ends above u_accept). Each step takes one evaluation of f and a slope, the inverse Jacobian: from a guess
// first its tetrahedron's (the slopes buffer: the piecewise linear inverse's), else, and
// wherever the residual falls by less than half in a step, f's own by forward differences
// (a quarter voxel: the MLS Jacobian is not M), kept while it converges fast;
// at most WARP_NEWTON_STEPS steps, each at most u_max_step voxels; a step that raises the
// residual (f curves within it, and Newton would cycle between two points) is halved, up to
// WARP_NEWTON_STEPS halvings in all; stops below u_tolerance or where the Jacobian is
// singular (a fold's edge), keeping the best point. Out: (s, w), w = the residual
// |f(s) - u| (voxels) where it is at most u_accept and (constant border) s is inside the
// volume, else -1 - residual.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/field.glsl"

layout(std430, binding = BIND_VOLUME_COORDS) buffer VolumeCoords {
    vec4 volume_coords[];
};
layout(std430, binding = BIND_VOLUME_SLOPES) readonly buffer VolumeSlopes {
    vec4 volume_slopes[];
};

uniform int u_offset;        // first item of this dispatch
uniform int u_count;         // voxels of the slab
uniform ivec3 u_slab_size;   // W, H and slices of the output slab
uniform vec3 u_frame_origin; // source voxels that the output's voxel (0, 0, 0) shows
uniform int u_slab_first;    // the slab's first output slice
uniform ivec3 u_volume_size; // W, H, D of the source
uniform float u_tolerance;
uniform float u_accept;
uniform float u_max_step;

// Newton from s (a guess of the cells' inverse with its slope where guided, else u itself
// and f's own Jacobians); leaves s at the point it ends at and returns its residual.
float volume_newton(inout vec3 s, vec3 u, bool guided, mat3 slope) {
    // f's Jacobian by forward differences of a quarter voxel (the MLS Jacobian is not M)
    const float h = 0.25;
    mat3 jacobian = mat3(0.0);
    vec3 fs = vec3(0.0);
    vec3 r = vec3(0.0);
    float residual = 0.0;
    float last = 1e30;    // the residual at the point the last step started from
    vec3 start = s;       // that point
    bool fresh = false;   // slope is f's inverse Jacobian at an iterate
    int steps = 0;
    int halvings = 0;
    int probe = 0;        // 0: f at the iterate s; 1, 2, 3: at s + h along x, y, z
    // One place evaluates f, the iterate's or a probe's: f is most of the shader's code, and
    // one copy of it (not four) keeps the program small enough for a GPU's registers.
    for (int n = 0; n < 5 * WARP_NEWTON_STEPS + 1; ++n) {
        vec3 axis = vec3(equal(ivec3(probe - 1), ivec3(0, 1, 2)));
        vec3 fx = volume_f(s + h * axis);
        if (probe == 0) {
            fs = fx;
            r = fs - u;
            residual = length(r);
            if (residual <= u_tolerance) {
                break;
            }
            if (residual > last && halvings < WARP_NEWTON_STEPS) {
                s = 0.5 * (start + s);   // the step overshot: half of it
                ++halvings;
                continue;
            }
            if (steps == WARP_NEWTON_STEPS) {
                break;
            }
            if (!guided || (residual > 0.5 * last && !fresh)) {
                // no guess, or the slope converges slowly: f's Jacobian here instead
                probe = 1;
                continue;
            }
            fresh = false;
        } else {
            jacobian[probe - 1] = (fx - fs) / h;
            if (probe < 3) {
                ++probe;
                continue;
            }
            probe = 0;
            if (!(abs(determinant(jacobian)) > 1e-9)) {
                break;   // singular (a fold's edge): keep the best point so far
            }
            slope = inverse(jacobian);
            guided = true;
            fresh = true;
        }
        last = residual;
        start = s;
        vec3 step = slope * r;
        float len = length(step);
        s -= len > u_max_step ? step * (u_max_step / len) : step;
        ++steps;
    }
    if (residual > last) {   // the last step's halvings did not bring it back down
        s = start;
        residual = last;
    }
    return residual;
}

void main() {
    int item = u_offset + int(gl_GlobalInvocationID.x);
    bool store = item < u_count;
    int i = min(item, u_count - 1);
    ivec3 p = ivec3(i % u_slab_size.x, (i / u_slab_size.x) % u_slab_size.y,
                    i / (u_slab_size.x * u_slab_size.y));
    vec3 u = u_frame_origin + vec3(p + ivec3(0, 0, u_slab_first));
    vec4 guess = volume_coords[i];
    bool guided = guess.w >= 0.0;
    mat3 slope = mat3(volume_slopes[3 * i].xyz, volume_slopes[3 * i + 1].xyz,
                      volume_slopes[3 * i + 2].xyz);
    vec3 s = u;
    float residual = 1e30;
    // from the guess; where it leads off (next to a fold, the cells' inverse may be another
    // sheet's), again from u itself with f's own Jacobians, keeping the better end. One call
    // in a loop, not two calls: one copy of f in the program.
    for (int attempt = 0; attempt < 2; ++attempt) {
        bool from_guess = attempt == 0 && guided;
        vec3 t = from_guess ? guess.xyz : u;
        float got = volume_newton(t, u, from_guess, slope);
        s = got < residual ? t : s;
        residual = min(got, residual);
        if (residual <= u_accept || !guided) {
            break;
        }
    }
    bool found = residual <= u_accept;
#if WARP_BORDER == 0
    // in the volume's closed box, within Newton's tolerance: a preimage on its face (a
    // quarter turn, a scale by 1/2 put some there) is in, whatever side rounding leaves it
    found = found && all(greaterThanEqual(s, vec3(-0.5 - u_tolerance))) &&
            all(lessThanEqual(s, vec3(u_volume_size) - 0.5 + u_tolerance));
#endif
    if (store) {
        volume_coords[i] = vec4(s, found ? residual : -1.0 - min(residual, 1e30));
    }
}
