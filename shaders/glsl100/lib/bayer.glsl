// The ordered dither of the light shafts' and the flame's first sample (shafts/scatter.frag,
// flame/march.frag).

// A pixel's place in the 4x4 Bayer pattern, 0..15: 4 b(x mod 2, y mod 2) + b(x/2 mod 2,
// y/2 mod 2) with the 2x2 pattern b(x, y) = 2 |x - y| + y (floors, not mod: exact everywhere).
float bayer2(vec2 p)
{
    p -= 2.0 * floor(p * 0.5);
    return 2.0 * abs(p.x - p.y) + p.y;
}

float bayer4(vec2 fragment)
{
    vec2 p = floor(fragment);
    return 4.0 * bayer2(p) + bayer2(floor(p * 0.5));
}
