// A multiscale volume read through a brick pool: the data value at a texture position of the
// finest level (texel centres on its points), from the coarsest level whose point spacing
// still fits one pixel there (shifted by the LOD bias), or, where that level's brick is not
// resident yet, from the nearest coarser one that is (the coarsest level always is: never a
// hole). Each resident brick fills one slot of cm_pool with one point of its neighbours
// around it, so a trilinear read inside the slot is the level's own. Defines the
// cm_sampleScalar the marcher reads. Which slot holds a brick: a directory of blocks of bricks
// and the blocks (page_table.py).
uniform sampler3D cm_pool;         // slots of (brick + 2)^3 values, side by side
uniform sampler3D cm_pageDirectory;  // per level and block of bricks: its block + 1, or 0
uniform sampler3D cm_pageBlocks;   // per brick of a block: its slot + 1, or 0 (not resident)
uniform float cm_pageScale;        // 65535 (uint16 entries, read normalised) or 1 (float32)
uniform vec3 cm_blockGrid;         // blocks along x, y, z of cm_pageBlocks
uniform float cm_blockBricks;      // bricks along a block's edge
uniform sampler2D cm_levelInfo;    // per level (row): the texels below
uniform vec3 cm_poolSlots;         // slots along x, y, z
uniform float cm_brickPoints;      // points along a brick's edge, apron left out
uniform mat3 cm_pagedWorldFromPoint;   // finest-level point offsets to world lengths
uniform vec3 cm_pagedEye;          // the eye in finest-level point coordinates
uniform vec2 cm_lodFootprint;      // world length a pixel spans at distance d: d x + y

// Row `level` of cm_levelInfo: (a, step), (b, 0), (points, 0), (directory origin, 0), with
// level point = finest point * a + b, and step the world length of one of its points.
vec4 cm_levelTexel(int level, int column)
{
  return texelFetch(cm_levelInfo, ivec2(column, level), 0);
}

// The slot holding brick `brick` of `level` (-1: not resident): its block through the
// directory, then its entry in the block.
int cm_brickSlot(int level, vec3 brick)
{
  vec3 block = floor(brick / cm_blockBricks);
  int index = int(texelFetch(cm_pageDirectory, ivec3(cm_levelTexel(level, 3).xyz + block), 0).r
                  * cm_pageScale + 0.5) - 1;
  if (index < 0)
  {
    return -1;
  }
  ivec3 grid = ivec3(cm_blockGrid + 0.5);
  ivec3 where = ivec3(index % grid.x, (index / grid.x) % grid.y, index / (grid.x * grid.y));
  ivec3 entry = where * int(cm_blockBricks + 0.5) + ivec3(brick - block * cm_blockBricks);
  return int(texelFetch(cm_pageBlocks, entry, 0).r * cm_pageScale + 0.5) - 1;
}

float cm_sampleScalar(vec3 texturePosition)
{
  vec3 finest = texturePosition * cm_levelTexel(0, 2).xyz - 0.5;
  float pixel = length(cm_pagedWorldFromPoint * (finest - cm_pagedEye)) * cm_lodFootprint.x
                + cm_lodFootprint.y;
  int chosen = 0;
  for (int level = CM_PAGED_LEVELS - 1; level > 0; --level)
  {
    if (cm_levelTexel(level, 0).w <= pixel)   // the coarsest whose points fit a pixel
    {
      chosen = level;
      break;
    }
  }
  for (int level = chosen; level < CM_PAGED_LEVELS; ++level)
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

// The level a sample at `texturePosition` reads first (the coarsest whose points fit a
// pixel there), as cm_sampleScalar chooses it.
int cm_pagedLevelAt(vec3 texturePosition)
{
  vec3 finest = texturePosition * cm_levelTexel(0, 2).xyz - 0.5;
  float pixel = length(cm_pagedWorldFromPoint * (finest - cm_pagedEye)) * cm_lodFootprint.x
                + cm_lodFootprint.y;
  for (int level = CM_PAGED_LEVELS - 1; level > 0; --level)
  {
    if (cm_levelTexel(level, 0).w <= pixel)
    {
      return level;
    }
  }
  return 0;
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
