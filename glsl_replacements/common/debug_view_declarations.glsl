// Debug view of a texture on a polydata actor: declarations.
// uv comes from the fragment's window position, so the actor must cover the viewport.
uniform vec2 cm_viewport;          // window size in pixels
#ifdef CM_VIEW_2D
uniform sampler2D cm_viewTexture;
#endif
#ifdef CM_VIEW_3D
uniform sampler3D cm_viewTexture;
uniform float cm_slice;            // texture z of the slice shown
#endif
#ifdef CM_VIEW_BUFFER
uniform samplerBuffer cm_viewTexture;
uniform int cm_bufferLength;
#endif
uniform vec4 cm_viewScale;         // texel * scale + bias is written
uniform vec4 cm_viewBias;
