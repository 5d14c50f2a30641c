// requires: voxel_declarations, paged_bricks
// A label grid streamed from a multiscale source (voxels/paged_labels.py): Amanatides & Woo
// traversal over the finest level's voxels, each voxel drawn with the label of the level its
// centre chooses (paged_bricks.glsl: the coarsest whose cells fit a pixel there), or of the
// nearest coarser resident one. Finest voxel i reads the level's cell round(i a + b) (its
// nearest point), so a coarse cell is a block of finest voxels, left or hit in one step; a
// brick holding nothing (its page entry: slot cm_poolSlots' count, no slot) is left whole.
// Coarse levels keep the most frequent non-empty label of each block (build_pyramid's
// 'mode'), so a coarse hit is a real label and a coarse empty cell has nothing under it.
// The pool holds rows of the per-label tables (float32, exact to 2^24), no apron.
// Same interface and tie rule as voxel_dda.glsl.

ivec4 cm_cachedBrick = ivec4(-1);   // the (level, brick) whose slot cm_cachedSlot holds
int cm_cachedSlot = -1;

int cm_pagedSlot(int level, vec3 brick)
{
  ivec4 key = ivec4(level, ivec3(brick));
  if (any(notEqual(key, cm_cachedBrick)))
  {
    cm_cachedBrick = key;
    cm_cachedSlot = cm_brickSlot(level, brick);
  }
  return cm_cachedSlot;
}

// The row of finest voxel `voxel` and the block of finest voxels [low, high) sharing it:
// its cell at the level read, or that level's whole brick when the brick holds nothing.
int cm_pagedLabel(ivec3 voxel, out ivec3 low, out ivec3 high)
{
  ivec3 dims = ivec3(cm_gridDims);
  vec3 finest = vec3(voxel);
  for (int level = cm_pagedLevelAtPoint(finest); level < CM_PAGED_LEVELS; ++level)
  {
    vec3 a = cm_levelTexel(level, 0).xyz;
    vec3 b = cm_levelTexel(level, 1).xyz;
    vec3 points = cm_levelTexel(level, 2).xyz;
    vec3 cell = floor(cm_levelPoint(finest, level) + 0.5);   // the nearest
    vec3 brick = floor(cell / cm_brickPoints);
    int slot = cm_pagedSlot(level, brick);
    if (slot < 0)
    {
      continue;   // not resident: the next coarser level
    }
    vec3 first = cell;
    vec3 last = cell;
    int label = 0;
    if (cm_slotIsEmpty(slot))   // nothing in this brick
    {
      first = brick * cm_brickPoints;
      last = min(first + cm_brickPoints - 1.0, points - 1.0);
    }
    else
    {
      int side = int(cm_brickPoints + 0.5);
      label = int(texelFetch(cm_pool, cm_slotOrigin(slot) * side
                                      + ivec3(cell - brick * cm_brickPoints),
                             0).r + 0.5);
    }
    // Finest voxels whose nearest cell lies in [first, last]; the first and last cells
    // reach the grid's sides.
    vec3 from = mix(ceil((first - 0.5 - b) / a), vec3(0.0), lessThan(first, vec3(0.5)));
    vec3 to = mix(ceil((last + 0.5 - b) / a), vec3(dims), greaterThan(last, points - 1.5));
    low = clamp(min(ivec3(from), voxel), ivec3(0), dims - 1);
    high = clamp(max(ivec3(to), voxel + 1), voxel + 1, dims);
    return label;
  }
  low = voxel;   // not reached: the coarsest level is resident
  high = voxel + 1;
  return 0;
}

int cm_label(ivec3 voxel)
{
  ivec3 low, high;
  return cm_pagedLabel(voxel, low, high);
}

int cm_voxelTraverse(vec3 a, vec3 d, float start, float end, out ivec3 voxel, inout int face,
                     out float t)
{
  ivec3 dims = ivec3(cm_gridDims);
  vec3 inverse, never, forward;
  cm_rayAxes(d, inverse, never, forward);
  ivec3 ahead = ivec3(forward);
  voxel = cm_startVoxel(a, d, inverse, never, forward, start, dims);
  t = start;
  int axis = -1;
  int count = dims.x + dims.y + dims.z + 3;   // each step leaves at least one voxel
  for (int i = 0; i < count; ++i)
  {
    ivec3 low, high;
    int label = cm_pagedLabel(voxel, low, high);
    if (label != 0 && cm_shown(label))
    {
      if (axis >= 0)
      {
        face = 2 * axis + ahead[axis];
      }
      return label;
    }
    ivec3 next;
    if (!cm_leaveBlock(a, d, inverse, never, forward, voxel, low, high, end, axis, t, next))
    {
      return 0;
    }
    voxel = next;
  }
  return 0;
}
