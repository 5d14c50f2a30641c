// Direct screen-space marcher on a box actor: the ray, the march and the output colour
// (after VTK's lighting, which it replaces).
{
  vec2 cm_pixel = (gl_FragCoord.xy - cm_viewport.xy) / cm_viewport.zw;
  vec2 cm_ndc = cm_pixel * 2.0 - 1.0;
  // The ray runs from the near plane (f = 0) to this back-face fragment (f = 1); view z is
  // linear in f for perspective and parallel projections alike.
  vec3 cm_near = cm_viewPoint(cm_ndc, 0.0);
  vec3 cm_back = cm_viewPoint(cm_ndc, gl_FragCoord.z);
  vec3 cm_scene = cm_viewPoint(cm_ndc, texture(cm_sceneDepth, cm_pixel).r);
  vec3 cm_a = (cm_textureFromView * vec4(cm_near, 1.0)).xyz;
  vec3 cm_b = (cm_textureFromView * vec4(cm_back, 1.0)).xyz;
  // Slab test against the box of texel centres, without epsilons: axes the ray does not
  // move along bound nothing (or everything, when outside the slab).
  vec3 cm_lo = 0.5 / cm_dims;
  vec3 cm_hi = 1.0 - 0.5 / cm_dims;
  vec3 cm_d = cm_b - cm_a;
  vec3 cm_moving = step(vec3(1e-30), abs(cm_d));
  vec3 cm_safe = mix(vec3(1.0), cm_d, cm_moving);
  vec3 cm_t0 = (cm_lo - cm_a) / cm_safe;
  vec3 cm_t1 = (cm_hi - cm_a) / cm_safe;
  vec3 cm_inside = step(cm_lo, cm_a) * step(cm_a, cm_hi);
  vec3 cm_enter = mix(mix(vec3(1e30), vec3(-1e30), cm_inside), min(cm_t0, cm_t1), cm_moving);
  vec3 cm_leave = mix(mix(vec3(-1e30), vec3(1e30), cm_inside), max(cm_t0, cm_t1), cm_moving);
  float cm_f0 = max(0.0, max(cm_enter.x, max(cm_enter.y, cm_enter.z)));
  float cm_f1 = min(1.0, min(cm_leave.x, min(cm_leave.y, cm_leave.z)));
  float cm_dz = cm_back.z - cm_near.z;
  if (abs(cm_dz) > 0.0)
  {
    cm_f1 = min(cm_f1, (cm_scene.z - cm_near.z) / cm_dz);
  }
  if (!(cm_f1 > cm_f0))
  {
    discard;
  }
  vec3 cm_entry = mix(cm_a, cm_b, cm_f0);
  vec3 cm_exit = mix(cm_a, cm_b, cm_f1);
  vec4 cm_rgba = cm_march(cm_entry, cm_exit,
                          length(mat3(cm_worldFromTexture) * (cm_exit - cm_entry)));
  if (!(cm_rgba.a > 0.0))
  {
    discard;
  }
  // Blended as straight alpha by VTK's translucent pass: out = rgb * a + (1 - a) * dst.
  fragOutput0 = vec4(cm_rgba.rgb / cm_rgba.a, cm_rgba.a);
  vec4 cm_clip = cm_projection * vec4(mix(cm_near, cm_back, cm_f0), 1.0);
  gl_FragDepth = clamp(cm_clip.z / cm_clip.w * 0.5 + 0.5, 0.0, 1.0);
}
