// The gradient map's lookup, in one place: t in [0, 1] to the colour of a 256 x 1 ramp sampled
// with linear filtering, t = 0 and 1 at the first and last texels' centres.
vec3 ramp_colour(sampler2D ramp, float t)
{
    return texture2D(ramp, vec2(t * (255.0 / 256.0) + 0.5 / 256.0, 0.5)).rgb;
}
