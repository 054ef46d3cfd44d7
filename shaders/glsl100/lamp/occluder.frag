#version 100
// The object seen from the lamp (mesh.vert places it): drawn with colour writes off, only its
// depth (step 1: particles behind it stop no light); then drawn black (step 4: the object's own
// shadow, which the floor reads).
precision mediump float;

void main()
{
    gl_FragColor = vec4(0.0, 0.0, 0.0, 1.0);
}
