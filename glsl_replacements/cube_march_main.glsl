// Cube ray-marching pass (000 pass 2): one ray per texel of the visible interior faces,
// from the eye (or the near plane) through the texel's point on the face, cut by the opaque
// depth found where that point projects on the screen (nearest sample). Target 0:
// premultiplied rgba; target 1: view distance where the ray stopped (the cube depth map of
// the bilateral filter). Texels of faces outside the mask are left empty.
uniform int cm_faceMask;   // bit i: interior face i faces the eye (equation 1)

void main()
{
  gl_FragData[0] = vec4(0.0);
  gl_FragData[1] = vec4(0.0);
  vec2 atlas = texCoord * vec2(3.0, 2.0);
  vec2 tile = min(floor(atlas), vec2(2.0, 1.0));
  int face = int(tile.x) + 3 * int(tile.y);
  if (((cm_faceMask >> face) & 1) == 0)
  {
    return;
  }
  vec3 point = cm_facePoint(face, atlas - tile);
  vec4 clip = cm_projection * (inverse(cm_textureFromView) * vec4(point, 1.0));
  if (!(clip.w > 0.0))
  {
    return;   // behind the eye: no pixel shows this texel
  }
  vec3 ndc = clip.xyz / clip.w;
  float backDepth = ndc.z * 0.5 + 0.5;
  if (!(backDepth > 0.0))
  {
    return;   // in front of the near plane
  }
  vec2 pixel = ndc.xy * 0.5 + 0.5;
  bool onScreen = all(greaterThanEqual(pixel, vec2(0.0))) && all(lessThanEqual(pixel, vec2(1.0)));
  float sceneDepth = onScreen ? cm_sceneDepthAt(pixel) : 1.0;
  vec3 entry, exit, entryView, exitView;
  vec4 rgba = vec4(0.0);
  if (cm_screenRay(ndc.xy, min(backDepth, 1.0), sceneDepth, entry, exit, entryView, exitView))
  {
    rgba = cm_march(entry, exit, length(mat3(cm_worldFromTexture) * (exit - entry)));
  }
  gl_FragData[0] = rgba;
  gl_FragData[1] = vec4(-exitView.z, 0.0, 0.0, 1.0);
}
