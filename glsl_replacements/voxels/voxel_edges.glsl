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
// `point` running along axis `along` (the projected line, exact under perspective: its
// window direction is the derivative of the projection, no second point needed).
float cm_edgeDistance(vec3 point, int along)
{
  vec4 clip = cm_clipFromTexture * vec4(point, 1.0);
  vec4 toward = cm_clipFromTexture[along];   // the axis' image, w = 0 in index space
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
