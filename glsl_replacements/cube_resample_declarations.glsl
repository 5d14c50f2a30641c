// Cube resampling pass (000 pass 3): declarations. The box's interior faces fetch the
// marched texels by cube mapping, with the 2x2 bilateral depth filter of section 3.2.
uniform vec3 cm_dims;                 // texels (points) of the volume along x, y, z
uniform sampler2D cm_cubeColor;       // premultiplied rgba per cube-map texel (atlas)
uniform sampler2D cm_cubeDepth;       // view distance where each texel's ray stopped
uniform float cm_occlusionSharpness;  // k_z: weight 0 once depths differ by 1/k_z texels
uniform float cm_texelWorld;          // world length of one cube-map texel (depth unit)
uniform sampler2D cm_sceneColor;      // the scene drawn so far, over the viewport
