// Occupancy mipmaps of a material grid (CM_MIP_LEVELS = 1..3): level L holds, per cell of
// 2^L voxels per axis, whether any voxel under it is filled (any label, hidden or not: the
// levels never change with the palette). A coarse cell is empty only if every voxel under
// it is, so skipping it skips nothing drawn.
uniform sampler3D cm_occupancy1;
#if CM_MIP_LEVELS > 1
uniform sampler3D cm_occupancy2;
#endif
#if CM_MIP_LEVELS > 2
uniform sampler3D cm_occupancy3;
#endif

// The coarsest level (0 if none) whose cell around `voxel` is empty.
int cm_emptyLevel(ivec3 voxel)
{
  if (texelFetch(cm_occupancy1, voxel >> 1, 0).r > 0.0)
  {
    return 0;
  }
#if CM_MIP_LEVELS > 1
  if (texelFetch(cm_occupancy2, voxel >> 2, 0).r > 0.0)
  {
    return 1;
  }
#endif
#if CM_MIP_LEVELS > 2
  if (texelFetch(cm_occupancy3, voxel >> 3, 0).r > 0.0)
  {
    return 2;
  }
#endif
  return CM_MIP_LEVELS;
}
