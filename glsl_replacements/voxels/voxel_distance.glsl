// The neighbour distance field (CM_DISTANCE_FIELD = its largest radius, 1..3): per
// voxel, the largest r whose cube of (2r + 1)^3 voxels around it is empty (any label counts
// as filled, hidden or not), so a ray in that voxel leaves the whole cube in one step.
uniform sampler3D cm_safeRadius;   // uint8, r as a normalised texel

int cm_emptyRadius(ivec3 voxel)
{
  return int(texelFetch(cm_safeRadius, voxel, 0).r * 255.0 + 0.5);
}
