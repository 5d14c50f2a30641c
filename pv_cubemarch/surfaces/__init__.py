"""Polynomial active-cell surfaces: f = 0 of a quadratic B-spline field, per pixel.

``options`` (what the user sets), ``technique`` (the active cells' boxes or the domain's
box, their bindings and the state behind ``actor.cubemarch``; registers the techniques
``'active'`` and ``'full'`` of kind ``'surface'``).
"""
