// Per-cell records (the seed's layout: the cell boxes of traversal 'cell_boxes', and the
// dense cells of technique 'full'): cm_cells holds CM_CELL_FLOATS floats per cell: its
// corner (i, j, k) first when the fragment finds its cell by number (the cell boxes), its
// 27 Bernstein coefficients from CM_FIRST_COEFFICIENT on (a slowest, c fastest), and with
// CM_COLOR_VALUES a second field's 27 from there.
uniform samplerBuffer cm_cells;

// Read cell `number`'s 27 coefficients into cm_beta.
void cm_loadCell(int number)
{
  int base = number * CM_CELL_FLOATS + CM_FIRST_COEFFICIENT;
  for (int n = 0; n < 27; ++n)
  {
    cm_beta[n] = texelFetch(cm_cells, base + n).r;
  }
}

#ifdef CM_COLOR_VALUES
// The second field of cell `number` at local `u` (its 27 coefficients read once, here).
float cm_colorValue(int number, vec3 u)
{
  int base = number * CM_CELL_FLOATS + CM_COLOR_VALUES;
  vec3 bu = cm_basis(u.x), bv = cm_basis(u.y), bw = cm_basis(u.z);
  float f = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    for (int b = 0; b < 3; ++b)
    {
      int n = base + 9 * a + 3 * b;
      f += bu[a] * bv[b] * dot(vec3(texelFetch(cm_cells, n).r, texelFetch(cm_cells, n + 1).r,
                                    texelFetch(cm_cells, n + 2).r), bw);
    }
  }
  return f;
}
#endif
