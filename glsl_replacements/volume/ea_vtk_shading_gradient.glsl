// VTK's shading gradient, declared for any code a render pass adds to VTK's own lighting
// function (SSAO's reads it), which this path never calls; VTK declares it only inside that
// function, for its own shading, where its declaration hides this one.
vec4 shading_gradient = vec4(0.0);
