// requires: paged_bricks
// A multiscale volume read through a brick pool (paged_bricks.glsl): the data value at a
// texture position of the finest level (texel centres on its points), from the level its
// point chooses, or, where that level's brick is not resident yet, from the nearest coarser
// one that is (the coarsest level always is: never a hole). Each resident brick fills one
// slot of cm_pool with one point of its neighbours around it, so a trilinear read inside
// the slot is the level's own. Defines the cm_sampleScalar the marcher reads.
float cm_sampleScalar(vec3 texturePosition)
{
  vec3 finest = texturePosition * cm_levelTexel(0, 2).xyz - 0.5;
  for (int level = cm_pagedLevelAtPoint(finest); level < CM_PAGED_LEVELS; ++level)
  {
    vec3 points = cm_levelTexel(level, 2).xyz;
    vec3 point = clamp(finest * cm_levelTexel(level, 0).xyz + cm_levelTexel(level, 1).xyz,
                       vec3(0.0), points - 1.0);
    vec3 brick = min(floor(point / cm_brickPoints), ceil(points / cm_brickPoints) - 1.0);
    int slot = cm_brickSlot(level, brick);
    if (slot >= 0)
    {
      ivec3 slots = ivec3(cm_poolSlots + 0.5);
      ivec3 where = ivec3(slot % slots.x, (slot / slots.x) % slots.y, slot / (slots.x * slots.y));
      float side = cm_brickPoints + 2.0;
      vec3 texel = vec3(where) * side + 1.5 + (point - brick * cm_brickPoints);
      return texture(cm_pool, texel / (cm_poolSlots * side)).r;
    }
  }
  return 0.0;   // not reached: the coarsest level is resident
}

// The level a sample at `texturePosition` reads first, as cm_sampleScalar chooses it.
int cm_pagedLevelAt(vec3 texturePosition)
{
  return cm_pagedLevelAtPoint(texturePosition * cm_levelTexel(0, 2).xyz - 0.5);
}

// Where, past f0, the ray entry + (exit - entry) f next crosses a distance from the eye at
// which the chosen level changes (1 if nowhere before the exit). The distance is
// |A + B f| (world lengths), so each level's threshold is met at most twice.
float cm_pagedLevelEnd(vec3 entry, vec3 exit, float f0)
{
  if (!(cm_lodFootprint.x > 0.0))
  {
    return 1.0;   // parallel projection: one level along the whole ray
  }
  vec3 dims = cm_levelTexel(0, 2).xyz;
  vec3 a = cm_pagedWorldFromPoint * (entry * dims - 0.5 - cm_pagedEye);
  vec3 b = cm_pagedWorldFromPoint * ((exit - entry) * dims);
  float bb = dot(b, b);
  float ab = dot(a, b);
  float aa = dot(a, a);
  float end = 1.0;
  for (int level = 1; level < CM_PAGED_LEVELS; ++level)
  {
    float reach = (cm_levelTexel(level, 0).w - cm_lodFootprint.y) / cm_lodFootprint.x;
    float discriminant = ab * ab - bb * (aa - reach * reach);
    if (bb > 0.0 && discriminant > 0.0)
    {
      float root = sqrt(discriminant);
      float first = (-ab - root) / bb;
      float second = (-ab + root) / bb;
      end = first > f0 + 1e-6 ? min(end, first) : end;
      end = second > f0 + 1e-6 ? min(end, second) : end;
    }
  }
  return end;
}

// Points of level `level` a texture-space span crosses along its dominant axis.
float cm_pagedTexels(vec3 span, int level)
{
  vec3 points = abs(span * cm_levelTexel(0, 2).xyz * cm_levelTexel(level, 0).xyz);
  return max(points.x, max(points.y, points.z));
}
