// A world drawn by one traversal (CM_CHUNK_INDEX = log2 of the chunk edge; models/chunk_pool.py):
// cm_labels is a pool of slots, each a stored chunk's labels and occupancy levels (padded to
// a whole chunk), and cm_chunkIndex holds per chunk 0 (nothing drawn), -m (every voxel is
// label m) or s + 1 (stored in slot s). The index is the occupancy level of whole chunks,
// level CM_CHUNK_INDEX: an empty chunk is left in one step. Slot s starts at block
// (s % gx, (s / gx) % gy, s / (gx * gy)) of the pool, blocks of cm_slotShape texels.
uniform sampler3D cm_chunkIndex;  // per chunk, one float
uniform vec3 cm_slotGrid;         // slots along x, y, z of the pool
uniform vec3 cm_slotShape;        // texels of one slot

// The label of `voxel` (level 0), or whether its level-`level` cell holds a filled voxel
// (non-zero: yes), through the chunk index. Level-`level` cells never straddle chunks.
int cm_levelLabel(ivec3 voxel, int level)
{
  ivec3 chunk = voxel >> CM_CHUNK_INDEX;
  float entry = texelFetch(cm_chunkIndex, chunk, 0).r;
  if (entry < 0.5 || level >= CM_CHUNK_INDEX)
  {
    return int(abs(entry) + 0.5);   // 0, a uniform chunk's label, or non-zero: stored
  }
  int slot = int(entry - 0.5);
  ivec3 grid = ivec3(cm_slotGrid);
  ivec3 origin = ivec3(slot % grid.x, (slot / grid.x) % grid.y, slot / (grid.x * grid.y))
                 * ivec3(cm_slotShape);
  ivec3 cell = (voxel - (chunk << CM_CHUNK_INDEX)) >> level;
#ifdef CM_MIP_LEVELS
  if (level > 0)
  {
    int along = 1 << CM_CHUNK_INDEX;
    origin[CM_LEVEL_ROW_AXIS] += along - (along >> (level - 1)) + level - 1;
    origin[CM_LEVEL_SLAB_AXIS] += along;
  }
#endif
  return int(texelFetch(cm_labels, origin + cell, 0).r * cm_labelScale + 0.5);
}

int cm_label(ivec3 voxel)
{
  return cm_levelLabel(voxel, 0);
}
