// Per-cell records (one record per cell: the cell boxes of traversal 'cell_boxes', and the
// dense cells of technique 'full'): cm_cells holds CM_CELL_FLOATS floats per cell: its
// corner (i, j, k) first when the fragment finds its cell by number (the cell boxes), its
// 27 Bernstein coefficients from CM_FIRST_COEFFICIENT on (a slowest, c fastest), and with
// CM_COLOR_VALUES a second field's 27 from there.
uniform samplerBuffer cm_cells;

// Three consecutive floats of cm_cells from `first`.
vec3 cm_cellFloats(int first)
{
  return vec3(texelFetch(cm_cells, first).r, texelFetch(cm_cells, first + 1).r,
              texelFetch(cm_cells, first + 2).r);
}

// Read 27 coefficients from float `base` on into cm_beta (written out: no loop).
void cm_loadFloats(int base)
{
  cm_beta[0] = cm_cellFloats(base);
  cm_beta[1] = cm_cellFloats(base + 3);
  cm_beta[2] = cm_cellFloats(base + 6);
  cm_beta[3] = cm_cellFloats(base + 9);
  cm_beta[4] = cm_cellFloats(base + 12);
  cm_beta[5] = cm_cellFloats(base + 15);
  cm_beta[6] = cm_cellFloats(base + 18);
  cm_beta[7] = cm_cellFloats(base + 21);
  cm_beta[8] = cm_cellFloats(base + 24);
}

// Read cell `number`'s 27 coefficients into cm_beta.
void cm_loadCell(int number)
{
  cm_loadFloats(number * CM_CELL_FLOATS + CM_FIRST_COEFFICIENT);
}

#ifdef CM_COLOR_VALUES
// The second field of cell `number` at local `u` (replaces cm_beta: read the geometry first).
float cm_colorValue(int number, vec3 u)
{
  cm_loadFloats(number * CM_CELL_FLOATS + CM_COLOR_VALUES);
  return cm_field(u);
}
#endif
