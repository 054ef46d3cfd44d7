// Per-particle numbers that every driver computes alike: the R2 low-discrepancy sequence
// (Roberts 2018) at the particle's index, each a single multiply and fract of exact integers,
// where a hash's chain of products (lib/hash.glsl) may be contracted into fused multiply-adds by
// one driver and not another, and its fract then amplifies a last-bit difference into another
// number. For what a particle keeps all its life (a tumble axis, a shape, a colour) and a browser
// must draw as EGL does. Needs u_state_size.

// Three numbers in [0, 1) for the particle at texel uv.
vec3 particle_sequence(vec2 uv)
{
    vec2 texel = floor(uv * u_state_size);
    float index = texel.y * u_state_size.x + texel.x;
    return fract(index * vec3(0.8191725134, 0.6710436067, 0.5497004779) + 0.5);
}
