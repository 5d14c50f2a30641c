// Cube resampling pass, vertex stage (after VTK's position, before the far-plane clamp):
// the vertex's place on the box in texture coordinates and its distance along the view axis.
{
  vec4 cm_view = cm_inverseProjection * gl_Position;
  cm_view /= cm_view.w;
  cm_faceTexture = (cm_textureFromView * cm_view).xyz;
  cm_faceDistance = -cm_view.z;
}
