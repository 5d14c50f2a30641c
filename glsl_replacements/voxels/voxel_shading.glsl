// Lighting of a voxel hit (CM_LIGHTING; common/blinn_phong.glsl): the entered face's normal.
vec3 cm_shadeVoxel(vec3 color, int face, vec3 pointView, vec3 towardEye)
{
  vec3 normal = towardEye;   // a ray that starts inside its voxel: the face toward the eye
  if (face >= 0)
  {
    vec3 normalIndex = vec3(0.0);
    normalIndex[face / 2] = (face - 2 * (face / 2)) == 1 ? -1.0 : 1.0;
    normal = normalize(cm_normalFromIndex * normalIndex);
  }
  return cm_shade(color, normal, pointView, towardEye);
}
