// requires: ea_declarations
// What the blend modes other than 'composite' share: the opacity the transfer function
// gives a scalar per opacity_unit_distance (VTK's opacity table value), not accumulated.
uniform float cm_opacityUnit;   // the transfer function's opacity_unit_distance

float cm_opacityAt(float scalar)
{
  return 1.0 - exp(-cm_transfer(scalar).a * cm_opacityUnit);
}
