// Occupancy mipmaps of a material grid (CM_MIP_LEVELS = 1..n), in one texture with the
// labels (models.voxels.LevelAtlas) so a step reads any level with one fetch: level L holds,
// per cell of 2^L voxels per axis, whether any voxel under it is filled (any label, hidden or
// not: the levels never change with the palette). A coarse cell is empty only if every
// voxel under it is, so skipping it skips nothing drawn. The labels (level 0) sit at the
// origin; level L >= 1 at (nx - (nx >> (L - 1)) + L - 1, 0, nz), as
// models.voxels.level_x_offset computes it: a formula, no table indexed per step.

// The label of `voxel` (level 0), or whether its level-`level` cell holds a filled voxel
// (non-zero: yes).
int cm_levelLabel(ivec3 voxel, int level)
{
  ivec3 cell = voxel >> level;
  if (level > 0)
  {
    ivec3 dims = ivec3(cm_gridDims);
    cell += ivec3(dims.x - (dims.x >> (level - 1)) + level - 1, 0, dims.z);
  }
  return int(texelFetch(cm_labels, cell, 0).r * cm_labelScale + 0.5);
}
