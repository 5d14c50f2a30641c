// requires: surface_declarations, surface_dense
// The whole domain (conventional ray marching, kept as the baseline): each
// fragment of the domain box's back faces marches its pixel's ray from where it enters the
// domain (or the near plane) to where it leaves, every cm_stepLength cell units, each sample
// in its own cell's polynomial (dense: cell n's coefficients at 27 n, loaded when the ray
// enters the cell), the exit sampled last; the first sign change is bisected. Followed by
// surface_hit.glsl.
  vec3 cm_originView, cm_directionView, cm_origin, cm_direction;   // view and cell space
  vec2 cm_span;
  if (!cm_domainRay(cm_originView, cm_directionView, cm_origin, cm_direction, cm_span))
  {
    discard;
  }
  float cm_start = cm_span.x;
  float cm_cells = length(cm_direction) * (cm_span.y - cm_start);   // cell units
  int cm_count = max(int(ceil(cm_cells / cm_stepLength)), 1);
  float cm_dt = (cm_span.y - cm_start) * cm_stepLength / max(cm_cells, 1e-30);
  float cm_t0 = cm_start;
  float cm_f0 = cm_fieldAt(cm_origin + cm_direction * cm_t0);
  float cm_depth = cm_f0 == 0.0 ? cm_t0 : -1.0;
  for (int cm_k = 1; cm_k <= cm_count && cm_depth < 0.0; ++cm_k)
  {
    float cm_t1 = min(cm_start + float(cm_k) * cm_dt, cm_span.y);
    float cm_f1 = cm_fieldAt(cm_origin + cm_direction * cm_t1);
    if (cm_brackets(cm_f0, cm_f1))
    {
      for (int cm_r = 0; cm_r < cm_refineSteps; ++cm_r)
      {
        float cm_t = 0.5 * (cm_t0 + cm_t1);
        float cm_f = cm_fieldAt(cm_origin + cm_direction * cm_t);
        if (cm_sameSide(cm_f0, cm_f))
        {
          cm_t0 = cm_t;
          cm_f0 = cm_f;
        }
        else
        {
          cm_t1 = cm_t;
        }
      }
      cm_depth = cm_refineSteps == 0 ? cm_t1 : 0.5 * (cm_t0 + cm_t1);
    }
    cm_t0 = cm_t1;
    cm_f0 = cm_f1;
  }
  if (cm_depth < 0.0)
  {
    discard;
  }
  vec3 cm_point = cm_origin + cm_direction * cm_depth;
  cm_fieldAt(cm_point);   // loads the hit's cell
  vec3 cm_local = clamp(cm_point - vec3(cm_loadedCell), 0.0, 1.0);
  ivec3 cm_cellsPerAxis = ivec3(cm_gridDims);
  int cm_hitCell = cm_loadedCell.x + cm_cellsPerAxis.x * (cm_loadedCell.y
                                                          + cm_cellsPerAxis.y * cm_loadedCell.z);
