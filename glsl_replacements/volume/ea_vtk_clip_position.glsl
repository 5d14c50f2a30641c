// VTK's volume mapper, vertex stage (after VTK's clip position, which it replaces): the box
// corner projected by one matrix made in double precision on the CPU, camera-relative. VTK
// multiplies its projection, view and volume matrices on the GPU in float32; far from the
// origin those hold world-sized translations that cancel, and the box moves by pixels.
gl_Position = cm_clipFromIndex * vec4(in_vertexPos.xyz, 1.0);
