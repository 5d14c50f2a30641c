//VTK::System::Dec
// A full-screen pass writing a known pattern into every target: target i holds
// (u, v, cm_value, i). Used to check render-to-texture, and as the smallest example pass.
//VTK::Output::Dec
in vec2 texCoord;
uniform float cm_value;

void main()
{
  for (int i = 0; i < CM_TARGETS; ++i)
  {
    gl_FragData[i] = vec4(texCoord, cm_value, float(i));
  }
}
