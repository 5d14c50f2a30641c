// Occupancy mipmaps of a material grid (CM_MIP_LEVELS = 1..n), packed in one atlas so the
// traversal picks a level at run time: level L holds, per cell of 2^L voxels per axis,
// whether any voxel under it is filled (any label, hidden or not: the levels never change
// with the palette). A coarse cell is empty only if every voxel under it is, so skipping it
// skips nothing drawn. Level 1 sits at the atlas origin; level L >= 2 at
// (cm_levelColumn, cm_levelRows[L / 4][L % 4], 0).
uniform sampler3D cm_occupancy;
uniform float cm_levelColumn;
uniform mat4 cm_levelRows;

// Whether the level-`level` cell around `voxel` holds a filled voxel (level >= 1).
bool cm_cellOccupied(ivec3 voxel, int level)
{
  ivec3 cell = voxel >> level;
  if (level > 1)
  {
    cell += ivec3(int(cm_levelColumn), int(cm_levelRows[level / 4][level % 4]), 0);
  }
  return texelFetch(cm_occupancy, cell, 0).r > 0.0;
}
