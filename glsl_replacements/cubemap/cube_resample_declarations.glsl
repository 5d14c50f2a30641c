// Cube resampling pass (the cube map's pass 3): declarations. The box's interior faces fetch
// the marched texels by cube mapping, with the 2x2 bilateral depth filter.
uniform vec3 cm_dims;                 // texels (points) of the volume along x, y, z
uniform sampler2D cm_cubeColor;       // premultiplied rgba per cube-map texel (atlas)
uniform sampler2D cm_cubeDepth;       // view distance where each texel's ray stops
uniform float cm_occlusionSharpness;  // k_z: weight 0 once depths differ by 1/k_z texels
uniform float cm_texelWorld;          // world length of one cube-map texel (depth unit)
uniform vec2 cm_atlasAllocated;       // texels of the atlas textures (the used part may be less)
in vec3 cm_faceTexture;               // this fragment's point on the face (texture coords)
in float cm_faceDistance;             // and its distance along the view axis

// Distance along the view axis of a window depth (perspective or parallel).
float cm_viewDistance(float windowDepth)
{
  vec4 point = cm_inverseProjection * vec4(0.0, 0.0, windowDepth * 2.0 - 1.0, 1.0);
  return -point.z / point.w;
}
