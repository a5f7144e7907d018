// The backward method: for each output voxel u of the slab, the source point s with
// f(s) = u by Newton's method on f (source voxels), from the first guess in the coordinates
// buffer ((x, y, z, w), w >= 0: the cells' piecewise linear inverse covers u) or from u
// itself. The Jacobian by forward differences (a quarter voxel: the MLS Jacobian is not M);
// at most WARP_NEWTON_STEPS steps, each at most u_max_step voxels; stops below u_tolerance
// or where the Jacobian is singular (a fold's edge). Out: (s, w), w = the residual
// |f(s) - u| (voxels) where it is at most u_accept and (constant border) s is inside the
// volume, else -1 - residual.
layout(local_size_x = LOCAL_SIZE) in;

#include "volume/field.glsl"

layout(std430, binding = BIND_VOLUME_COORDS) buffer VolumeCoords {
    vec4 volume_coords[];
};

uniform int u_offset;        // first item of this dispatch
uniform int u_count;         // voxels of the slab
uniform ivec3 u_slab_size;   // W, H and slices of the output slab
uniform vec3 u_slab_origin;  // source voxels that the slab's voxel (0, 0, 0) shows
uniform ivec3 u_volume_size; // W, H, D of the source
uniform float u_tolerance;
uniform float u_accept;
uniform float u_max_step;

void main() {
    int item = u_offset + int(gl_GlobalInvocationID.x);
    bool store = item < u_count;
    int i = min(item, u_count - 1);
    ivec3 p = ivec3(i % u_slab_size.x, (i / u_slab_size.x) % u_slab_size.y,
                    i / (u_slab_size.x * u_slab_size.y));
    vec3 u = u_slab_origin + vec3(p);
    vec4 guess = volume_coords[i];
    vec3 s = guess.w >= 0.0 ? guess.xyz : u;
    const float h = 0.25;
    float residual = 0.0;
    for (int k = 0; ; ++k) {
        vec3 fs = volume_f(s);
        vec3 r = fs - u;
        residual = length(r);
        if (residual <= u_tolerance || k == WARP_NEWTON_STEPS) {
            break;
        }
        vec3 jx = (volume_f(s + vec3(h, 0.0, 0.0)) - fs) / h;
        vec3 jy = (volume_f(s + vec3(0.0, h, 0.0)) - fs) / h;
        vec3 jz = (volume_f(s + vec3(0.0, 0.0, h)) - fs) / h;
        vec3 n = cross(jy, jz);
        float det = dot(jx, n);
        if (!(abs(det) > 1e-9)) {
            break;   // singular: keep the best point so far
        }
        vec3 step = vec3(dot(r, n), dot(jx, cross(r, jz)), dot(jx, cross(jy, r))) / det;
        float len = length(step);
        s -= len > u_max_step ? step * (u_max_step / len) : step;
    }
    bool found = residual <= u_accept;
#if WARP_BORDER == 0
    found = found && all(greaterThanEqual(s, vec3(-0.5))) &&
            all(lessThanEqual(s, vec3(u_volume_size) - 0.5));
#endif
    if (store) {
        volume_coords[i] = vec4(s, found ? residual : -1.0 - min(residual, 1e30));
    }
}
