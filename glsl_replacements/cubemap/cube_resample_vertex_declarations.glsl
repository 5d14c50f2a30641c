// Cube resampling pass, vertex stage: declarations. Each box vertex hands its point in
// texture coordinates and its view distance to the fragments, interpolated on the face.
uniform mat4 cm_inverseProjection;   // clip to view
uniform mat4 cm_textureFromView;     // view to volume texture coordinates
out vec3 cm_faceTexture;
out float cm_faceDistance;
