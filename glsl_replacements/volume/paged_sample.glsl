// requires: paged_bricks
// A multiscale volume read through a brick pool (paged_bricks.glsl): the data value at a
// texture position of the finest level (texel centres on its points), from the level its
// point chooses, or, where that level's brick is not resident yet, from the nearest coarser
// one that is (the coarsest level always is: never a hole). Each resident brick fills one
// slot of cm_pool with one point of its neighbours around it, so a trilinear read inside
// the slot is the level's own. Defines the cm_sampleScalar the marcher reads.
#ifdef CM_SKIP_EMPTY
uniform float cm_pagedEmptyValue;  // a value of zero extinction: what an empty brick reads
#endif

// The brick of `level` a sample at finest-level point `finest` reads, in that level's bricks.
vec3 cm_pagedBrick(vec3 finest, int level)
{
  vec3 points = cm_levelTexel(level, 2).xyz;
  return min(floor(cm_levelPoint(finest, level) / cm_brickPoints),
             ceil(points / cm_brickPoints) - 1.0);
}

// The value of level `level` at finest-level point `finest`, from its brick in `slot`.
float cm_readSlot(vec3 finest, int level, int slot)
{
  vec3 point = cm_levelPoint(finest, level);
  vec3 brick = cm_pagedBrick(finest, level);
  float side = cm_brickPoints + 2.0;
  vec3 texel = vec3(cm_slotOrigin(slot)) * side + 1.5 + (point - brick * cm_brickPoints);
  return texture(cm_pool, texel / (cm_poolSlots * side)).r;
}

#ifdef CM_SKIP_EMPTY
// What cm_brickIsEmpty found last: where, and the level and slot whose brick answered. The
// marcher asks it at the very position it then samples: the sample reuses the lookup.
vec3 cm_checkedAt = vec3(-1e30);
int cm_checkedLevel = 0;
int cm_checkedSlot = -1;
#endif

float cm_sampleScalar(vec3 texturePosition)
{
  vec3 finest = texturePosition * cm_levelTexel(0, 2).xyz - 0.5;
#ifdef CM_SKIP_EMPTY
  if (all(equal(texturePosition, cm_checkedAt)) && cm_checkedSlot >= 0)
  {
    return cm_slotIsEmpty(cm_checkedSlot) ? cm_pagedEmptyValue
        : cm_readSlot(finest, cm_checkedLevel, cm_checkedSlot);
  }
#endif
  for (int level = cm_pagedLevelAtPoint(finest); level < CM_PAGED_LEVELS; ++level)
  {
    int slot = cm_brickSlot(level, cm_pagedBrick(finest, level));
    if (slot >= 0)
    {
#ifdef CM_SKIP_EMPTY
      if (cm_slotIsEmpty(slot))   // a brick of zero extinction: no slot
      {
        return cm_pagedEmptyValue;
      }
#endif
      return cm_readSlot(finest, level, slot);
    }
  }
  return 0.0;   // not reached: the coarsest level is resident
}

#ifdef CM_SKIP_EMPTY
// Empty-space skipping (ea_march.glsl's hooks): a brick whose values, apron included, all
// map to zero extinction has no slot, its page entry says so. A sample is empty where the
// brick it reads is; the ray may then leave, in one step, the box where that stays true:
// the brick of the level it chose and of every level it fell back through (not resident:
// the next coarser read instead), down to the empty one.
int cm_skipFirst = 0;   // the levels cm_brickIsEmpty went through, first and last
int cm_skipLast = 0;

bool cm_brickIsEmpty(vec3 position)
{
  vec3 finest = position * cm_levelTexel(0, 2).xyz - 0.5;
  cm_checkedAt = position;
  cm_checkedSlot = -1;
  cm_skipFirst = cm_pagedLevelAtPoint(finest);
  for (int level = cm_skipFirst; level < CM_PAGED_LEVELS; ++level)
  {
    int slot = cm_brickSlot(level, cm_pagedBrick(finest, level));
    if (slot >= 0)
    {
      cm_skipLast = level;
      cm_checkedLevel = level;
      cm_checkedSlot = slot;
      return cm_slotIsEmpty(slot);
    }
  }
  return false;
}

// Steps (of stepVector, from entry) to where the ray leaves the box cm_brickIsEmpty found
// empty at step t: the nearest exit of the bricks it went through, as finest-level points
// (level point = finest point a + b, so a brick's [kB, (k + 1)B) is (kB - b) / a ...).
float cm_brickExitSteps(vec3 entry, vec3 stepVector, float t)
{
  vec3 dims = cm_levelTexel(0, 2).xyz;
  vec3 origin = entry * dims - 0.5;
  vec3 direction = stepVector * dims;
  vec3 finest = origin + direction * (t + 0.5);
  vec3 moving = step(vec3(1e-30), abs(direction));
  vec3 safe = mix(vec3(1.0), direction, moving);
  float exit = 1e30;
  for (int level = cm_skipFirst; level <= cm_skipLast; ++level)
  {
    vec3 a = cm_levelTexel(level, 0).xyz;
    vec3 b = cm_levelTexel(level, 1).xyz;
    vec3 brick = cm_pagedBrick(finest, level);
    vec3 low = (brick * cm_brickPoints - b) / a;
    vec3 high = ((brick + 1.0) * cm_brickPoints - b) / a;
    vec3 side = mix(low, high, step(vec3(0.0), direction));
    vec3 steps = mix(vec3(1e30), (side - origin) / safe, moving);
    exit = min(exit, min(steps.x, min(steps.y, steps.z)));
  }
  return exit;
}
#endif

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
