// requires: surface_declarations
// The fixed-step march inside one loaded cell: from local a to b (cm_stepLength cell units
// apart, from a, the exit b sampled last however short the last interval), the first
// interval whose ends differ in sign (or end on 0; with CM_LEVELS: lie on two sides of a
// level) is halved cm_refineSteps times. Returns the fraction of a..b at the root, or -1
// when no sign change was seen (cm_rootLevel: the level crossed).
float cm_marchCell(vec3 a, vec3 b)
{
  float span = length(b - a);
  int count = max(int(ceil(span / cm_stepLength)), 1);
  float step = cm_stepLength / max(span, 1e-30);   // fraction of a..b per step
  float s0 = 0.0;
  float f0 = cm_field(a);
  cm_rootLevel = cm_crossedLevel(f0, f0);   // the start on a level
  if (cm_rootLevel >= 0)
  {
    cm_rootPast = 0.0;
    return 0.0;
  }
  for (int k = 1; k <= count; ++k)
  {
    float s1 = min(float(k) * step, 1.0);
    float f1 = cm_field(mix(a, b, s1));
    int level = cm_crossedLevel(f0, f1);
    if (level >= 0)
    {
      float c = cm_levelValue(level);
      for (int r = 0; r < cm_refineSteps; ++r)
      {
        float s = 0.5 * (s0 + s1);
        float f = cm_field(mix(a, b, s));
        if (cm_sameSide(f0 - c, f - c))
        {
          s0 = s;
          f0 = f;
        }
        else
        {
          s1 = s;
        }
      }
      cm_rootLevel = level;
      cm_rootPast = s1 + (s1 - s0);   // a bracket past: f may be the level at s1 itself
      return f1 == c && cm_refineSteps == 0 ? s1 : 0.5 * (s0 + s1);
    }
    s0 = s1;
    f0 = f1;
  }
  return -1.0;
}
