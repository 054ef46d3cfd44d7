// Unit vectors as two numbers in [-1, 1] (Meyer et al. 2010, "octahedral" normals): the
// octahedron |x| + |y| + |z| = 1, its lower half folded out over the corners. The collision
// field's normals (lib/field3d.glsl) and the confetti's orientation (collision3d.frag ORIENTED,
// quads/confetti.vert) are stored so. numpy twin: es2particles/fields/field3d.py (octahedral).

vec3 octahedral_decode(vec2 e)
{
    vec3 n = vec3(e, 1.0 - abs(e.x) - abs(e.y));
    if (n.z < 0.0) {
        vec2 s = vec2(e.x >= 0.0 ? 1.0 : -1.0, e.y >= 0.0 ? 1.0 : -1.0);
        n.xy = (1.0 - abs(e.yx)) * s;
    }
    return normalize(n);
}

vec2 octahedral_encode(vec3 n)
{
    vec3 o = n / (abs(n.x) + abs(n.y) + abs(n.z));
    if (o.z < 0.0) {
        vec2 s = vec2(o.x >= 0.0 ? 1.0 : -1.0, o.y >= 0.0 ? 1.0 : -1.0);
        return (1.0 - abs(o.yx)) * s;
    }
    return o.xy;
}
