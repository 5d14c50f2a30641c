// A box actor's corner moved outward by its margin (model coordinates; box_polydata's
// cm_grow): the box keeps its exact corners, so VTK's bounds (reset_camera,
// show_bounds) are the data's, while the drawn box is a little larger.
in vec3 cm_grow;
