// requires: camera_declarations, cube_faces, ea_declarations, ea_direct_declarations, ea_march, screen_ray
// Cube ray-marching pass (the cube map's pass 2): one ray per texel of the visible interior faces,
// from the eye (or the near plane) through the texel's point on the face, cut by the opaque
// depth found where that point projects on the screen (nearest sample). Target 0:
// premultiplied rgba; target 1: the cube depth map of the bilateral filter, the distance
// along the view axis where the ray stops (the nearer of the opaque depth and the face),
// defined as the resampling pass defines it for a pixel. Faces outside the mask stay empty.
uniform int cm_faceMask;           // bit i: interior face i faces the eye (visible-face mask)
uniform mat4 cm_viewFromTexture;   // volume texture coordinates to view

void main()
{
  gl_FragData[0] = vec4(0.0);
  gl_FragData[1] = vec4(0.0);
  vec2 atlasTexel = floor(texCoord * cm_atlasSize());
  vec2 tile = min(floor(atlasTexel / cm_tileSize()), vec2(2.0, 1.0));
  int face = int(tile.x) + 3 * int(tile.y);
  if (((cm_faceMask >> face) & 1) == 0)
  {
    return;
  }
  // Border texels repeat the nearest edge texel of the face.
  vec2 faceTexel = clamp(atlasTexel - cm_tileOrigin(face) - 1.0, 0.0, cm_faceSize - 1.0);
  vec3 point = cm_facePoint(face, (faceTexel + 0.5) / cm_faceSize);
  vec4 pointView = cm_viewFromTexture * vec4(point, 1.0);
  vec4 clip = cm_projection * pointView;
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
  if (cm_screenRay(ndc.xy, sceneDepth, entry, exit, entryView, exitView))
  {
    rgba = cm_march(entry, exit, cm_mediumLength(exit - entry));
  }
  gl_FragData[0] = rgba;
  float sceneDistance = -cm_viewPoint(ndc.xy, sceneDepth).z;
  gl_FragData[1] = vec4(min(sceneDistance, -pointView.z), 0.0, 0.0, 1.0);
}
