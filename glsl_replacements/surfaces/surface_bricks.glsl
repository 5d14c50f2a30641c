// Bricks of shared spline coefficients (traversal 'index'; models/surface_bricks.py): the
// grid is cut into bricks of CM_BRICK_SIZE cells per edge. cm_brickIndex holds per brick its
// slot (x, y, z in the slot grid) and 1, or 0 when it has no active cell. A slot holds the
// brick's (CM_BRICK_SIZE + 2)^3 B-spline coefficients in cm_brickCoefficients (the second
// field's in cm_brickColors), neighbouring cells sharing theirs, and one byte per cell in
// cm_brickCells: 1 where the cell is active.
uniform sampler3D cm_brickIndex;          // RGBA float per brick
uniform sampler3D cm_brickCoefficients;   // R float
uniform sampler3D cm_brickCells;          // R8
#ifdef CM_COLOR_VALUES
uniform sampler3D cm_brickColors;         // R float, as cm_brickCoefficients
#endif
#define CM_BRICK_SIZE (1 << CM_BRICK_SHIFT)

ivec3 cm_indexedBrick = ivec3(-1);   // the brick whose entry cm_brickEntry holds
vec4 cm_brickEntry = vec4(0.0);

// Whether `brick` holds an active cell. A ray stays in a brick for several steps: its entry
// is read once, when the ray enters it.
bool cm_brickStored(ivec3 brick)
{
  if (any(notEqual(brick, cm_indexedBrick)))
  {
    cm_indexedBrick = brick;
    cm_brickEntry = texelFetch(cm_brickIndex, brick, 0);
  }
  return cm_brickEntry.a > 0.5;
}

// Whether `cell` is active (its brick stored, its byte 1).
bool cm_cellActive(ivec3 cell)
{
  if (!cm_brickStored(cell >> CM_BRICK_SHIFT))
  {
    return false;
  }
  ivec3 texel = ivec3(cm_brickEntry.xyz) * CM_BRICK_SIZE + (cell & (CM_BRICK_SIZE - 1));
  return texelFetch(cm_brickCells, texel, 0).r > 0.0;   // 1 / 255 (normalised bytes)
}

// The pool texel of `cell`'s first coefficient (its brick stored).
ivec3 cm_coefficientTexel(ivec3 cell)
{
  cm_brickStored(cell >> CM_BRICK_SHIFT);
  return ivec3(cm_brickEntry.xyz) * (CM_BRICK_SIZE + 2) + (cell & (CM_BRICK_SIZE - 1));
}

// The 27 spline coefficients from `first` in `pool` to the cell's Bernstein coefficients in
// cm_beta: per axis (c0, c1, c2) becomes ((c0 + c1) / 2, c1, (c1 + c2) / 2), as
// models/surface.py's TO_BERNSTEIN.
void cm_loadSpline(sampler3D pool, ivec3 first)
{
  float c[27];
  for (int a = 0; a < 3; ++a)
  {
    for (int b = 0; b < 3; ++b)
    {
      for (int k = 0; k < 3; ++k)
      {
        c[9 * a + 3 * b + k] = texelFetch(pool, first + ivec3(a, b, k), 0).r;
      }
    }
  }
  for (int line = 0; line < 9; ++line)   // along z: n, n + 1, n + 2
  {
    int n = 3 * line;
    float middle = c[n + 1];
    c[n] = 0.5 * (c[n] + middle);
    c[n + 2] = 0.5 * (c[n + 2] + middle);
  }
  for (int line = 0; line < 9; ++line)   // along y: n, n + 3, n + 6
  {
    int n = 9 * (line / 3) + line % 3;
    float middle = c[n + 3];
    c[n] = 0.5 * (c[n] + middle);
    c[n + 6] = 0.5 * (c[n + 6] + middle);
  }
  for (int n = 0; n < 9; ++n)   // along x: n, n + 9, n + 18
  {
    float middle = c[n + 9];
    c[n] = 0.5 * (c[n] + middle);
    c[n + 18] = 0.5 * (c[n + 18] + middle);
  }
  for (int n = 0; n < 27; ++n)
  {
    cm_beta[n] = c[n];
  }
}

// Read active cell `cell`'s coefficients into cm_beta.
void cm_loadCellAt(ivec3 cell)
{
  cm_loadSpline(cm_brickCoefficients, cm_coefficientTexel(cell));
}

#ifdef CM_COLOR_VALUES
// The second field of `cell` at local `u` (replaces cm_beta: read the geometry first).
float cm_colorValue(ivec3 cell, vec3 u)
{
  cm_loadSpline(cm_brickColors, cm_coefficientTexel(cell));
  return cm_field(u);
}
#endif
