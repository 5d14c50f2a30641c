"""Scene import: the ``Scene`` model, USD stages (usd-core), meshes (trimesh), ``load_scene``."""
