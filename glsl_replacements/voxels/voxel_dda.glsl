// The t (fraction of a..b) where the ray crosses each axis's forward boundary of the block
// [low, high); 1e30 on an axis it does not move along.
vec3 cm_blockExits(vec3 a, vec3 inverse, vec3 moving, vec3 forward, ivec3 low, ivec3 high)
{
  return mix(vec3(1e30), (mix(vec3(low), vec3(high), forward) - a) * inverse, moving);
}

// Amanatides & Woo traversal of a material grid (002): from a to b (index space) to the first
// drawn voxel. Returns its material (0: none), the voxel, the face it was entered through
// (2 * axis + 1 when entered moving +axis, 2 * axis moving -axis; `face` comes in as the
// face a enters the first voxel through, -1 when a is inside it) and the fraction t of a..b
// where it is entered.
// Each iteration leaves one empty block [low, high) of voxels: the voxel itself, a whole
// empty cell of an occupancy level (CM_MIP_LEVELS: the level descends on an occupied cell and
// climbs back when the ray leaves its parent cell), or the empty cube around the voxel
// (CM_DISTANCE_FIELD). The block's exit is found like any crossing, from its boundaries, and
// the traversal goes on from the voxel just past it: skipping empty blocks changes no hit.
// Tie rule: when several axes cross a boundary at the same t, x steps before y before z (the
// CPU reference's rule). An axis the ray does not move along is never crossed: no division
// by zero (GLSL 1.50 promises no infinity).
int cm_voxelTraverse(vec3 a, vec3 b, out ivec3 voxel, inout int face, out float t)
{
  ivec3 dims = ivec3(cm_gridDims);
  vec3 d = b - a;
  vec3 moving = step(vec3(1e-30), abs(d));
  vec3 inverse = 1.0 / mix(vec3(1.0), d, moving);   // as the CPU reference: t = (x - a) / d
  vec3 forward = step(vec3(0.0), d);
  voxel = clamp(ivec3(floor(a)), ivec3(0), dims - 1);
  vec3 tMax = cm_blockExits(a, inverse, moving, forward, voxel, voxel + 1);   // this voxel's
  bool fresh = true;   // tMax is the current voxel's (after a block it is made when needed)
  t = 0.0;
#ifdef CM_MIP_LEVELS
  // The first voxel is read before any level (a ray into a dense grid hits at once); when
  // it is empty the ray starts from the coarsest level and descends.
  int level = 0;
  bool first = true;
  // A move either leaves a block or descends a level; a level is climbed only after a move.
  int count = 2 * (dims.x + dims.y + dims.z + 3) + CM_MIP_LEVELS + 1;
#else
  int count = dims.x + dims.y + dims.z + 3;   // no ray crosses more voxels than this
#endif
  for (int i = 0; i < count; ++i)
  {
    ivec3 low = voxel;
    ivec3 high = voxel + 1;
    bool block = false;   // leaving more than this voxel
#ifdef CM_MIP_LEVELS
    if (level > 0)
    {
      if (cm_cellOccupied(voxel, level))
      {
        --level;
        continue;
      }
      low = (voxel >> level) << level;
      high = min(low + (1 << level), dims);
      block = true;
    }
    else
#endif
    {
      int material = cm_visibleMaterial(voxel);
      if (material != 0)
      {
        return material;
      }
#ifdef CM_MIP_LEVELS
      if (first)
      {
        first = false;
        level = CM_MIP_LEVELS;
        continue;
      }
#endif
#ifdef CM_DISTANCE_FIELD
      int radius = cm_emptyRadius(voxel);
      if (radius > 0)
      {
        low = max(voxel - radius, ivec3(0));
        high = min(voxel + radius + 1, dims);
        block = true;
      }
#endif
    }
    vec3 exits;
    if (block)
    {
      exits = cm_blockExits(a, inverse, moving, forward, low, high);
    }
    else
    {
      if (!fresh)
      {
        tMax = cm_blockExits(a, inverse, moving, forward, voxel, voxel + 1);
        fresh = true;
      }
      exits = tMax;
    }
    int axis = (exits.x <= exits.y && exits.x <= exits.z) ? 0 : (exits.y <= exits.z ? 1 : 2);
    ivec3 onAxis = ivec3(equal(ivec3(axis), ivec3(0, 1, 2)));   // no dynamic indexing below
    t = min(exits.x, min(exits.y, exits.z));
    if (t > 1.0)
    {
      return 0;
    }
    // The voxel past the exit: from one voxel, a step along the exit axis; from a block,
    // the other axes are read at the exit point (kept inside the block's span).
    ivec3 next = block ? clamp(ivec3(floor(a + d * t)), low, high - 1) : voxel;
    ivec3 past = low - 1 + (high - low + 1) * ivec3(forward);   // per axis, once past it
    next += (past - next) * onAxis;
    if (any(lessThan(next, ivec3(0))) || any(greaterThanEqual(next, dims)))
    {
      return 0;
    }
#ifdef CM_MIP_LEVELS
    if (level < CM_MIP_LEVELS && any(notEqual(next >> (level + 1), voxel >> (level + 1))))
    {
      ++level;   // left the parent cell: its neighbour may be empty at the coarser level
    }
#endif
    if (block)
    {
      fresh = false;
    }
    else
    {
      tMax = mix(tMax, (vec3(next) + forward - a) * inverse, vec3(onAxis));   // never summed
    }
    voxel = next;
    face = 2 * axis + (dot(vec3(onAxis), forward) > 0.5 ? 1 : 0);
  }
  return 0;
}
