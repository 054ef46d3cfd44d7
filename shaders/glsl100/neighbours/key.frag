#version 100
// The key pass of a neighbour grid (es2particles/frame/neighbours.py): each slot of the order keeps
// the particle it held last step and takes the number of that particle's cell, row by row
// (j * W + i; in 3D (k * H + j) * W + i), as its key; the merge network then sorts the slots
// by cell, ties by index. Slots of padding (an index >= u_count) stay padding: they sort after
// every particle.
// NEIGHBOUR_READ is the generated reader of the keyed quantity (read_position, say);
// u_state_size and u_count are the particles' (es2particles/gl/bindings.py).
#include "lib/order.glsl"

uniform sampler2D u_order;       // last step's order, read at this fragment's own slot
#ifdef NEIGHBOUR_3D
uniform vec3 u_neighbour_size;   // the grid's W, H and D in cells
uniform vec3 u_neighbour_lo;     // its world box's lower corner
#else
uniform vec2 u_neighbour_size;   // the grid's W and H in cells
uniform vec4 u_neighbour_box;    // its world rectangle x0, y0, x1, y1
#endif
uniform float u_neighbour_cell;  // a cell's side
varying vec2 v_uv;

#include "lib/neighbours.glsl"

void main()
{
    // Built in a highp variable and written once (see sort/key.frag: gl_FragColor is mediump).
    highp vec4 slot;
    float index = order_index(texture2D(u_order, v_uv));
    if (index >= u_count) {
        slot = order_padding(index);
    } else {
        vec2 cell = neighbour_table_cell(
            neighbour_cell(NEIGHBOUR_READ(order_state_uv(index, u_state_size))));
        slot = order_encode(cell.y * u_neighbour_size.x + cell.x, index);
    }
    gl_FragColor = slot;
}
