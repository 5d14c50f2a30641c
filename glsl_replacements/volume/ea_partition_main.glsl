// requires: camera_declarations, ea_declarations, ea_march, screen_ray
// One partition of a volume split across workers (sort-last rendering). The rays are the
// whole volume's, stepped as the whole box steps them (from its entry, cm_stepScale texels of
// the dominant axis); this pass blends only the samples whose middles lie in its own box of
// texel centres, so the partitions' images composited in visibility order are the whole
// render's. Neighbouring partitions share their boundary points: a sample near the boundary
// is interpolated from the same points as in the whole grid. Target 0: the blend mode's
// premultiplied rgba; target 1: the ray's raw state (the projections' kept value), so the
// client keeps the partition holding the ray's extreme.
uniform vec3 cm_wholeLo;   // the whole grid's box of texel centres, in this partition's
uniform vec3 cm_wholeHi;   // texture coordinates

void main()
{
  vec3 entry, exit, entryView, exitView;
  vec4 state = cm_blendStart();
  vec4 rgba = vec4(0.0);
  if (cm_screenRayBox(texCoord * 2.0 - 1.0, 1.0, cm_wholeLo, cm_wholeHi, entry, exit,
                      entryView, exitView))
  {
    vec3 span = exit - entry;
    float mediumLength = cm_mediumLength(span);
    float steps = max(cm_dominantTexels(span, cm_dims) / cm_stepScale, 1e-6);
    vec3 stepVector = span / steps;
    // The steps (in step units from the entry) over which the ray is inside this partition.
    vec2 own = cm_slab(entry, stepVector, 0.5 / cm_dims, 1.0 - 0.5 / cm_dims);
    float count = ceil(steps);
    float last = count - 1.0;
    float lastMiddle = last + 0.5 * (steps - last);   // the last segment is cut at the exit
    float k0 = clamp(ceil(own.x - 0.5), 0.0, last);
    float k1 = clamp(ceil(own.y - 0.5), 0.0, last);
    if (lastMiddle >= own.x && lastMiddle < own.y)
    {
      k1 = count;
    }
    if (mediumLength > 0.0 && k1 > k0)
    {
#ifdef CM_SHADE
      cm_rayWorld = normalize(mat3(cm_worldFromTexture) * span);
#endif
      float pieceSteps = k1 >= count ? steps - k0 : k1 - k0;
      vec3 a = entry + stepVector * k0;
      cm_marchPiece(state, a, a + stepVector * pieceSteps,
                    mediumLength * pieceSteps / steps, pieceSteps);
      rgba = cm_blendResult(state);
    }
  }
  gl_FragData[0] = rgba;
  gl_FragData[1] = state;
}
