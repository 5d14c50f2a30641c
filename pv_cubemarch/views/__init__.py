"""Live views: a scene drawn on the server, its techniques' speed/accuracy knobs as controls.

:mod:`.knobs` says which knobs each kind of technique offers, :mod:`.session` applies them
to a plotter and measures the result (no GUI), :mod:`.app` builds the trame app (optional
dependency: ``pip install 'pv_cubemarch[jupyter]'``).
"""
