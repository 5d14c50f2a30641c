"""GL plumbing, written once for every technique.

Textures, per-draw bindings, render-to-texture passes, frame inputs (the scene's depth and
colour, multisampling decided per frame), the GLSL assembler, the overlay renderer and box
actors.

Techniques describe what to bind and which snippets to compose; they never write binding code.
"""
