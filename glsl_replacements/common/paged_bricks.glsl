// A multiscale source read through a brick pool (brick_pager.py): the pool, its page table
// (a directory of blocks of bricks, then the blocks: page_table.py) and the per-level table;
// which slot holds a brick, and which level a finest-level point chooses: the coarsest whose
// point spacing still fits one pixel there (shifted by the LOD bias). Shared by the volume's
// sampling (paged_sample.glsl) and the streamed label traversal (voxel_paged.glsl).
uniform sampler3D cm_pool;         // slots of (brick + 2 apron)^3 values, side by side
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


// Where slot `slot` starts in the pool, in slots (x fastest); and whether an entry's slot
// is none at all: a brick marked empty (page entry = the pool's slot count), no slot.
ivec3 cm_slotOrigin(int slot)
{
  ivec3 slots = ivec3(cm_poolSlots + 0.5);
  return ivec3(slot % slots.x, (slot / slots.x) % slots.y, slot / (slots.x * slots.y));
}

bool cm_slotIsEmpty(int slot)
{
  ivec3 slots = ivec3(cm_poolSlots + 0.5);
  return slot >= slots.x * slots.y * slots.z;
}

// The point of level `level` (continuous, in its points, kept inside it) at finest-level
// point `finest`.
vec3 cm_levelPoint(vec3 finest, int level)
{
  return clamp(finest * cm_levelTexel(level, 0).xyz + cm_levelTexel(level, 1).xyz,
               vec3(0.0), cm_levelTexel(level, 2).xyz - 1.0);
}

// The level a sample at finest-level point `finest` reads first: the coarsest whose points
// fit a pixel there.
int cm_pagedLevelAtPoint(vec3 finest)
{
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
