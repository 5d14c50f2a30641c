// Occupancy mipmaps of a material grid (CM_MIP_LEVELS = 1..n), in one texture with the
// labels (models.voxels.LevelAtlas) so a step reads any level with one fetch: level L holds,
// per cell of 2^L voxels per axis, whether any voxel under it is filled (any label, hidden or
// not: the levels never change with the palette). A coarse cell is empty only if every
// voxel under it is, so skipping it skips nothing drawn. The labels (level 0) sit at the
// origin; level L >= 1 past them along CM_LEVEL_SLAB_AXIS, at n - (n >> (L - 1)) + L - 1
// along CM_LEVEL_ROW_AXIS (n: the grid's size there), as models.voxels.level_origin
// computes it: a formula, no table indexed per step.

// The label of `voxel` (level 0), or whether its level-`level` cell holds a filled voxel
// (non-zero: yes).
#ifndef CM_CHUNK_INDEX   // a world's levels: through its chunk index
int cm_levelLabel(ivec3 voxel, int level)
{
  ivec3 cell = voxel >> level;
  if (level > 0)
  {
    ivec3 dims = ivec3(cm_gridDims);
    int along = dims[CM_LEVEL_ROW_AXIS];
    ivec3 origin = ivec3(0);
    origin[CM_LEVEL_ROW_AXIS] = along - (along >> (level - 1)) + level - 1;
    origin[CM_LEVEL_SLAB_AXIS] = dims[CM_LEVEL_SLAB_AXIS];
    cell += origin;
  }
  return int(texelFetch(cm_labels, cell, 0).r * cm_labelScale + 0.5);
}
#endif
