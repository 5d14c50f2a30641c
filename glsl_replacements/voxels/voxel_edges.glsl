// Voxel edges (CM_EDGES; PyVista's show_edges): every drawn face's outline, drawn as VTK
// draws a mesh's edges. The coverage of a pixel is 0.5 + half the line width minus its
// distance (pixels, window space) to the nearest of the face's four edge lines, clamped to
// [0, 1], times the edges' opacity; the unlit colour and diffuse term go to the edge colour
// by it, the highlight stays.
uniform mat4 cm_clipFromTexture;   // index space to clip (made once per draw on the CPU)
uniform vec3 cm_edgeColor;
uniform float cm_edgeHalfWidth;    // half the drawn width, pixels
uniform float cm_edgeOpacity;

// Pixels from this fragment's centre to the window image of the index-space line through
// `point` running along `along` (the projected line, exact under perspective: its window
// direction is the derivative of the projection, no second point needed).
float cm_lineDistance(vec3 point, vec3 along)
{
  vec4 clip = cm_clipFromTexture * vec4(point, 1.0);
  vec4 toward = cm_clipFromTexture * vec4(along, 0.0);   // the direction's image
  vec2 halfSize = 0.5 * cm_viewport.zw;
  vec2 window = (clip.xy / clip.w + 1.0) * halfSize + cm_viewport.xy;
  vec2 direction = (toward.xy * clip.w - clip.xy * toward.w) * halfSize;
  vec2 across = gl_FragCoord.xy - window;
  float run = length(direction);
  if (run < 1e-30)   // the line is seen end on: the distance to its point
  {
    return length(across);
  }
  return abs(direction.x * across.y - direction.y * across.x) / run;
}

// The same for the line along index axis `along`.
float cm_edgeDistance(vec3 point, int along)
{
  vec3 unit = vec3(0.0);
  unit[along] = 1.0;
  return cm_lineDistance(point, unit);
}

// The edges' coverage of this pixel on face `face` of voxel `voxel` (index space; 0 where
// the ray started inside its voxel and entered no face).
float cm_edgeCoverage(ivec3 voxel, int face, vec3 point)
{
  if (face < 0)
  {
    return 0.0;
  }
  int axis = face / 2;
  int u = (axis + 1) - 3 * ((axis + 1) / 3);
  int v = (axis + 2) - 3 * ((axis + 2) / 3);
  float nearest = 1e30;
  for (int side = 0; side < 2; ++side)
  {
    vec3 onU = point;
    onU[u] = float(voxel[u] + side);   // the edge u = const, along v
    nearest = min(nearest, cm_edgeDistance(onU, v));
    vec3 onV = point;
    onV[v] = float(voxel[v] + side);   // the edge v = const, along u
    nearest = min(nearest, cm_edgeDistance(onV, u));
  }
  return clamp(0.5 + cm_edgeHalfWidth - nearest, 0.0, 1.0) * cm_edgeOpacity;
}

#ifdef CM_EDGE_LABELS
// edge_mode='labels': only the edges between different labels. The drawn label of a voxel
// (0 outside the grid, empty or hidden).
int cm_drawnAt(ivec3 voxel)
{
  if (any(lessThan(voxel, ivec3(0))) || any(greaterThanEqual(voxel, ivec3(cm_gridDims))))
  {
    return 0;
  }
  return cm_visibleMaterial(voxel);
}

// On face `face` of `voxel` (label `material`): the face's edges where the surface across
// shows another label (the voxel diagonally toward the eye if drawn, else the neighbour
// in the face's layer, else empty). Where the ray started on a clip plane inside its voxel,
// the lines where the plane crosses the voxel's faces toward a voxel of another label.
float cm_labelEdgeCoverage(ivec3 voxel, int face, vec3 point, int material)
{
  float nearest = 1e30;
  if (face >= 0)
  {
    int axis = face / 2;
    int toward = (face % 2 == 1) ? -1 : 1;   // entered moving +axis: the eye is below
    for (int shift = 1; shift <= 2; ++shift)
    {
      int held = (axis + shift) % 3;
      int along = (axis + 3 - shift) % 3;
      for (int side = 0; side < 2; ++side)
      {
        ivec3 beside = voxel;
        beside[held] += 2 * side - 1;
        ivec3 ahead = beside;
        ahead[axis] += toward;
        int front = cm_drawnAt(ahead);
        int across = front != 0 ? front : cm_drawnAt(beside);
        if (across != material)
        {
          vec3 onEdge = point;
          onEdge[held] = float(voxel[held] + side);
          nearest = min(nearest, cm_edgeDistance(onEdge, along));
        }
      }
    }
  }
#ifdef CM_CLIP_PLANES
  else
  {
    for (int i = 0; i < CM_CLIP_PLANES; ++i)
    {
      vec4 plane = cm_clipPlane(i);   // unit normal in index space
      if (abs(dot(plane, vec4(point, 1.0))) > 1e-3 * (1.0 + max(max(abs(point.x),
          abs(point.y)), abs(point.z))))
      {
        continue;   // the ray did not start on this plane
      }
      vec3 n = plane.xyz;
      for (int axis = 0; axis < 3; ++axis)
      {
        vec3 unit = vec3(0.0);
        unit[axis] = 1.0;
        vec3 along = cross(n, unit);
        if (length(along) < 1e-6)
        {
          continue;   // the plane runs parallel to these faces
        }
        vec3 within = unit - n * dot(n, unit) / dot(n, n);
        for (int side = 0; side < 2; ++side)
        {
          ivec3 beside = voxel;
          beside[axis] += 2 * side - 1;
          if (cm_drawnAt(beside) != material)
          {
            float level = float(voxel[axis] + side);
            vec3 start = point + within * ((level - point[axis]) / within[axis]);
            nearest = min(nearest, cm_lineDistance(start, along));
          }
        }
      }
    }
  }
#endif
  return clamp(0.5 + cm_edgeHalfWidth - nearest, 0.0, 1.0) * cm_edgeOpacity;
}
#endif
