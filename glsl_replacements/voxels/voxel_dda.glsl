// Amanatides & Woo traversal of a material grid (002): from a to b (index space), voxel by
// voxel, to the first drawn voxel. Returns its material (0: none), the voxel, the face it was
// entered through (2 * axis + 1 when entered moving +axis, 2 * axis moving -axis; `face`
// comes in as the face a enters the first voxel through, -1 when a is inside it) and the
// fraction t of a..b where it is entered.
// Tie rule: one axis is stepped per iteration; when several axes cross a boundary at the same
// t, x steps before y before z (the CPU reference's rule). An axis the ray does not move along
// is never crossed: no division by zero (GLSL 1.50 promises no infinity).
int cm_voxelTraverse(vec3 a, vec3 b, out ivec3 voxel, inout int face, out float t)
{
  ivec3 dims = ivec3(cm_gridDims);
  vec3 d = b - a;
  vec3 moving = step(vec3(1e-30), abs(d));
  vec3 safe = mix(vec3(1.0), d, moving);
  ivec3 stepDir = ivec3(sign(d) * moving);
  voxel = clamp(ivec3(floor(a)), ivec3(0), dims - 1);
  vec3 boundary = vec3(voxel) + step(vec3(0.0), d) * moving;   // the next boundary per axis
  vec3 tMax = mix(vec3(1e30), (boundary - a) / safe, moving);
  t = 0.0;
  int count = dims.x + dims.y + dims.z + 3;   // no ray crosses more voxels than this
  for (int i = 0; i < count; ++i)
  {
#ifdef CM_MIP_LEVELS
    // Leave the coarsest empty cell around this voxel in one step (voxel_mip.glsl): its
    // exit is found like any crossing, from the cell's boundaries, and the traversal goes
    // on from the voxel just past it, its crossings computed afresh from that voxel.
    int level = cm_emptyLevel(voxel);
    if (level > 0)
    {
      ivec3 low = (voxel >> level) << level;
      ivec3 high = min(low + (1 << level), dims);
      vec3 exits = mix(vec3(1e30), (mix(vec3(low), vec3(high), step(vec3(0.0), d)) - a)
                                   / safe, moving);
      int axis = (exits.x <= exits.y && exits.x <= exits.z) ? 0
                 : (exits.y <= exits.z ? 1 : 2);
      t = exits[axis];
      if (t > 1.0)
      {
        return 0;
      }
      ivec3 inside = clamp(ivec3(floor(a + d * t)), low, high - 1);
      inside[axis] = stepDir[axis] > 0 ? high[axis] : low[axis] - 1;
      if (inside[axis] < 0 || inside[axis] >= dims[axis])
      {
        return 0;
      }
      voxel = inside;
      face = 2 * axis + (stepDir[axis] > 0 ? 1 : 0);
      boundary = vec3(voxel) + step(vec3(0.0), d) * moving;
      tMax = mix(vec3(1e30), (boundary - a) / safe, moving);
      continue;
    }
#endif
    int material = cm_visibleMaterial(voxel);
    if (material != 0)
    {
      return material;
    }
    int axis = (tMax.x <= tMax.y && tMax.x <= tMax.z) ? 0 : (tMax.y <= tMax.z ? 1 : 2);
    t = tMax[axis];
    if (t > 1.0)
    {
      return 0;
    }
    voxel[axis] += stepDir[axis];
    if (voxel[axis] < 0 || voxel[axis] >= dims[axis])
    {
      return 0;
    }
    tMax[axis] = ((float(voxel[axis]) + (stepDir[axis] > 0 ? 1.0 : 0.0)) - a[axis])
                 / safe[axis];   // from the voxel, never accumulated
    face = 2 * axis + (stepDir[axis] > 0 ? 1 : 0);
  }
  return 0;
}
