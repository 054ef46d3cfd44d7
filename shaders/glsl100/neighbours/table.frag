#version 100
// The cell table of a neighbour grid (es2particles/frame/neighbours.py): for the cell this fragment
// stands for, number c = j * W + i, the first slot of the sorted order whose key is at least c, by
// binary search (a cell's particles are its slots up to the next cell's first; an empty cell's
// first is the next cell's). Padding keys sort after every cell. Written as a 32-bit integer over
// the four bytes of an RGBA8 texel (R the highest), or as R in RGBA32F: every value is an integer
// of at most 2^24, exact in highp.
precision highp float;
precision highp sampler2D;
#include "lib/order.glsl"

uniform sampler2D u_order;        // the order, sorted by cell
uniform vec2 u_order_size;        // its width and height in slots (powers of two)
uniform vec2 u_neighbour_size;    // the table's W and H in cells (3D: W and H D, row k H + j)
uniform float u_levels;           // log2(slots) + 1: the search's steps
varying vec2 v_uv;

float key_at(float slot)
{
    vec2 cell = vec2(order_mod(slot, u_order_size.x), floor(slot / u_order_size.x));
    return order_key(texture2D(u_order, (cell + 0.5) / u_order_size));
}

void main()
{
    vec2 cell = floor(v_uv * u_neighbour_size);
    float c = cell.y * u_neighbour_size.x + cell.x;
    float lo = 0.0;
    float hi = u_order_size.x * u_order_size.y;
    for (int i = 0; i < 26; i++) {  // 2^24 slots take 25 steps; GLSL ES 1.00 loops are constant
        if (float(i) >= u_levels || lo >= hi) {
            break;
        }
        float mid = floor((lo + hi) * 0.5);
        if (key_at(mid) < c) {
            lo = mid + 1.0;
        } else {
            hi = mid;
        }
    }
    highp vec4 first;
#ifdef ORDER_FLOAT
    first = vec4(lo, 0.0, 0.0, 0.0);
#else
    first = vec4(floor(lo / 16777216.0), order_mod(floor(lo / 65536.0), 256.0),
                 order_mod(floor(lo / 256.0), 256.0), order_mod(lo, 256.0)) * (1.0 / 255.0);
#endif
    gl_FragColor = first;
}
