// Kuhn's split of a cell into 6 tetrahedra about its diagonal from corner 0 to corner 7
// (corner bits: 1 x, 2 y, 4 z): tetrahedron t is (0, a, a | b, 7) for the t-th order (a, b, c)
// of the axes. Every cell is split alike, so neighbouring cells' split faces match.
// glmls.volume.frame.TETRAHEDRA is the same table.
const int VOLUME_TETRA[12] = int[12](1, 3, 1, 5, 2, 3, 2, 6, 4, 5, 4, 6);

// A voxel centre within this (barycentric) of a tetrahedron counts as inside: shared faces
// belong to both sides, and the first cell in scan order takes them.
#define VOLUME_INSIDE_EPS 1e-5

// The barycentric coordinates (of b, c, d) of p in tetrahedron (a, b, c, d); false where it
// is flat (its volume below 1e-7 of the product of its edges' lengths).
bool volume_barycentric(vec3 a, vec3 b, vec3 c, vec3 d, vec3 p, out vec3 l) {
    vec3 e1 = b - a;
    vec3 e2 = c - a;
    vec3 e3 = d - a;
    vec3 r = p - a;
    vec3 n = cross(e2, e3);
    float det = dot(e1, n);
    l = vec3(0.0);
    if (!(abs(det) > 1e-7 * length(e1) * length(e2) * length(e3))) {
        return false;
    }
    l = vec3(dot(r, n), dot(e1, cross(r, e3)), dot(e1, cross(e2, r))) / det;
    return true;
}

// How far inside the tetrahedron barycentric coordinates l are (>= 0: inside).
float volume_depth(vec3 l) {
    return min(min(l.x, l.y), min(l.z, 1.0 - l.x - l.y - l.z));
}

bool volume_inside(vec3 l) {
    return volume_depth(l) >= -VOLUME_INSIDE_EPS;
}
