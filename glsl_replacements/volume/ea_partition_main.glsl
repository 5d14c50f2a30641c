// requires: camera_declarations, ea_declarations, ea_march, slab, pixel_ray, screen_ray
// One partition of a volume split across workers (sort-last rendering). The rays are the
// whole volume's, stepped as the whole box steps them (from its entry, cm_stepScale texels of
// the dominant axis); this pass blends only the samples whose middles lie in its own part of
// the whole grid, so the partitions' images composited in visibility order are the whole
// render's. Which samples a partition owns is decided in the whole grid's texture frame,
// from the same uniforms in every partition: neighbours agree to the bit on a sample lying
// on their shared plane (coarse steps put many there), so none is lost or blended twice.
// The samples are then read in this partition's own frame; neighbours share their boundary
// points, so a sample near the boundary is interpolated from the same points as in the
// whole grid. Target 0: the blend mode's premultiplied rgba; with CM_KEEP_STATE (the
// projections) target 1: the ray's raw state, so the client keeps the slab holding the
// extreme. With CM_PIXEL_STOP (composite) and cm_pixelStops set, a second pass for the
// pixels whose whole ray stops inside this partition (drawn in a scissored window):
// cm_pixelStop holds each one's stop opacity (from the opacity the partitions in front
// leave), negative where nothing is redrawn.
uniform mat4 cm_wholeTextureFromView;  // the whole grid's texture coordinates from view
uniform vec3 cm_wholeDims;             // the whole grid's points along x, y, z
uniform vec3 cm_ownLo;                 // this partition's box of texel centres, in the
uniform vec3 cm_ownHi;                 // whole grid's texture coordinates
#ifdef CM_PIXEL_STOP
uniform int cm_pixelStops;             // 1: read each pixel's stop opacity from cm_pixelStop
uniform sampler2D cm_pixelStop;        // one texel per pixel of a window, rows bottom to top
uniform vec2 cm_pixelStopOrigin;       // the window's lower-left pixel
#endif

void main()
{
  vec4 state = cm_blendStart();
  vec4 rgba = vec4(0.0);
#ifdef CM_PIXEL_STOP
  cm_rayStopOpacity = cm_stopOpacity;
  if (cm_pixelStops == 1)
  {
    cm_rayStopOpacity = texelFetch(cm_pixelStop, ivec2(gl_FragCoord.xy - cm_pixelStopOrigin),
                                   0).r;
    if (cm_rayStopOpacity < 0.0)
    {
      gl_FragData[0] = rgba;
      return;
    }
  }
#endif
  vec3 originView, directionView;
  cm_pixelRay(texCoord * 2.0 - 1.0, originView, directionView);
  vec3 origin = (cm_wholeTextureFromView * vec4(originView, 1.0)).xyz;
  vec3 direction = mat3(cm_wholeTextureFromView) * directionView;
  vec2 inBox = cm_slab(origin, direction, 0.5 / cm_wholeDims, 1.0 - 0.5 / cm_wholeDims);
  float t0 = max(cm_viewDepthOf(0.0), inBox.x);
  float t1 = min(inBox.y, cm_viewDepthOf(1.0));
  if (t1 > t0)
  {
    vec3 span = (t1 - t0) * direction;
    float steps = max(cm_dominantTexels(span, cm_wholeDims) / cm_stepScale, 1e-6);
    // The steps (in step units from the entry) over which the ray is in this partition.
    vec2 own = cm_slab(origin + t0 * direction, span / steps, cm_ownLo, cm_ownHi);
    float count = ceil(steps);
    float last = count - 1.0;
    float lastMiddle = last + 0.5 * (steps - last);   // the last segment is cut at the exit
    float k0 = clamp(ceil(own.x - 0.5), 0.0, last);
    float k1 = clamp(ceil(own.y - 0.5), 0.0, last);
    if (lastMiddle >= own.x && lastMiddle < own.y)
    {
      k1 = count;
    }
    // The same ray, view depth t0 to t1, in this partition's texture frame.
    vec3 entry = (cm_textureFromView * vec4(originView + t0 * directionView, 1.0)).xyz;
    vec3 exit = (cm_textureFromView * vec4(originView + t1 * directionView, 1.0)).xyz;
    float mediumLength = cm_mediumLength(exit - entry);
    if (mediumLength > 0.0 && k1 > k0)
    {
#ifdef CM_SHADE
      cm_rayWorld = normalize(mat3(cm_worldFromTexture) * (exit - entry));
#endif
      vec3 stepVector = (exit - entry) / steps;
      float pieceSteps = k1 >= count ? steps - k0 : k1 - k0;
      vec3 a = entry + stepVector * k0;
      cm_marchPiece(state, a, a + stepVector * pieceSteps,
                    mediumLength * pieceSteps / steps, pieceSteps);
      rgba = cm_blendResult(state);
    }
  }
  gl_FragData[0] = rgba;
#ifdef CM_KEEP_STATE
  gl_FragData[1] = state;
#endif
}
