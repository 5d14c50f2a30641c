// Bricks of shared spline coefficients (traversal 'index'; models/surface_bricks.py): the
// grid is cut into bricks of CM_BRICK_SIZE cells per edge. cm_brickIndex holds per brick its
// slot (x, y, z in the slot grid) and 1, or 0 when it has no active cell. A slot holds the
// brick's (CM_BRICK_SIZE + 2)^3 B-spline coefficients in cm_brickCoefficients (the second
// field's in cm_brickColors), neighbouring cells sharing theirs, and one byte per cell in
// cm_brickCells: 1 where the cell is active. Above them, cm_blocks holds per block of
// CM_BLOCK_SIZE cells per edge whether any of its bricks is stored.
uniform sampler3D cm_brickIndex;          // RGBA float per brick
uniform sampler3D cm_brickCoefficients;   // R float
uniform sampler3D cm_brickCells;          // R8
#ifdef CM_COLOR_VALUES
uniform sampler3D cm_brickColors;         // R float, as cm_brickCoefficients
#endif
uniform sampler3D cm_blocks;              // R8
#define CM_BRICK_SIZE (1 << CM_BRICK_SHIFT)
#define CM_BLOCK_SIZE (1 << CM_BLOCK_SHIFT)

// Whether `block` holds a stored brick (read at every step: each enters another block).
bool cm_blockOccupied(ivec3 block)
{
  return texelFetch(cm_blocks, block, 0).r > 0.0;   // 1 / 255 (normalised bytes)
}

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

// Three spline coefficients along z from `first` in `pool`, as Bernstein coefficients along
// z: (c0, c1, c2) becomes ((c0 + c1) / 2, c1, (c1 + c2) / 2) (models/surface.py's
// TO_BERNSTEIN, per axis).
vec3 cm_splineRow(sampler3D pool, ivec3 first)
{
  float c0 = texelFetch(pool, first, 0).r;
  float c1 = texelFetch(pool, first + ivec3(0, 0, 1), 0).r;
  float c2 = texelFetch(pool, first + ivec3(0, 0, 2), 0).r;
  return vec3(0.5 * (c0 + c1), c1, 0.5 * (c1 + c2));
}

// The same conversion across three rows of cm_beta (along y or x).
void cm_toBernstein(int r0, int r1, int r2)
{
  vec3 middle = cm_beta[r1];
  cm_beta[r0] = 0.5 * (cm_beta[r0] + middle);
  cm_beta[r2] = 0.5 * (cm_beta[r2] + middle);
}

// The 27 spline coefficients from `first` in `pool` to the cell's Bernstein coefficients in
// cm_beta, along z, then y, then x (written out: no loop).
void cm_loadSpline(sampler3D pool, ivec3 first)
{
  cm_beta[0] = cm_splineRow(pool, first);
  cm_beta[1] = cm_splineRow(pool, first + ivec3(0, 1, 0));
  cm_beta[2] = cm_splineRow(pool, first + ivec3(0, 2, 0));
  cm_beta[3] = cm_splineRow(pool, first + ivec3(1, 0, 0));
  cm_beta[4] = cm_splineRow(pool, first + ivec3(1, 1, 0));
  cm_beta[5] = cm_splineRow(pool, first + ivec3(1, 2, 0));
  cm_beta[6] = cm_splineRow(pool, first + ivec3(2, 0, 0));
  cm_beta[7] = cm_splineRow(pool, first + ivec3(2, 1, 0));
  cm_beta[8] = cm_splineRow(pool, first + ivec3(2, 2, 0));
  cm_toBernstein(0, 1, 2);   // along y
  cm_toBernstein(3, 4, 5);
  cm_toBernstein(6, 7, 8);
  cm_toBernstein(0, 3, 6);   // along x
  cm_toBernstein(1, 4, 7);
  cm_toBernstein(2, 5, 8);
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
