// Direct screen-space marcher on a box actor: the frame's opaque depth (after the camera
// declarations, camera_declarations.glsl). VTK's volume mapper (CM_VTK_MAPPER) sets its rays
// up with the same code and reads its own copy of the opaque depth, so the depth sampler and
// its reader are left out there.

#ifndef CM_VTK_MAPPER
#ifdef CM_DEPTH_MULTISAMPLED
uniform sampler2DMS cm_sceneDepth;    // the frame's own multisampled depth (not written now)
uniform int cm_depthSamples;
uniform vec4 cm_depthViewport;        // its texels of the viewport (cm_viewport, unless the
                                      // box draws into a reduced target of ours)
#else
uniform sampler2D cm_sceneDepth;      // opaque depth of this frame, over the viewport
#endif

// Opaque depth under a window position (pixel is in [0, 1] over the viewport).
float cm_sceneDepthAt(vec2 pixel)
{
#ifdef CM_DEPTH_MULTISAMPLED
  // The samples sit around the pixel centre: their mean is the centre's depth on a surface
  // (one sample alone is off by a fraction of a pixel, much on grazing surfaces), and a
  // blend of surface and background at an outline, as the resolved colour is.
  ivec2 texel = ivec2(cm_depthViewport.xy + pixel * cm_depthViewport.zw);
  float sum = 0.0;
  for (int i = 0; i < cm_depthSamples; ++i)
  {
    sum += texelFetch(cm_sceneDepth, texel, i).r;
  }
  return sum / float(max(cm_depthSamples, 1));
#elif defined(CM_DEPTH_FRAMEBUFFER)
  // The window's own depth texture (not a copy): the nearest texel of the viewport.
  vec2 texel = clamp(floor(pixel * cm_viewport.zw), vec2(0.0), cm_viewport.zw - 1.0);
  return texelFetch(cm_sceneDepth, ivec2(cm_viewport.xy + texel), 0).r;
#else
  return texture(cm_sceneDepth, pixel).r;
#endif
}
#endif
