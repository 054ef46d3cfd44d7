// Whole counts below 2^24 in the three bytes r, g, b of an RGBA8 texel (r the lowest): a
// density summed exactly where no float target can be blended into (the WebGL page's
// density/add.frag; read by post/tonemap.frag with DENSITY_COUNTS). a is a flag: 1 where a batch
// filled a channel to its top, so the count there may be short. Exact in highp float, whose
// 24-bit significand holds every whole number up to 2^24. The page's density() decodes the same
// bytes in JavaScript (es2particles/webpage/executor.js).

float count_decode(vec4 texel)
{
    vec3 bytes = floor(texel.rgb * 255.0 + 0.5);
    return dot(bytes, vec3(1.0, 256.0, 65536.0));
}

vec3 count_encode(float count)
{
    float c = clamp(floor(count + 0.5), 0.0, 16777215.0);
    float high = floor(c / 65536.0);
    float rest = c - high * 65536.0;
    float middle = floor(rest / 256.0);
    return vec3(rest - middle * 256.0, middle, high) / 255.0;
}
