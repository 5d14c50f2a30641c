// Lighting of a voxel hit (CM_LIGHTING; common/blinn_phong.glsl): the entered face's normal.
// The entered face's view-space normal (a ray that starts inside its voxel: toward the eye).
vec3 cm_voxelFaceNormal(int face, vec3 towardEye)
{
  if (face < 0)
  {
    return towardEye;
  }
  vec3 normalIndex = vec3(0.0);
  normalIndex[face / 2] = (face - 2 * (face / 2)) == 1 ? -1.0 : 1.0;
  return normalize(cm_normalFromIndex * normalIndex);
}

vec3 cm_shadeVoxel(vec3 color, int face, vec3 pointView, vec3 towardEye)
{
  return cm_shade(color, cm_voxelFaceNormal(face, towardEye), pointView, towardEye);
}
