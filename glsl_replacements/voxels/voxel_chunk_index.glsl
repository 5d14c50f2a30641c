// A world drawn by one traversal (CM_CHUNK_INDEX = log2 of the chunk edge; models/chunk_pool.py):
// cm_labels is a pool of slots, each a stored chunk's labels and occupancy levels (padded to
// a whole chunk), and cm_chunkIndex holds per chunk (x, y, z, kind): kind 0 (nothing
// drawn), -m (every voxel is label m) or 1 (stored, its slot starting at pool texel x, y,
// z). The index is the occupancy level of whole chunks, level CM_CHUNK_INDEX: an empty
// chunk is left in one step. A ray stays in a chunk for many steps: the chunk's entry is
// read once, when the ray enters it (llvmpipe skips a branch no pixel of its 8 takes).
uniform sampler3D cm_chunkIndex;  // per chunk, RGBA float

ivec3 cm_indexedChunk = ivec3(-1);   // the chunk whose entry cm_chunkEntry holds
vec4 cm_chunkEntry = vec4(0.0);

// The label of `voxel` (level 0), or whether its level-`level` cell holds a filled voxel
// (non-zero: yes), through the chunk index. Level-`level` cells never straddle chunks.
int cm_levelLabel(ivec3 voxel, int level)
{
  ivec3 chunk = voxel >> CM_CHUNK_INDEX;
  if (any(notEqual(chunk, cm_indexedChunk)))
  {
    cm_indexedChunk = chunk;
    cm_chunkEntry = texelFetch(cm_chunkIndex, chunk, 0);
  }
  float kind = cm_chunkEntry.a;
  if (kind < 0.5 || level >= CM_CHUNK_INDEX)
  {
    return int(abs(kind) + 0.5);   // 0, a uniform chunk's label, or 1: stored
  }
  ivec3 origin = ivec3(cm_chunkEntry.xyz);
  ivec3 cell = (voxel & ((1 << CM_CHUNK_INDEX) - 1)) >> level;
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
