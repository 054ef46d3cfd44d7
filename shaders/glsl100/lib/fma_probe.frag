#version 100
// Whether the driver fuses a * b + c into one rounding, as GLSL ES allows it to (ES 1.00 has no
// `precise`): with a = b = 1 + 2^-12, a * b is 1 + 2^-11 + 2^-24 exactly and 1 + 2^-11 once
// rounded to float32 (a tie, to even). Less c = 1 + 2^-11, the rounded product leaves 0 and a
// fused one 2^-24, scaled here to 1.
precision highp float;
uniform vec3 u_abc;

void main()
{
    gl_FragColor = vec4((u_abc.x * u_abc.y - u_abc.z) * 16777216.0);
}
