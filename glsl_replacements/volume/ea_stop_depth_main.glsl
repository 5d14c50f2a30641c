// requires: camera_declarations, ea_declarations, blend_composite, ea_march, screen_ray
// Where each pixel's ray stops (opacity past cm_stopOpacity), as a window depth; 1 where it
// never does. The rays and steps are the box marcher's, one per pixel of the viewport, but
// not cut by the opaque scene: the depth is never nearer than where the image's ray stops,
// so what lies behind it (a streamed volume's bricks) reaches no pixel.
void main()
{
  vec3 entry, exit, entryView, exitView;
  float depth = 1.0;
  if (cm_screenRay(texCoord * 2.0 - 1.0, 1.0, entry, exit, entryView, exitView))
  {
    cm_march(entry, exit, cm_mediumLength(exit - entry));
    if (cm_stopped)
    {
      vec3 span = exit - entry;
      float along = dot(cm_stopPosition - entry, span) / max(dot(span, span), 1e-30);
      vec4 clip = cm_projection * vec4(mix(entryView, exitView, along), 1.0);
      depth = clamp(clip.z / clip.w * 0.5 + 0.5, 0.0, 1.0);
    }
  }
  gl_FragData[0] = vec4(depth, 0.0, 0.0, 1.0);
}
