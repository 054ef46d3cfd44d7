// Deterministic per-particle random numbers from float arithmetic only (ES 1.00 has no integer
// bit operations): Dave Hoskins' "hash without sine", four outputs in [0,1) from four inputs.
// Inputs are kept below 4096 so that fract() keeps enough bits in float32.
// numpy twin: es2particles/scenes/collision.py, hash44().

vec4 hash44(vec4 p4)
{
    p4 = fract(p4 * vec4(0.1031, 0.1030, 0.0973, 0.1099));
    p4 += dot(p4, p4.wzxy + 33.33);
    return fract((p4.xxyz + p4.yzzw) * p4.zywx);
}
