// requires: surface_declarations, surface_records
// Dense coefficients (technique 'full'): the field at any cell-space point, from the cell it
// lies in (clamped into the grid), whose coefficients are loaded when the point changes cell.
ivec3 cm_loadedCell = ivec3(-1);

float cm_fieldAt(vec3 point)
{
  ivec3 dims = ivec3(cm_gridDims);
  ivec3 cell = clamp(ivec3(floor(point)), ivec3(0), dims - 1);
  if (any(notEqual(cell, cm_loadedCell)))
  {
    cm_loadedCell = cell;
    cm_loadCell(cell.x + dims.x * (cell.y + dims.y * cell.z));
  }
  return cm_field(point - vec3(cell));
}
