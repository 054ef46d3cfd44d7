#version 100
// The liquid's metaballs, step 1 (the article author's particles pass): each particle a white disc
// (over gl_PointCoord) in the reduced buffer; overlapping discs write the same white.
precision mediump float;

void main()
{
    vec2 p = gl_PointCoord * 2.0 - 1.0;
    if (dot(p, p) > 1.0) {
        discard;
    }
    gl_FragColor = vec4(1.0);
}
