// The seed's march inside one loaded cell: from local a to b (cm_stepLength cell units
// apart, from a, the exit b sampled last however short the last interval), the first
// interval whose ends differ in sign (or end on 0) is halved cm_refineSteps times. Returns
// the fraction of a..b at the root, or -1 when no sign change was seen.
float cm_marchCell(vec3 a, vec3 b)
{
  float span = length(b - a);
  int count = max(int(ceil(span / cm_stepLength)), 1);
  float step = cm_stepLength / max(span, 1e-30);   // fraction of a..b per step
  float s0 = 0.0;
  float f0 = cm_field(a);
  if (f0 == 0.0)
  {
    cm_rootPast = 0.0;
    return 0.0;
  }
  for (int k = 1; k <= count; ++k)
  {
    float s1 = min(float(k) * step, 1.0);
    float f1 = cm_field(mix(a, b, s1));
    if (cm_brackets(f0, f1))
    {
      for (int r = 0; r < cm_refineSteps; ++r)
      {
        float s = 0.5 * (s0 + s1);
        float f = cm_field(mix(a, b, s));
        if (cm_sameSide(f0, f))
        {
          s0 = s;
          f0 = f;
        }
        else
        {
          s1 = s;
        }
      }
      cm_rootPast = s1;
      return f1 == 0.0 && cm_refineSteps == 0 ? s1 : 0.5 * (s0 + s1);
    }
    s0 = s1;
    f0 = f1;
  }
  return -1.0;
}
