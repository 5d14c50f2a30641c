// requires: surface_bricks
// One traversal per pixel through the active cells (traversal 'index', instead of a box per
// cell): Amanatides & Woo from a to b (cell space) over three levels, blocks of
// CM_BLOCK_SIZE cells, bricks of CM_BRICK_SIZE cells, and cells. A block or brick with no
// active cell is left in one step; in a stored brick the ray steps cell by cell, and each
// active cell it meets is loaded and marched from where the ray enters it to where it
// leaves (cm_marchCell, or cm_exactRoot), in the order the ray meets them: the first root
// found is the nearest, and the traversal stops there. Returns the fraction of a..b at the
// hit (-1: none) and the hit's cell (and in cm_rootPast the fraction just past the root).
// As voxel_dda.glsl: each step leaves a block [low, high) through its nearest boundary, x
// before y before z on a tie; an axis the ray does not move along is never crossed. The
// cheap stepping runs in the inner loop; the march (the costly part: llvmpipe runs a
// branch for 8 pixels when any of them takes it) in the outer one, once per active cell.
vec3 cm_rayStart;     // a
vec3 cm_rayInverse;   // 1 / (b - a) on the axes the ray moves along, else 0
vec3 cm_rayNever;     // 1e30 on the axes it does not move along, else 0
vec3 cm_rayForward;   // 1 on the axes it moves up, else 0

// The fraction of a..b where the ray leaves the block of cells [low, high), and the axis.
float cm_leaveBlock(ivec3 low, ivec3 high, out int axis)
{
  vec3 exits = (mix(vec3(low), vec3(high), cm_rayForward) - cm_rayStart) * cm_rayInverse
               + cm_rayNever;
  axis = (exits.x <= exits.y && exits.x <= exits.z) ? 0 : (exits.y <= exits.z ? 1 : 2);
  return min(exits.x, min(exits.y, exits.z));
}

float cm_traverse(vec3 a, vec3 b, out ivec3 cell)
{
  ivec3 dims = ivec3(cm_gridDims);
  vec3 d = b - a;
  vec3 moving = step(vec3(1e-30), abs(d));
  cm_rayStart = a;
  cm_rayInverse = moving / mix(vec3(1.0), d, moving);
  cm_rayNever = 1e30 * (1.0 - moving);
  cm_rayForward = step(vec3(0.0), d);
  ivec3 ahead = ivec3(cm_rayForward);
  cell = clamp(ivec3(floor(a)), ivec3(0), dims - 1);
  float entry = 0.0;      // where the ray entered `cell` (or its block)
  int level = 2;          // 2: blocks, 1: bricks of an occupied block, 0: cells of a brick
  bool passing = false;   // the current cell was marched: step out of it
  // Moves number at most the cells, bricks and blocks crossed, descents the bricks and
  // blocks.
  int count = 3 * (dims.x + dims.y + dims.z + 3);
  int i = 0;
  while (i < count)   // once per active cell met
  {
    for (; i < count; ++i)   // up to the next active cell (or out of a..b)
    {
      ivec3 low = cell;
      ivec3 high = cell + 1;
      if (level == 2)
      {
        if (cm_blockOccupied(cell >> CM_BLOCK_SHIFT))
        {
          level = 1;   // look at its bricks, from this cell's
          continue;
        }
        low = (cell >> CM_BLOCK_SHIFT) << CM_BLOCK_SHIFT;
        high = min(low + CM_BLOCK_SIZE, dims);
      }
      else if (level == 1)
      {
        if (cm_brickStored(cell >> CM_BRICK_SHIFT))
        {
          level = 0;   // look at its cells, from this one
          continue;
        }
        low = (cell >> CM_BRICK_SHIFT) << CM_BRICK_SHIFT;
        high = min(low + CM_BRICK_SIZE, dims);
      }
      else if (!passing && cm_cellActive(cell))
      {
        break;
      }
      passing = false;
      int axis;
      float exit = cm_leaveBlock(low, high, axis);
      if (exit >= 1.0)
      {
        return -1.0;
      }
      // The cell just past the exit: on the exit axis the first beyond the block, on the
      // others the exit point's (kept inside the block's span).
      ivec3 onAxis = ivec3(equal(ivec3(axis), ivec3(0, 1, 2)));
      ivec3 next = clamp(ivec3(floor(a + d * exit)), low, high - 1);
      ivec3 past = low - 1 + (high - low + 1) * ahead;
      next += (past - next) * onAxis;
      if (any(lessThan(next, ivec3(0))) || any(greaterThanEqual(next, dims)))
      {
        return -1.0;
      }
      if (any(notEqual(next >> CM_BLOCK_SHIFT, cell >> CM_BLOCK_SHIFT)))
      {
        level = 2;   // into another block: is it occupied?
      }
      else if (level == 0 && any(notEqual(next >> CM_BRICK_SHIFT, cell >> CM_BRICK_SHIFT)))
      {
        level = 1;   // into another brick of this block
      }
      cell = next;
      entry = exit;
    }
    if (i >= count)
    {
      return -1.0;
    }
    int axis;
    float exit = min(cm_leaveBlock(cell, cell + 1, axis), 1.0);
    cm_loadCellAt(cell);
    vec3 corner = vec3(cell);
    // Marched 1e-4 cell past both faces (the polynomial extends smoothly past the cell): a
    // root on a face may round to the outside in both cells' samples (seen: pinholes in a
    // surface lying on the faces between cells, 31 of 3,335 pixels).
    float pad = 1e-4 / max(length(d), 1e-30);
    float from = max(entry - pad, 0.0);
    float to = min(exit + pad, 1.0);
    vec3 cellA = a + d * from - corner;
    vec3 cellB = a + d * to - corner;
#ifdef CM_EXACT_ROOT
    float s = cm_exactRoot(cellA, cellB);
#else
    float s = cm_marchCell(cellA, cellB);
#endif
    if (s >= 0.0)
    {
      cm_rootPast = mix(from, to, cm_rootPast);   // as a fraction of a..b
      return mix(from, to, s);
    }
    passing = true;
  }
  return -1.0;
}
