// Volumetric clipping planes (VTK's mapper clipping planes, PyVista's add_volume_clip_plane):
// a volume keeps the points p of texture space where dot(plane, vec4(p, 1)) >= 0 for every
// plane (4 floats each, made on the CPU in double precision from the world planes). Rays are
// cut to the kept interval before the march, so the cut face shows the interior exactly.
#ifdef CM_CLIP_PLANES
uniform float cm_clipPlanes[4 * CM_CLIP_PLANES];

vec4 cm_clipPlane(int i)
{
  return vec4(cm_clipPlanes[4 * i], cm_clipPlanes[4 * i + 1], cm_clipPlanes[4 * i + 2],
              cm_clipPlanes[4 * i + 3]);
}

// The part of (enter, leave) where origin + t * direction is kept (empty: leave < enter).
vec2 cm_clipInterval(vec3 origin, vec3 direction, vec2 range)
{
  for (int i = 0; i < CM_CLIP_PLANES; ++i)
  {
    vec4 plane = cm_clipPlane(i);
    float start = dot(plane, vec4(origin, 1.0));
    float rate = dot(plane.xyz, direction);
    if (rate > 0.0)
    {
      range.x = max(range.x, -start / rate);
    }
    else if (rate < 0.0)
    {
      range.y = min(range.y, -start / rate);
    }
    else if (start < 0.0)
    {
      range.y = -1e30;   // parallel to the plane, on its clipped side
    }
  }
  return range;
}

// The index-space normal of the plane that cuts the ray at t (the nearest crossing), facing
// back along the ray: a cut face's normal, lit as PyVista lights a clipped mesh's cut.
vec3 cm_clipNormalAt(vec3 origin, vec3 direction, float t)
{
  vec3 normal = vec3(0.0);
  float nearest = 1e30;
  for (int i = 0; i < CM_CLIP_PLANES; ++i)
  {
    vec4 plane = cm_clipPlane(i);
    float rate = dot(plane.xyz, direction);
    if (rate != 0.0)
    {
      float off = abs(-dot(plane, vec4(origin, 1.0)) / rate - t);
      if (off < nearest)
      {
        nearest = off;
        normal = rate > 0.0 ? -plane.xyz : plane.xyz;
      }
    }
  }
  return normal;
}

// 1 where the point is kept, 0 where a plane clips it.
float cm_clipKeeps(vec3 p)
{
  for (int i = 0; i < CM_CLIP_PLANES; ++i)
  {
    if (dot(cm_clipPlane(i), vec4(p, 1.0)) < 0.0)
    {
      return 0.0;
    }
  }
  return 1.0;
}
#endif
