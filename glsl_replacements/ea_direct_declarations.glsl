// Direct screen-space marcher on a box actor: declarations (after the colour declarations).
// The box's back faces are drawn; each fragment reconstructs its eye ray from the window
// position, so the camera inside the box and a near plane cutting it need no special case.
uniform sampler3D cm_volume;          // data values, texel centres on the grid points
uniform sampler2D cm_sceneDepth;      // opaque depth of this frame, over the viewport
uniform vec4 cm_viewport;             // origin and size of the renderer, in pixels
uniform mat4 cm_inverseProjection;    // normalised device coordinates to view
uniform mat4 cm_projection;           // view to clip
uniform mat4 cm_textureFromView;      // view to volume texture coordinates

float cm_sampleScalar(vec3 texturePosition)
{
  return texture(cm_volume, texturePosition).r;
}

vec3 cm_viewPoint(vec2 ndc, float windowDepth)
{
  vec4 point = cm_inverseProjection * vec4(ndc, windowDepth * 2.0 - 1.0, 1.0);
  return point.xyz / point.w;
}
