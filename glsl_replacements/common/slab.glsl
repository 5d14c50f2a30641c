// The one ray/box slab test of every shader: the interval of t over which
// origin + t * direction lies inside the box [lo, hi], as (t_enter, t_leave); empty when
// t_leave < t_enter. No epsilons and no division by zero (GLSL 1.50 gives no infinity):
// an axis the ray does not move along bounds nothing when the origin is inside its slab,
// and empties the interval when it is outside.
vec2 cm_slab(vec3 origin, vec3 direction, vec3 lo, vec3 hi)
{
  vec3 moving = step(vec3(1e-30), abs(direction));
  vec3 safe = mix(vec3(1.0), direction, moving);
  vec3 t0 = (lo - origin) / safe;
  vec3 t1 = (hi - origin) / safe;
  vec3 inside = step(lo, origin) * step(origin, hi);
  vec3 enter = mix(mix(vec3(1e30), vec3(-1e30), inside), min(t0, t1), moving);
  vec3 leave = mix(mix(vec3(-1e30), vec3(1e30), inside), max(t0, t1), moving);
  return vec2(max(enter.x, max(enter.y, enter.z)), min(leave.x, min(leave.y, leave.z)));
}
