// Material grids: declarations. Voxel (i, j, k) spans [i, i+1] x [j, j+1] x [k, k+1] of
// the grid's index space (cm_textureFromView maps view to it); its label is one texel of
// cm_labels (a row of the per-label tables: uint8 or uint16 as a normalised texture, read
// back exactly with cm_labelScale; wider rows as float32, scale 1);
// a label's colour and opacity are one texel of cm_palette (opacity 0: hidden, traversed as
// empty).
uniform sampler3D cm_labels;     // one texel per voxel, nearest
uniform float cm_labelScale;     // 255 (uint8), 65535 (uint16) or 1 (float32 rows)
uniform sampler2D cm_palette;    // RGBA, material m at (m % width, m / width)
uniform vec3 cm_gridDims;        // voxels along x, y, z
uniform float cm_near;           // the near plane's view depth
#ifdef CM_WHOLE_GRID
// A brick of a larger grid (sort-last rendering): its rays are traversed in the whole
// grid's index space (cm_textureFromView is the whole grid's), through the voxels outside
// the brick as empty space, so that they meet the voxels the whole grid's rays meet.
uniform vec3 cm_wholeDims;       // the whole grid's voxels along x, y, z
uniform vec3 cm_brickOrigin;     // the brick's first voxel in the whole grid
#define CM_TRAVERSED_DIMS cm_wholeDims
#else
#define CM_TRAVERSED_DIMS cm_gridDims
#endif
#ifdef CM_OCCLUDERS
uniform float cm_useOccluders;      // 1: the world's solid faces were drawn this frame
uniform sampler2D cm_occluderDepth; // per pixel, a view depth no ray passes without a hit
#endif
#ifdef CM_SHELL_LEVEL
uniform float cm_startAtProxy;   // 1: rays start at the brick shell (its depth pass ran)
uniform sampler2D cm_shellDepth; // per pixel, the view depth where the ray meets the shell
#endif

// The label of a voxel (0: empty), drawn or hidden (a world's: through its chunk index,
// voxel_chunk_index.glsl; a streamed grid's: through its brick pool, voxel_paged.glsl).
#if defined(CM_CHUNK_INDEX) || defined(CM_PAGED_LEVELS)
int cm_label(ivec3 voxel);
#elif defined(CM_LABEL_APRON)
// A world's chunk as its translucent layers read it: one voxel of its neighbours around its
// labels, so the voxels just past its box (-1 and cm_gridDims) are read too.
int cm_label(ivec3 voxel)
{
  return int(texelFetch(cm_labels, voxel + 1, 0).r * cm_labelScale + 0.5);
}
#else
int cm_label(ivec3 voxel)
{
  return int(texelFetch(cm_labels, voxel, 0).r * cm_labelScale + 0.5);
}
#endif

// A material's colour and opacity: the palette is wrapped into rows (a 1D texture as wide
// as 65536 labels is past GL's width limit); entries past the last material are (0, 0, 0, 0).
vec4 cm_paletteEntry(int material)
{
  int width = textureSize(cm_palette, 0).x;
  return texelFetch(cm_palette, ivec2(material % width, material / width), 0);
}

// Whether a non-zero label is drawn: it has a palette entry of non-zero opacity.
bool cm_shown(int material)
{
  ivec2 size = textureSize(cm_palette, 0);
  return material < size.x * size.y && cm_paletteEntry(material).a > 0.0;
}

// The material of a voxel, if it is drawn (0: empty or hidden).
int cm_visibleMaterial(ivec3 voxel)
{
  int material = cm_label(voxel);
  return material != 0 && cm_shown(material) ? material : 0;
}

// What a traversal of the ray a + d t steps by, per axis: t = (x - a) / d as the CPU
// reference; an axis the ray does not move along gets `inverse` 0 and `never` 1e30, so its
// crossing is never the nearest (GLSL 1.50 promises no infinity); `forward`: 1 where d >= 0.
void cm_rayAxes(vec3 d, out vec3 inverse, out vec3 never, out vec3 forward)
{
  vec3 moving = step(vec3(1e-30), abs(d));
  inverse = moving / mix(vec3(1.0), d, moving);
  never = 1e30 * (1.0 - moving);
  forward = step(vec3(0.0), d);
}

// The voxel the ray a + d t is in at t, on each axis between the voxels `from` and `far`
// (where it can be; `far` the farther along the ray): the point's floor is only a guess
// (float32 rounds it either way near a plane), drawn back a hair along the ray so that it
// is the voxel or the one before, then moved on where the plane to the next was crossed
// before t: at an earlier t, or at t itself where `ties` is 1 (the tie rule). The planes'
// t are computed as a step's exits are, so a traversal agrees with them to the bit. All
// axes at once (a loop per axis, checking both sides, cost llvmpipe 2x).
ivec3 cm_voxelAt(vec3 a, vec3 d, vec3 inverse, vec3 never, vec3 forward, float t,
                 ivec3 from, ivec3 far, vec3 ties)
{
  ivec3 up = ivec3(forward);
  ivec3 stride = 2 * up - 1;
  ivec3 moving = ivec3(lessThan(never, vec3(1.0)));
  vec3 point = a + d * t - vec3(stride * moving) * (1e-5 * (1.0 + abs(a) + abs(d * t)));
  ivec3 voxel = clamp(ivec3(floor(point)), min(from, far), max(from, far));
  vec3 ahead = (vec3(voxel + up) - a) * inverse + never;
  vec3 crossed = max(vec3(lessThan(ahead, vec3(t))), vec3(equal(ahead, vec3(t))) * ties);
  return voxel + stride * ivec3(crossed) * moving * ivec3(notEqual(voxel, far));
}

// The voxel the ray is in at t = start, as a traversal from farther back leaves it: past
// every plane crossed at or before start, within the grid. Where a ray starts (a box, the
// near plane, a brick shell) then changes no voxel it meets after: a brick of a grid,
// traversed in the whole grid's frame, meets the voxels the whole grid's traversal meets.
ivec3 cm_startVoxel(vec3 a, vec3 d, vec3 inverse, vec3 never, vec3 forward, float start,
                    ivec3 dims)
{
  ivec3 up = ivec3(forward);
  return cm_voxelAt(a, d, inverse, never, forward, start, (dims - 1) * (1 - up),
                    (dims - 1) * up, vec3(1.0));
}

// A traversal step (voxel_dda.glsl, voxel_paged.glsl): leave the block [low, high) of
// voxels, which holds the ray's voxel `from`, along the ray a + d t (index space; `inverse`
// 1/d per moving axis, 0 on the others, `never` 1e30 on those, `forward` 1 where d >= 0).
// Its nearest forward boundary, x before y before z on a tie, is crossed at t through
// `axis`; `next` is the voxel just past it: on the exit axis the first voxel beyond the
// block, on the others the voxel stepping one voxel at a time would be in (cm_voxelAt), so
// a block of many voxels is left exactly where its voxels, left one by one, would be,
// whatever blocks the occupancy levels make.
// False when the ray ends first (past t = end) or leaves the grid.
bool cm_leaveBlock(vec3 a, vec3 d, vec3 inverse, vec3 never, vec3 forward, ivec3 from,
                   ivec3 low, ivec3 high, float end, out int axis, out float t,
                   out ivec3 next)
{
  vec3 exits = (mix(vec3(low), vec3(high), forward) - a) * inverse + never;
  axis = (exits.x <= exits.y && exits.x <= exits.z) ? 0 : (exits.y <= exits.z ? 1 : 2);
  t = min(exits.x, min(exits.y, exits.z));
  next = low;
  if (t > end)
  {
    return false;
  }
  ivec3 onAxis = ivec3(equal(ivec3(axis), ivec3(0, 1, 2)));
  // the other axes: where the ray is at the exit, within the block from `from` on, the
  // tie going to the axes below the exit's
  ivec3 far = low + (high - 1 - low) * ivec3(forward);   // the block's last voxel on the ray
  next = cm_voxelAt(a, d, inverse, never, forward, t, from, far,
                    vec3(lessThan(ivec3(0, 1, 2), ivec3(axis))));
  ivec3 past = low - 1 + (high - low + 1) * ivec3(forward);
  next += (past - next) * onAxis;
  return all(greaterThanEqual(next, ivec3(0))) && all(lessThan(next,
                                                           ivec3(CM_TRAVERSED_DIMS)));
}

// The face of the grid box a ray (index space) enters through, as voxel faces are numbered
// (2 * axis + 1 moving +axis): the axis whose slab it enters last, ties to the lowest axis
// (as the CPU reference).
int cm_boxEntryFace(vec3 origin, vec3 direction)
{
  vec3 moving = step(vec3(1e-30), abs(direction));
  vec3 safe = mix(vec3(1.0), direction, moving);
  vec3 enter = mix(vec3(-1e30), min(-origin / safe, (CM_TRAVERSED_DIMS - origin) / safe),
                   moving);
  int axis = (enter.x >= enter.y && enter.x >= enter.z) ? 0 : (enter.y >= enter.z ? 1 : 2);
  return 2 * axis + (direction[axis] > 0.0 ? 1 : 0);
}
