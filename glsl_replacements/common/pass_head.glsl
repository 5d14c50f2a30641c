//VTK::System::Dec
// Full-screen pass: its inputs and outputs (the first snippet of every standalone pass).
//VTK::Output::Dec
in vec2 texCoord;
