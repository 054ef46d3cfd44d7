// 3D simplex noise with its analytic gradient, from float arithmetic alone: GLSL ES 1.00 has no
// integer operations a fragment shader can count on, and no indexing by a computed index, so the
// lattice hash is a permutation polynomial on integer-valued floats and each corner's gradient is
// picked by arithmetic, not from a table. simplex3(p) = (gradient.xyz, value), the value in
// about [-1, 1]. Every integer stays below 2^18 (float32 holds integers exactly up to 2^24).
// numpy twin: es2particles/twins/flow.py (simplex3), float64.

// x mod 289 of an integer-valued x, |x| < 2^16 (lattice cells, hash sums). (x + 0.5) / 289 lies
// at least 0.5 / 289 = 1.7e-3 from an integer, while its float32 error is a few ulp of a number
// below 2^8 (ulp 1.5e-5), so floor() never lands on the wrong side, as floor(x / 289) can when
// x is a multiple of 289 and an inexact division (a GPU may multiply by a reciprocal) lands just
// below the whole number, giving 289 for 0.
float mod289(float x)
{
    return x - 289.0 * floor((x + 0.5) / 289.0);
}

vec3 mod289(vec3 x)
{
    return x - 289.0 * floor((x + 0.5) / 289.0);
}

// The permutation polynomial (34 h^2 + h) mod 289, a permutation of 0..288, of an integer
// 0 <= h < 578. Reduced after each product: 34 h + 1 < 2^15, then (< 289) * h < 2^18. The whole
// product (34 h + 1) h, up to 1.1e7, would be exact too, but not its + 0.5 (ulp 1 above 2^23),
// and its quotient by 289 would carry an ulp of 2^-8, above the 1.7e-3 margin.
float permute289(float h)
{
    return mod289(mod289(34.0 * h + 1.0) * h);
}

// 0..288 for a lattice point of coordinates 0..289 (reduced mod 289, plus a corner's 0 or 1),
// chained z, y, x: each sum stays below 578.
float lattice_hash(vec3 i)
{
    return permute289(permute289(permute289(i.z) + i.y) + i.x);
}

// One of Perlin's 12 cube-edge directions, (+-1, +-1, 0) and its permutations, picked by h mod 12
// (289 = 24 * 12 + 1: the first direction comes 25 times in 289, the others 24, a bias the
// noise does not show). k / 4 says which component is 0, the bits of k mod 4 the other two's signs.
vec3 edge_gradient(float h)
{
    float k = h - 12.0 * floor((h + 0.5) / 12.0);
    float axis = floor((k + 0.5) / 4.0);
    float b = k - 4.0 * axis;
    float high = floor((b + 0.5) / 2.0);
    float u = 1.0 - 2.0 * (b - 2.0 * high);
    float v = 1.0 - 2.0 * high;
    float e0 = step(axis, 0.5);  // axis 0: (u, v, 0)
    float e2 = step(1.5, axis);  // axis 2: (0, u, v); else (u, 0, v)
    return vec3(u * (1.0 - e2), v * e0 + u * e2, v * (1.0 - e0));
}

// One corner's kernel: value t^4 (g.d), t = max(0.5 - |d|^2, 0), and its gradient
// t^4 g - 8 t^3 (g.d) d. The radius sqrt(0.5) keeps every lattice point within reach of p among
// its simplex's four corners, so the sum is C3 (each kernel meets zero with three zero
// derivatives); with 0.6 a kernel reaches past them, and the sum jumps at simplex faces (by some
// 0.3% of its range, measured in the twin).
vec4 simplex_corner(vec3 d, vec3 g)
{
    float t = max(0.5 - dot(d, d), 0.0);
    float t2 = t * t;
    float t3 = t2 * t;
    float t4 = t2 * t2;
    float gd = dot(g, d);
    return vec4(t4 * g - (8.0 * t3 * gd) * d, t4 * gd);
}

// (gradient.xyz, value) of the noise at p.
vec4 simplex3(vec3 p)
{
    const float F3 = 1.0 / 3.0;  // skew: the simplex lattice onto the cube lattice
    const float G3 = 1.0 / 6.0;  // and back
    // 76: the largest raw sum, 0.0130072 (one kernel's peak (4/9)^4 / 3 and a trace of
    // its neighbours', found by gradient ascent in the twin), maps to +-0.9885.
    const float NOISE_SCALE = 76.0;
    vec3 cell = floor(p + (p.x + p.y + p.z) * F3);
    vec3 d0 = p - cell + (cell.x + cell.y + cell.z) * G3;
    // The simplex holding d0: step along the largest component first, then along the second.
    // Ties go to x before y before z, one consistent order, so exactly one component is largest
    // and one smallest.
    float xy = step(d0.y, d0.x);  // 1 where x >= y
    float yz = step(d0.z, d0.y);
    float xz = step(d0.z, d0.x);
    vec3 first = vec3(xy * xz, (1.0 - xy) * yz, (1.0 - xz) * (1.0 - yz));
    vec3 last = vec3((1.0 - xy) * (1.0 - xz), xy * (1.0 - yz), xz * yz);
    vec3 second = 1.0 - last;
    vec3 d1 = d0 - first + G3;
    vec3 d2 = d0 - second + 2.0 * G3;
    vec3 d3 = d0 - 1.0 + 3.0 * G3;
    vec3 i = mod289(cell);
    vec4 sum = simplex_corner(d0, edge_gradient(lattice_hash(i)))
             + simplex_corner(d1, edge_gradient(lattice_hash(i + first)))
             + simplex_corner(d2, edge_gradient(lattice_hash(i + second)))
             + simplex_corner(d3, edge_gradient(lattice_hash(i + 1.0)));
    return NOISE_SCALE * sum;
}
