// requires: voxel_declarations
// Amanatides & Woo traversal of a material grid: along the ray a + d t (index space) from
// t = start to t = end, to the first drawn voxel. Returns its material (0: none), the voxel,
// the face it was entered through (2 * axis + 1 when entered moving +axis, 2 * axis moving
// -axis; `face` comes in as the face the ray enters its first voxel through, -1 when it
// starts inside it) and the t where it is entered.
// Each step leaves one empty block [low, high) of voxels: the voxel itself, a whole empty
// cell of an occupancy level (CM_MIP_LEVELS: the level descends on an occupied cell and
// climbs back when the ray leaves its parent cell), or the empty cube around the voxel
// (CM_DISTANCE_FIELD). The block's exit is found like any crossing, from its boundaries, and
// the traversal goes on from the voxel just past it: skipping empty blocks changes no hit.
// Tie rule: when several axes cross a boundary at the same t, x steps before y before z (the
// CPU reference's rule). An axis the ray does not move along is never crossed: no division
// by zero (GLSL 1.50 promises no infinity).
// Cost: llvmpipe runs a loop's body whole for 8 pixels at once, both sides of every branch
// included, so a step reads one texture once (the labels, or the level atlas holding them);
// the palette is read in the outer loop, once per filled voxel met, never per step.
#if defined(CM_LOD) && defined(CM_MIP_LEVELS)
#define CM_FINEST cm_drawLevel
#else
#define CM_FINEST 0
#endif

#ifdef CM_WHOLE_GRID
// Outside the brick [base, top) of the whole grid: the block [low, high) holding `voxel`
// on the far side of the first of the brick's planes it lies past (empty here, and left in
// one step); false inside the brick, `low` and `high` left as they came.
bool cm_outsideBrick(ivec3 voxel, ivec3 base, ivec3 top, ivec3 dims, inout ivec3 low,
                     inout ivec3 high)
{
  for (int j = 0; j < 3; ++j)
  {
    if (voxel[j] < base[j] || voxel[j] >= top[j])
    {
      low = ivec3(0);
      high = dims;
      low[j] = voxel[j] < base[j] ? 0 : top[j];
      high[j] = voxel[j] < base[j] ? base[j] : dims[j];
      return true;
    }
  }
  return false;
}
#endif

int cm_voxelTraverse(vec3 a, vec3 d, float start, float end, out ivec3 voxel, inout int face,
                     out float t)
{
  ivec3 dims = ivec3(CM_TRAVERSED_DIMS);
  vec3 inverse, never, forward;
  cm_rayAxes(d, inverse, never, forward);
  ivec3 ahead = ivec3(forward);
  voxel = cm_startVoxel(a, d, inverse, never, forward, start, dims);
  t = start;
#ifdef CM_WHOLE_GRID
  ivec3 base = ivec3(cm_brickOrigin);   // voxels are the whole grid's; textures the brick's
#else
  ivec3 base = ivec3(0);
#endif
  ivec3 top = base + ivec3(cm_gridDims);
  int axis = -1;   // the axis of the last move (none yet: `face` stays as it came)
  bool passing = false;   // the current voxel is filled but hidden: step through it
#ifdef CM_MIP_LEVELS
  // The first voxel is read before any level (a ray into a dense grid hits at once); when
  // it is empty the ray starts from the coarsest level and descends. With level of detail
  // (CM_LOD) the traversal never descends below cm_drawLevel: a filled cell there is a hit,
  // drawn with its representative label (voxel_lod.glsl).
  int level = CM_FINEST;
  bool first = true;
  // A move either leaves a block or descends a level; a level is climbed only after a
  // move, so descents number at most the moves plus the levels.
  int count = 2 * (dims.x + dims.y + dims.z + 3) + CM_MIP_LEVELS + 1;
#else
  int count = dims.x + dims.y + dims.z + 3;   // no ray crosses more voxels than this
#endif
  int i = 0;
  while (i < count)   // once per filled voxel met
  {
    int label = 0;
    for (; i < count; ++i)   // up to the next filled voxel (or out of the grid)
    {
      ivec3 low = voxel;
      ivec3 high = voxel + 1;
      ivec3 cell = voxel - base;   // in the grid's own textures
#ifdef CM_WHOLE_GRID
      if (cm_outsideBrick(voxel, base, top, dims, low, high))
      {
        label = 0;
      }
      else
#endif
      {
#ifdef CM_MIP_LEVELS
        label = cm_levelLabel(cell, level);
        if (label != 0 && !passing)   // a filled voxel, or a coarse cell with one under it
        {
          if (level <= CM_FINEST)
          {
            break;
          }
          --level;
          continue;
        }
        if (first && !passing)
        {
          first = false;
          level = CM_MIP_LEVELS;
#ifdef CM_SHELL_LEVEL
          // From the brick shell the ray is next to a filled brick: its coarse cells are
          // filled, so it starts below the bricks' level and climbs as it leaves them.
          if (cm_startAtProxy > 0.5)
          {
            level = max(min(CM_MIP_LEVELS, CM_SHELL_LEVEL - 1), CM_FINEST);
          }
#endif
          continue;
        }
        first = false;
        if (level > 0)
        {
          low = ((cell >> level) << level) + base;
          high = min(low + (1 << level), top);
        }
#else
        label = cm_label(cell);
        if (label != 0 && !passing)
        {
          break;
        }
#endif
#ifdef CM_DISTANCE_FIELD
#ifdef CM_MIP_LEVELS
        if (level == 0)
#endif
        {
          int radius = cm_emptyRadius(cell);
          low = max(voxel - radius, base);
          high = min(voxel + radius + 1, top);
        }
#endif
      }
      passing = false;
      ivec3 next;
      if (!cm_leaveBlock(a, d, inverse, never, forward, voxel, low, high, end, axis, t,
                         next))
      {
        return 0;
      }
#ifdef CM_MIP_LEVELS
      if (level < CM_MIP_LEVELS
          && any(notEqual((next - base) >> (level + 1), cell >> (level + 1))))
      {
        ++level;   // left the parent cell: its neighbour may be empty at the coarser level
      }
#endif
      voxel = next;
    }
    if (i >= count)
    {
      return 0;
    }
    if (cm_shown(label))
    {
      if (axis >= 0)
      {
        face = 2 * axis + ahead[axis];
      }
      return label;
    }
#ifdef CM_LOD
    if (level > 0)   // a coarse cell whose representative is hidden: look under it
    {
      --level;
      first = false;   // not back up to the top on an empty sub-cell: it is under this one
      continue;
    }
#endif
    passing = true;
  }
  return 0;
}
