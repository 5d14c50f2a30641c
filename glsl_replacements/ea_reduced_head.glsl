//VTK::System::Dec
// Reduced-resolution emission/absorption pass: its inputs and outputs (the first snippet).
//VTK::Output::Dec
in vec2 texCoord;
