// Emission/absorption: declarations shared by every shader that composites a volume.
// cm_transferTable is a (CM_TABLE_SIZE x 1) RGBA float texture: rgb emission colour and
// extinction sigma per data unit (cm_mediumLength) in alpha.
uniform sampler2D cm_transferTable;
uniform vec2 cm_clim;              // scalar values of the first and last table rows
uniform float cm_stopOpacity;      // early ray termination once opacity exceeds this

// The one transfer lookup: rgb and extinction of a scalar in a table over clim.
vec4 cm_transferLookup(sampler2D table, vec2 clim, float scalar)
{
  float u = clamp((scalar - clim.x) / (clim.y - clim.x), 0.0, 1.0);
  // Row centres: u = 0 reads row 0 and u = 1 the last row, as numpy.interp does.
  float x = (0.5 + u * float(CM_TABLE_SIZE - 1)) / float(CM_TABLE_SIZE);
  return texture(table, vec2(x, 0.5));
}

vec4 cm_transfer(float scalar)
{
  return cm_transferLookup(cm_transferTable, cm_clim, scalar);
}

// The length of a texture-space path through the medium, in the data's own units (the
// grid's frame before the actor's placement: VTK measures opacity_unit_distance there, so
// a scaling user_matrix keeps the volume's look).
uniform mat4 cm_mediumFromTexture;

float cm_mediumLength(vec3 path)
{
  return length(mat3(cm_mediumFromTexture) * path);
}

// Composite one segment of length dt (data units) front to back into premultiplied rgba.
void cm_composite(inout vec4 rgba, vec4 emission_extinction, float dt)
{
  float alpha = 1.0 - exp(-emission_extinction.a * dt);
  float weight = (1.0 - rgba.a) * alpha;
  rgba.rgb += weight * emission_extinction.rgb;
  rgba.a += weight;
}
