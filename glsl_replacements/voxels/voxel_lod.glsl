// Level of detail (CM_LOD, with CM_MIP_LEVELS): the finest level a pixel's traversal
// descends to, from how large a pixel is against a voxel where its ray starts. A level-L
// cell is 2^L voxels wide; the level is the coarsest whose cells are no wider than a pixel
// there (voxels further along the ray are smaller still), shifted by cm_lodBias. The atlas's
// levels hold representative labels (models.voxels.representative_levels), so a filled cell
// at that level is drawn in its most frequent label.
uniform float cm_lodBias;     // added to log2(pixel / voxel) before rounding down
uniform float cm_voxelSize;   // the longest voxel edge, in view units

int cm_drawLevel = 0;         // set by the fragment before the traversal

// The level for a ray starting at view depth `depth` (cm_pixelRay's parameter).
int cm_lodLevel(float depth)
{
  mat4 p = cm_projection;
  // A pixel's widest side in view units: at depth 1 (perspective) or anywhere (parallel).
  float pixel = 2.0 / min(p[0][0] * cm_viewport.z, p[1][1] * cm_viewport.w);
  pixel *= p[3][3] == 0.0 ? max(depth, 0.0) : 1.0;
  float level = floor(log2(max(pixel / cm_voxelSize, 1e-30)) + cm_lodBias);
#ifdef CM_CHUNK_INDEX
  // A world's coarsest level is its chunk index, which holds slots, not labels.
  return int(clamp(level, 0.0, float(min(CM_MIP_LEVELS, CM_CHUNK_INDEX - 1))));
#else
  return int(clamp(level, 0.0, float(CM_MIP_LEVELS)));
#endif
}
