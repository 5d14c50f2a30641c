// requires: camera_declarations, pixel_ray, slab
// Polynomial surfaces: declarations. Cell (i, j, k) spans [i, i+1] x [j, j+1] x [k, k+1]
// of cell space (cm_textureFromView maps view to it); its field is the quadratic tensor
// Bernstein polynomial sum beta[a][b][c] B_a(u) B_b(v) B_c(w) in cell-local (u, v, w) in
// [0, 1]^3 (models/surface.py), kept local: global powers lose all precision in float32.
// Where the cells' coefficients come from is the storage's (surface_records.glsl: per-cell
// records; surface_bricks.glsl: bricks of shared spline coefficients).
uniform vec3 cm_gridDims;        // cells along x, y, z
uniform vec3 cm_domainLower;     // the part of cell space drawn (samples at an image's
uniform vec3 cm_domainUpper;     // points: their hull, half a cell inside the grid)
uniform float cm_near;           // the near plane's view depth
uniform float cm_stepLength;     // cell units between samples (the domain's diagonal / M)
uniform int cm_refineSteps;      // bisections of the first sign change
uniform vec3 cm_surfaceColor;
#ifdef CM_NORMAL_COLORS
uniform mat3 cm_normalFromIndex;   // cell-space normals to view space (inverse transpose)
#endif

// The cell being marched: cm_beta[3 a + b][c]. No function evaluated per sample has a
// loop: llvmpipe counts every iteration of every loop of a fragment against one budget of
// 65535 (gallivm's loop limiter), and loops stop once it is spent (seen: the full march
// losing far hits past about 4200 samples, 15 iterations each). Inner loops are written
// out so the budget goes to samples.
vec3 cm_beta[9];
// After a root is found: the fraction of the segment marched just past it (its bracket's
// far end, where the field has changed sign), from where the translucent layers look for
// the next root.
float cm_rootPast = 0.0;

// Whether a root lies between two field values: they differ in sign, or one is 0. Signs are
// compared, never multiplied: a product of two small values underflows to 0 in float32
// (seen: fields scaled by 1e-19 drawn where they have no root).
bool cm_brackets(float f0, float f1)
{
  return (f0 <= 0.0 && f1 >= 0.0) || (f0 >= 0.0 && f1 <= 0.0);
}

// Whether two field values lie strictly on the same side of 0.
bool cm_sameSide(float f0, float f1)
{
  return (f0 > 0.0 && f1 > 0.0) || (f0 < 0.0 && f1 < 0.0);
}

// The level sets drawn: f = 0 alone, or (CM_LEVELS, several translucent isosurfaces in
// one pass) f = cm_levels[k] for each k. cm_crossedLevel says which level lies between
// two field values (the one nearest the first: the ray meets it first), or -1; written out
// per level, as no function evaluated per sample may loop (see cm_beta).
int cm_rootLevel = 0;   // the level of the last root found
#ifdef CM_LEVELS
uniform float cm_levels[CM_LEVELS];
uniform float cm_levelColors[3 * CM_LEVELS];   // each level's RGB
#define CM_TRY_LEVEL(k) if (cm_brackets(f0 - cm_levels[k], f1 - cm_levels[k]) \
    && abs(cm_levels[k] - f0) < nearest) { nearest = abs(cm_levels[k] - f0); level = k; }

float cm_levelValue(int level)
{
  return cm_levels[level];
}

int cm_crossedLevel(float f0, float f1)
{
  int level = -1;
  float nearest = 1e38;
  CM_TRY_LEVEL(0)
  CM_TRY_LEVEL(1)
#if CM_LEVELS > 2
  CM_TRY_LEVEL(2)
#endif
#if CM_LEVELS > 3
  CM_TRY_LEVEL(3)
#endif
#if CM_LEVELS > 4
  CM_TRY_LEVEL(4)
#endif
#if CM_LEVELS > 5
  CM_TRY_LEVEL(5)
#endif
#if CM_LEVELS > 6
  CM_TRY_LEVEL(6)
#endif
#if CM_LEVELS > 7
  CM_TRY_LEVEL(7)
#endif
  return level;
}
#else
float cm_levelValue(int level)
{
  return 0.0;
}

int cm_crossedLevel(float f0, float f1)
{
  return cm_brackets(f0, f1) ? 0 : -1;
}
#endif

vec3 cm_basis(float u)
{
  return vec3((1.0 - u) * (1.0 - u), 2.0 * u * (1.0 - u), u * u);
}

vec3 cm_basisDerivative(float u)
{
  return vec3(-2.0 * (1.0 - u), 2.0 - 4.0 * u, 2.0 * u);
}

// The field of the loaded cell at local `u`, from the three axes' basis values.
float cm_tensor(vec3 bu, vec3 bv, vec3 bw)
{
  vec3 rows0 = vec3(dot(cm_beta[0], bw), dot(cm_beta[1], bw), dot(cm_beta[2], bw));
  vec3 rows1 = vec3(dot(cm_beta[3], bw), dot(cm_beta[4], bw), dot(cm_beta[5], bw));
  vec3 rows2 = vec3(dot(cm_beta[6], bw), dot(cm_beta[7], bw), dot(cm_beta[8], bw));
  return bu.x * dot(rows0, bv) + bu.y * dot(rows1, bv) + bu.z * dot(rows2, bv);
}

float cm_field(vec3 u)
{
  return cm_tensor(cm_basis(u.x), cm_basis(u.y), cm_basis(u.z));
}

// The loaded cell's gradient per cell unit at local `u`.
vec3 cm_fieldGradient(vec3 u)
{
  vec3 bu = cm_basis(u.x), bv = cm_basis(u.y), bw = cm_basis(u.z);
  return vec3(cm_tensor(cm_basisDerivative(u.x), bv, bw),
              cm_tensor(bu, cm_basisDerivative(u.y), bw),
              cm_tensor(bu, bv, cm_basisDerivative(u.z)));
}

// This fragment's ray in view and cell space, and the span of it inside the domain from
// where it enters (or the near plane: the camera inside) to where it leaves, cut to where
// the clip planes keep it; false when none of it is.
bool cm_domainRay(out vec3 originView, out vec3 directionView, out vec3 origin,
                  out vec3 direction, out vec2 span)
{
  cm_fragmentRay(originView, directionView, origin, direction);
  // a hair larger, as a cell's slab: a ray exactly on a face (an axis-aligned parallel view)
  // that float32 puts an ulp outside is kept, as the contour's edge is drawn there
  span = cm_slab(origin, direction, cm_domainLower - vec3(1e-4), cm_domainUpper + vec3(1e-4));
  span.x = max(span.x, cm_near);
  span.y = min(span.y, cm_viewDepthOf(1.0));   // nothing past the far plane, as VTK clips
#ifdef CM_CLIP_PLANES
  span = cm_clipInterval(origin, direction, span);   // the cut left open, as a clipped mesh
#endif
  return span.y > span.x;
}
