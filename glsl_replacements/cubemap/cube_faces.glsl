// The cube map of a volume as an atlas: the six interior faces of the box of texel centres
// (local cube [-1, 1]^3), face i (order +x, -x, +y, -y, +z, -z) in tile (i % 3, i / 3) of a
// 3 x 2 grid. A tile holds the face's S x S texels inside a one-texel border that repeats
// the edge texels, so filtering never reads another face. On face i (axis a = i / 2) the
// face coordinates u, v run along axes (a + 1) % 3 and (a + 2) % 3. Needs cm_dims.
uniform float cm_faceSize;   // S, texels per face edge at this frame's level

vec3 cm_localToTexture(vec3 local)
{
  vec3 lo = 0.5 / cm_dims;
  return mix(lo, 1.0 - lo, local * 0.5 + 0.5);
}

// Atlas texels of one tile (the face plus its border) and of the whole atlas.
float cm_tileSize()
{
  return cm_faceSize + 2.0;
}

vec2 cm_atlasSize()
{
  return vec2(3.0, 2.0) * cm_tileSize();
}

vec2 cm_tileOrigin(int face)
{
  return vec2(float(face % 3), float(face / 3)) * cm_tileSize();
}

// The point of face `face` at face coordinates uv in [0, 1]^2, in texture coordinates.
vec3 cm_facePoint(int face, vec2 uv)
{
  int axis = face / 2;
  vec3 local = vec3(0.0);
  local[axis] = (face & 1) == 1 ? -1.0 : 1.0;
  local[(axis + 1) % 3] = uv.x * 2.0 - 1.0;
  local[(axis + 2) % 3] = uv.y * 2.0 - 1.0;
  return cm_localToTexture(local);
}

// Cube mapping: the face a direction from the cube's centre meets, and where (uv in [0, 1]).
int cm_faceOf(vec3 texturePosition, out vec2 uv)
{
  vec3 lo = 0.5 / cm_dims;
  vec3 local = (texturePosition - lo) / (1.0 - 2.0 * lo) * 2.0 - 1.0;
  vec3 size = abs(local);
  int axis = size.x >= size.y && size.x >= size.z ? 0 : (size.y >= size.z ? 1 : 2);
  float major = max(size[axis], 1e-30);
  uv = clamp(vec2(local[(axis + 1) % 3], local[(axis + 2) % 3]) / major * 0.5 + 0.5,
             0.0, 1.0);
  return 2 * axis + (local[axis] < 0.0 ? 1 : 0);
}
