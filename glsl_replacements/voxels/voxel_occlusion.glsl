// requires: voxel_declarations
// Ambient occlusion of a voxel hit (CM_OCCLUSION): per-vertex voxel AO, the CPU reference's
// formula (pv_cubemarch.reference.voxels.occlusion_factor). The layer is the voxel on the
// viewer's side of the entered face (face 2 * axis + 1, entered moving +axis: voxel - e_axis;
// face 2 * axis: voxel + e_axis); u = (axis + 1) % 3 and v = (axis + 2) % 3 span the face.
// Corner (du, dv) of the face (each -1 or +1) sees side1 = layer + du e_u, side2 = layer +
// dv e_v and corner = layer + du e_u + dv e_v: level 3 when both sides are drawn, else
// side1 + side2 + corner. The hit's level is the bilinear mix of the 4 corners' at its
// place on the face; the factor is 1 - cm_occlusionStrength * level / 3. Drawn: as the
// traversal sees it (cm_visibleMaterial); voxels outside the grid are empty.
uniform float cm_occlusionStrength;   // 0..1: the factor at a fully occluded corner is 1 - it

// 1.0 if `voxel` is inside the grid and drawn, else 0.0.
float cm_occupied(ivec3 voxel)
{
  if (any(lessThan(voxel, ivec3(0))) || any(greaterThanEqual(voxel, ivec3(cm_gridDims))))
  {
    return 0.0;
  }
  return cm_visibleMaterial(voxel) != 0 ? 1.0 : 0.0;
}

// The level (0..3) of the face's corner (du, dv).
float cm_cornerOcclusion(ivec3 layer, ivec3 du, ivec3 dv)
{
  float side1 = cm_occupied(layer + du);
  float side2 = cm_occupied(layer + dv);
  float corner = cm_occupied(layer + du + dv);
  return (side1 > 0.5 && side2 > 0.5) ? 3.0 : side1 + side2 + corner;
}

// The factor (1 - strength .. 1) of the hit on `voxel` entered through `face` at the
// index-space `point`; 1 when the ray starts inside the voxel (face -1).
float cm_voxelOcclusion(ivec3 voxel, int face, vec3 point)
{
  if (face < 0)
  {
    return 1.0;
  }
  int axis = face / 2;
  int u = (axis + 1) % 3;
  int v = (axis + 2) % 3;
  ivec3 layer = voxel;
  layer[axis] += (face % 2 == 1) ? -1 : 1;
  ivec3 eu = ivec3(0);
  ivec3 ev = ivec3(0);
  eu[u] = 1;
  ev[v] = 1;
  float s = clamp(point[u] - float(voxel[u]), 0.0, 1.0);
  float r = clamp(point[v] - float(voxel[v]), 0.0, 1.0);
  float low = mix(cm_cornerOcclusion(layer, -eu, -ev), cm_cornerOcclusion(layer, eu, -ev), s);
  float high = mix(cm_cornerOcclusion(layer, -eu, ev), cm_cornerOcclusion(layer, eu, ev), s);
  float level = mix(low, high, r);   // bilinear: corner (-1, -1) at (s, r) = (0, 0)
  return 1.0 - cm_occlusionStrength * level / 3.0;
}
