// requires: surface_declarations
// The exact root (root = 'exact', beyond fixed steps): inside a cell the field along the ray
// a..b is a polynomial of degree at most 6 in s; its 7 Bernstein coefficients come from 7
// samples at s = k/6 through the inverse of the Bernstein basis there (exact fractions:
// tests/test_surfaces.py derives them again). A polynomial whose coefficients all have one
// sign has no root on its interval (the convex hull); otherwise the interval is halved (de
// Casteljau), depth first, left before right, down to CM_EXACT_DEPTH halvings (1/1024 of
// the segment), where the field itself must change sign across the interval; so the first
// root is found whatever the step: thin features and grazing rays are not missed, short of
// two roots within one 1/1024 of the segment. That interval is then bisected on the field
// itself (cm_refineSteps).
const float CM_SAMPLES_TO_BERNSTEIN[49] = float[49](
  1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
  (-29.0 / 20.0), 6.0, (-15.0 / 2.0), (20.0 / 3.0), (-15.0 / 4.0), (6.0 / 5.0), (-1.0 / 6.0),
  (227.0 / 150.0), (-222.0 / 25.0), (201.0 / 10.0), (-308.0 / 15.0), (123.0 / 10.0),
  (-102.0 / 25.0), (29.0 / 50.0),
  (-227.0 / 200.0), (189.0 / 25.0), (-837.0 / 40.0), 30.0, (-837.0 / 40.0), (189.0 / 25.0),
  (-227.0 / 200.0),
  (29.0 / 50.0), (-102.0 / 25.0), (123.0 / 10.0), (-308.0 / 15.0), (201.0 / 10.0),
  (-222.0 / 25.0), (227.0 / 150.0),
  (-1.0 / 6.0), (6.0 / 5.0), (-15.0 / 4.0), (20.0 / 3.0), (-15.0 / 2.0), 6.0, (-29.0 / 20.0),
  0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0);
#define CM_EXACT_DEPTH 10
#define CM_EXACT_ITERATIONS 160

float cm_whole[7];   // the polynomial on the cell's whole segment
float cm_part[7];    // on the interval being looked at

// cm_part becomes its polynomial on [0, s] (left) or [s, 1] (right) of its interval: de
// Casteljau's levels written out on scalars (array loops with a bound set by the outer
// loop left the coefficients unchanged on llvmpipe). After level r, p_i is the point
// P(r, i): the left part is P(r, 0) for r = 0..6, the right part P(6 - j, j).
void cm_split(float s, bool left)
{
  float p0 = cm_part[0], p1 = cm_part[1], p2 = cm_part[2], p3 = cm_part[3];
  float p4 = cm_part[4], p5 = cm_part[5], p6 = cm_part[6];
  float l1, l2, l3, l4, l5;
  float r5, r4, r3, r2, r1;
  p0 = mix(p0, p1, s); p1 = mix(p1, p2, s); p2 = mix(p2, p3, s);
  p3 = mix(p3, p4, s); p4 = mix(p4, p5, s); p5 = mix(p5, p6, s);
  l1 = p0; r5 = p5;
  p0 = mix(p0, p1, s); p1 = mix(p1, p2, s); p2 = mix(p2, p3, s);
  p3 = mix(p3, p4, s); p4 = mix(p4, p5, s);
  l2 = p0; r4 = p4;
  p0 = mix(p0, p1, s); p1 = mix(p1, p2, s); p2 = mix(p2, p3, s); p3 = mix(p3, p4, s);
  l3 = p0; r3 = p3;
  p0 = mix(p0, p1, s); p1 = mix(p1, p2, s); p2 = mix(p2, p3, s);
  l4 = p0; r2 = p2;
  p0 = mix(p0, p1, s); p1 = mix(p1, p2, s);
  l5 = p0; r1 = p1;
  p0 = mix(p0, p1, s);   // the point at s: both parts' shared end
  if (left)
  {
    cm_part[1] = l1; cm_part[2] = l2; cm_part[3] = l3;
    cm_part[4] = l4; cm_part[5] = l5; cm_part[6] = p0;
  }
  else
  {
    cm_part[0] = p0; cm_part[1] = r1; cm_part[2] = r2;
    cm_part[3] = r3; cm_part[4] = r4; cm_part[5] = r5;
  }
}

// 1 when every coefficient of cm_part is above 0, -1 below, 0 when they do not agree.
float cm_oneSign()
{
  float low = min(min(min(cm_part[0], cm_part[1]), min(cm_part[2], cm_part[3])),
                  min(min(cm_part[4], cm_part[5]), cm_part[6]));
  float high = max(max(max(cm_part[0], cm_part[1]), max(cm_part[2], cm_part[3])),
                   max(max(cm_part[4], cm_part[5]), cm_part[6]));
  return low > 0.0 ? 1.0 : (high < 0.0 ? -1.0 : 0.0);
}

// Row j of the samples-to-Bernstein matrix applied to the 7 samples (s0..s3, s4..s6).
float cm_bernsteinOf(int j, vec4 first, vec3 last)
{
  int r = 7 * j;
  return dot(vec4(CM_SAMPLES_TO_BERNSTEIN[r], CM_SAMPLES_TO_BERNSTEIN[r + 1],
                  CM_SAMPLES_TO_BERNSTEIN[r + 2], CM_SAMPLES_TO_BERNSTEIN[r + 3]), first)
         + dot(vec3(CM_SAMPLES_TO_BERNSTEIN[r + 4], CM_SAMPLES_TO_BERNSTEIN[r + 5],
                    CM_SAMPLES_TO_BERNSTEIN[r + 6]), last);
}

// The fraction of a..b at the first root of the loaded cell's field, or -1 if none. The
// setting up is written out (no loop: llvmpipe's budget of loop iterations per fragment
// goes to the subdivision).
float cm_exactRoot(vec3 a, vec3 b)
{
  vec4 first = vec4(cm_field(a), cm_field(mix(a, b, 1.0 / 6.0)), cm_field(mix(a, b, 2.0 / 6.0)),
                    cm_field(mix(a, b, 3.0 / 6.0)));
  vec3 last = vec3(cm_field(mix(a, b, 4.0 / 6.0)), cm_field(mix(a, b, 5.0 / 6.0)),
                   cm_field(b));
  cm_whole = float[7](cm_bernsteinOf(0, first, last), cm_bernsteinOf(1, first, last),
                      cm_bernsteinOf(2, first, last), cm_bernsteinOf(3, first, last),
                      cm_bernsteinOf(4, first, last), cm_bernsteinOf(5, first, last),
                      cm_bernsteinOf(6, first, last));
  cm_part = cm_whole;
  // 1e-6 of the polynomial's largest coefficient
  float tiny = 1e-6 * max(max(max(abs(cm_whole[0]), abs(cm_whole[1])),
                              max(abs(cm_whole[2]), abs(cm_whole[3]))),
                          max(max(abs(cm_whole[4]), abs(cm_whole[5])), abs(cm_whole[6])));
  int depth = 0;
  int index = 0;   // the interval [index, index + 1] / 2^depth
  float found = -1.0;
  float f0 = 0.0;
  float f1 = 0.0;
  for (int iteration = 0; iteration < CM_EXACT_ITERATIONS && found < 0.0; ++iteration)
  {
    bool rootless = cm_oneSign() != 0.0;
    if (!rootless && depth == CM_EXACT_DEPTH)
    {
      // The hull still straddles 0: the field itself must change sign across the
      // interval (float32 hulls of deep intervals, restricted from the whole segment's,
      // are not trusted further: seen to lose a plain crossing).
      float size = 1.0 / float(1 << depth);
      f0 = cm_field(mix(a, b, float(index) * size));
      f1 = cm_field(mix(a, b, float(index + 1) * size));
      // An end within float32's reach of 0 counts: a root on the cell's face may round
      // to the outside in both cells' samples (seen: a slab's face lost).
      if (cm_brackets(f0, f1) || min(abs(f0), abs(f1)) <= tiny)
      {
        found = float(index);
        break;
      }
      rootless = true;
    }
    if (rootless)   // no root here: on to the next interval to the right
    {
      index += 1;
      while (depth > 0 && (index & 1) == 0)
      {
        index >>= 1;
        depth -= 1;
      }
      if (depth == 0)
      {
        return -1.0;
      }
      float size = 1.0 / float(1 << depth);
      cm_part = cm_whole;
      cm_split(min(float(index + 1) * size, 1.0), true);
      cm_split(float(index) / float(index + 1), false);
      continue;
    }
    cm_split(0.5, true);
    depth += 1;
    index *= 2;
  }
  if (found < 0.0)
  {
    return -1.0;
  }
  // Bisect the last interval on the field itself (its ends differ in sign).
  float size = 1.0 / float(1 << depth);
  float s0 = found * size;
  float s1 = s0 + size;
  for (int r = 0; r < cm_refineSteps; ++r)
  {
    float s = 0.5 * (s0 + s1);
    float f = cm_field(mix(a, b, s));
    if (cm_sameSide(f0, f) && abs(f0) > tiny)
    {
      s0 = s;
      f0 = f;
    }
    else
    {
      s1 = s;
    }
  }
  cm_rootPast = s1 + (s1 - s0);   // a bracket past: f may be 0 at s1 itself
  return 0.5 * (s0 + s1);
}
