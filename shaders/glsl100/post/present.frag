#version 100
// The last post stage's image onto a WebGL page's canvas (es2particles/export/page.py): a copy.
precision mediump float;

varying vec2 v_uv;
uniform sampler2D u_source;

void main()
{
    gl_FragColor = vec4(texture2D(u_source, v_uv).rgb, 1.0);
}
