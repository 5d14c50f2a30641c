// Lighting of a voxel hit (CM_LIGHTING; common/blinn_phong.glsl): the entered face's normal.
#ifdef CM_CLIP_PLANES
// Where the hit is a clip plane's cut (set by the fragment before shading it, else 0): the
// plane's index-space normal (cm_clipNormalAt).
vec3 cm_cutNormal = vec3(0.0);
#endif

// The entered face's view-space normal; a ray that starts inside its voxel: a cut's plane,
// else toward the eye.
vec3 cm_voxelFaceNormal(int face, vec3 towardEye)
{
  if (face < 0)
  {
#ifdef CM_CLIP_PLANES
    if (cm_cutNormal != vec3(0.0))
    {
      vec3 normal = normalize(cm_normalFromIndex * cm_cutNormal);
      return dot(normal, towardEye) < 0.0 ? -normal : normal;
    }
#endif
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
