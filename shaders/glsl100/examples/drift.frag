#version 100
// A minimal user pass: every particle's position moves by u_delta each step. Declare it with
//   graph.add("drift", "examples/drift.frag", writes="position", reads=["position"],
//             uniforms={"u_delta": (0.01, 0.0)})
// The graph declares the rest for it: read_position(uv), write_position(value), v_uv (this
// particle's texel) and u_delta, typed from its value (see es2particles/bindings.py).

void main()
{
    write_position(read_position(v_uv) + u_delta);
}
