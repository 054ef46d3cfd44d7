// A neighbour grid's cells and the loop over the particles around a point
// (es2particles/frame/neighbours.py). Every number here is an integer below 2^24 (a cell, a slot, a
// particle index): exact in highp.
//
// The declarations it uses come with the pass (es2particles/gl/bindings.py): u_neighbour_size (W,
// H cells; in 3D W, H, D), u_neighbour_box (2D: x0, y0, x1, y1) or u_neighbour_lo (3D: x0, y0,
// z0), u_neighbour_cell (a cell's side); with the loop, the order and table samplers
// u_neighbour_order and u_neighbour_table, u_neighbour_order_size, the particles'
// u_neighbour_state_size and u_neighbour_count, and NEIGHBOUR_BOUND. NEIGHBOUR_KEY (the key
// pass) takes only neighbour_cell and neighbour_table_cell. NEIGHBOUR_3D: a grid of 3D cells.
//
//     NEIGHBOUR_POINT other;   // vec2, or vec3 in 3D
//     FOR_EACH_NEIGHBOUR(p, other) {
//         vec2 q = read_position(other);   // every particle within a cell of p, and others
//         ...
//     }
//
// (`other` is a vec2 always: the state texel of the particle visited) visits the particles of
// the 3 x 3 cells around point p (3 x 3 x 3 in 3D): three runs of slots (nine in 3D), one per
// row of cells (a row's three cells are consecutive in the order), each of at most
// NEIGHBOUR_BOUND particles (GLSL ES 1.00 loops need constant bounds; a row holding more is
// refused when the run checks it, never cut short unseen). The particle itself is among them:
// compare `other` with v_uv to leave it out.
//
// The table is a 2D texture of the cells: in 3D, cell (i, j, k) is texel (i, k H + j), so a
// cell's number, (k H + j) W + i, counts the texels row by row in both.

#ifdef NEIGHBOUR_3D
#define NEIGHBOUR_POINT vec3
#define NEIGHBOUR_ROWS 9
#define NEIGHBOUR_LO u_neighbour_lo
#else
#define NEIGHBOUR_POINT vec2
#define NEIGHBOUR_ROWS 3
#define NEIGHBOUR_LO u_neighbour_box.xy
#endif

// The cell (i, j[, k]) of a world point, clamped into the grid: a point outside the box takes
// the nearest cell, as a particle outside it is held (a cell is no smaller than the distance
// looked, so the search stays exact).
NEIGHBOUR_POINT neighbour_cell(NEIGHBOUR_POINT point)
{
    return clamp(floor((point - NEIGHBOUR_LO) / u_neighbour_cell), NEIGHBOUR_POINT(0.0),
                 u_neighbour_size - 1.0);
}

// A cell's texel in the table, and the table's size.
#ifdef NEIGHBOUR_3D
vec2 neighbour_table_cell(vec3 cell)
{
    return vec2(cell.x, cell.z * u_neighbour_size.y + cell.y);
}

vec2 neighbour_table_size()
{
    return vec2(u_neighbour_size.x, u_neighbour_size.y * u_neighbour_size.z);
}
#else
vec2 neighbour_table_cell(vec2 cell)
{
    return cell;
}

vec2 neighbour_table_size()
{
    return u_neighbour_size;
}
#endif

#ifndef NEIGHBOUR_KEY
// The first slot of the cell at table texel `cell`.
float neighbour_first(vec2 cell)
{
    vec4 t = texture2D(u_neighbour_table, (cell + 0.5) / neighbour_table_size());
#ifdef ORDER_FLOAT
    return t.x;
#else
    vec4 b = floor(t * 255.0 + 0.5);
    return ((b.x * 256.0 + b.y) * 256.0 + b.z) * 256.0 + b.w;
#endif
}

// The slot after the last particle of the cell at table texel `cell`: the next cell's first,
// or the count.
float neighbour_end(vec2 cell)
{
    vec2 size = neighbour_table_size();
    cell.x += 1.0;
    if (cell.x >= size.x) {
        cell = vec2(0.0, cell.y + 1.0);
    }
    return cell.y >= size.y ? u_neighbour_count : neighbour_first(cell);
}

vec2 neighbour_run;    // [first, end) slots of the row of cells being visited
float neighbour_slot;  // the slot of this step of the row

// Step k of row `row` (0, 1, 2: below, at, above; in 3D 0 to 8, three rows a layer, layers
// behind, at, in front) of the cells around `point`: false past the row's last particle, else
// true with `uv` the state texel of the particle in that slot. The slot is counted in a float,
// never float(k): an int is mediump by default in a fragment shader, and a driver that converts
// it at mediump (llvmpipe does) rounds 2049 to 2048.
bool neighbour_next(NEIGHBOUR_POINT point, int row, int k, out vec2 uv)
{
    neighbour_slot += 1.0;
    if (k == 0) {
        NEIGHBOUR_POINT c = neighbour_cell(point);
        float r = float(row);  // 0 to 8: exact at any precision
        float layer = floor((r + 0.5) / 3.0);
        NEIGHBOUR_POINT at = c;
        at.y += r - 3.0 * layer - 1.0;
        bool inside = at.y >= 0.0 && at.y < u_neighbour_size.y;
#ifdef NEIGHBOUR_3D
        at.z += layer - 1.0;
        inside = inside && at.z >= 0.0 && at.z < u_neighbour_size.z;
#endif
        neighbour_run = vec2(0.0);
        if (inside) {
            vec2 t = neighbour_table_cell(at);
            float x0 = max(c.x - 1.0, 0.0);
            float x1 = min(c.x + 1.0, u_neighbour_size.x - 1.0);
            neighbour_run = vec2(neighbour_first(vec2(x0, t.y)), neighbour_end(vec2(x1, t.y)));
        }
        neighbour_slot = neighbour_run.x;
    }
    float slot = neighbour_slot;
    uv = vec2(0.0);
    if (slot >= neighbour_run.y) {
        return false;
    }
    vec2 s = vec2(order_mod(slot, u_neighbour_order_size.x), floor(slot / u_neighbour_order_size.x));
    float index = order_index(texture2D(u_neighbour_order, (s + 0.5) / u_neighbour_order_size));
    uv = order_state_uv(index, u_neighbour_state_size);
    return true;
}

// Whether the particle at `other` is another than the one this pass computes (the loop visits
// the particle itself too).
bool neighbour_other(vec2 other)
{
    return floor(other * u_neighbour_state_size) != floor(v_uv * u_neighbour_state_size);
}

// The loop: FOR_EACH_NEIGHBOUR(point, uv) { body }, `uv` a vec2 variable the body reads. Its
// counter is highp: a mediump int need not count past 1024.
#define FOR_EACH_NEIGHBOUR(POINT, UV) for (int neighbour_row = 0; neighbour_row < NEIGHBOUR_ROWS; neighbour_row++) for (highp int neighbour_k = 0; neighbour_k < NEIGHBOUR_BOUND; neighbour_k++) if (!neighbour_next(POINT, neighbour_row, neighbour_k, UV)) break; else
#endif
