"""The GLSL assembler: snippets, feature ``#define``s, VTK tags.

A technique declares a :class:`ShaderRecipe` (which snippet replaces which VTK tag, and
which features are on); the assembler loads the ``.glsl`` files, prefixes the defines so
the compiled shader holds only the scene's features, and applies them as VTK shader
replacements. Compile and link errors become :class:`ShaderCompileError`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import cache
from importlib import resources

from ..core.shader_errors import MARKER, watch_shader_errors  # noqa: F401 (re-exported)

SNIPPET_PACKAGE = "pv_cubemarch.glsl_replacements"


@cache
def _snippet_paths() -> dict:
    """Every ``glsl_replacements/<folder>/<name>.glsl`` by name (names are unique)."""
    found: dict = {}
    for folder in resources.files(SNIPPET_PACKAGE).iterdir():
        if not folder.is_dir():
            continue
        for path in folder.iterdir():
            if path.name.endswith(".glsl"):
                name = path.name[:-5]
                if name in found:
                    raise ValueError(f"GLSL snippet {name!r} exists in two folders; snippet "
                                     "names must be unique.")
                found[name] = path
    return found


@cache
def snippet_source(name: str) -> str:
    """The text of the snippet ``name`` (``glsl_replacements/<folder>/<name>.glsl``)."""
    path = _snippet_paths().get(name)
    if path is None:
        raise FileNotFoundError(f"No GLSL snippet {name!r}; known snippets: "
                                f"{sorted(_snippet_paths())}.")
    text = path.read_text()
    # VTK fills its tags after ours: a tag left in a snippet (even in a comment) gets VTK's
    # code pasted into it. Only a standalone pass may start with the system tag.
    stray = [tag for tag in re.findall(r"//VTK::[\w:]+", text) if tag != "//VTK::System::Dec"
             and tag != "//VTK::Output::Dec"]
    if stray:
        raise ValueError(f"GLSL snippet {name!r} contains VTK tag(s) {stray}; VTK would fill "
                         "them. Describe tags in words in comments.")
    return text


@cache
def snippet_requirements(name: str) -> tuple[str, ...]:
    """The snippets ``name`` declares it needs: its ``// requires: a, b`` header lines."""
    needed: list[str] = []
    for line in snippet_source(name).splitlines():
        if not line.startswith("//"):
            break
        head, _, rest = line[2:].strip().partition(":")
        if head == "requires":
            needed += [part.strip() for part in rest.split(",") if part.strip()]
    unknown = [n for n in needed if n not in _snippet_paths()]
    if unknown:
        raise ValueError(f"GLSL snippet {name!r} requires unknown snippet(s) {unknown}.")
    return tuple(needed)


def check_requirements(stages: dict[str, tuple[str, ...]]) -> None:
    """Raise ``ValueError`` naming a snippet whose required snippets its stage lacks."""
    for stage, names in stages.items():
        for name in names:
            missing = [n for n in snippet_requirements(name) if n not in names]
            if missing:
                raise ValueError(f"GLSL snippet {name!r} requires {missing} in the {stage} "
                                 f"shader, which has only {list(names)}; add them to the "
                                 "recipe before it.")


def define_lines(defines: dict[str, object]) -> str:
    """``#define`` lines for the enabled features (``False``/``None`` values are left out)."""
    lines = []
    for key, value in sorted(defines.items()):
        if value is False or value is None:
            continue
        text = "1" if value is True else str(value)
        lines.append(f"#define {key} {text}")
    return "\n".join(lines)


@dataclass(frozen=True)
class Replacement:
    """Replace the VTK ``tag`` of ``stage`` ('fragment' or 'vertex') by ``snippet``.

    ``snippet`` may be several names, concatenated in order (VTK keeps one replacement per
    tag). ``keep_tag`` puts the original tag back, so VTK still fills it: ``"after"`` the snippet
    (for declarations that VTK's code may use) or ``"before"`` it (to post-process what VTK
    computed there); ``False`` drops VTK's code for that tag.
    """

    tag: str
    snippet: str | tuple[str, ...]
    stage: str = "fragment"
    keep_tag: str | bool = False


@dataclass
class ShaderRecipe:
    """The snippets and feature switches of one shader.

    The defines are emitted once, in the first replacement, so every later snippet sees
    them; for a standalone pass, :meth:`fragment_source` assembles a whole shader.
    """

    replacements: list[Replacement] = field(default_factory=list)
    defines: dict[str, object] = field(default_factory=dict)
    standalone: str | tuple[str, ...] | None = None

    @property
    def snippet_names(self) -> tuple[str, ...]:
        """Names of every snippet the shader is built from."""
        names = [name for r in self.replacements for name in _names(r.snippet)]
        return tuple(names + (list(_names(self.standalone)) if self.standalone else []))

    def code_for(self, replacement: Replacement, first: bool) -> str:
        """The text that replaces ``replacement.tag``."""
        if replacement.keep_tag not in (False, "before", "after"):
            raise ValueError(f"keep_tag must be False, 'before' or 'after', got "
                             f"{replacement.keep_tag!r}.")
        parts = [replacement.tag] if replacement.keep_tag == "before" else []
        if first and self.defines:
            parts.append(define_lines(self.defines))
        for name in _names(replacement.snippet):
            parts.append(f"{MARKER}{name}")
            parts.append(snippet_source(name))
        if replacement.keep_tag == "after":
            parts.append(replacement.tag)
        return "\n".join(parts) + "\n"

    def check(self) -> None:
        """Raise ``ValueError`` if a snippet's declared requirements are not in its stage."""
        stages: dict[str, tuple[str, ...]] = {}
        for item in self.replacements:
            stages[item.stage] = stages.get(item.stage, ()) + _names(item.snippet)
        if self.standalone:
            stages["standalone"] = _names(self.standalone)
        check_requirements(stages)

    def apply(self, shader_property) -> None:
        """Install the replacements on a ``vtkShaderProperty`` (actor or volume)."""
        self.check()
        shader_property.ClearAllShaderReplacements()
        for index, item in enumerate(self.replacements):
            code = self.code_for(item, first=index == 0)
            if item.stage == "fragment":
                shader_property.AddFragmentShaderReplacement(item.tag, True, code, False)
            elif item.stage == "vertex":
                shader_property.AddVertexShaderReplacement(item.tag, True, code, False)
            else:
                raise ValueError(f"Unknown shader stage {item.stage!r}.")

    def fragment_source(self) -> str:
        """A complete fragment shader for a full-screen pass from the ``standalone`` snippets.

        The first snippet starts with the system tag; the defines follow it, then every
        snippet in order (libraries first, the one with ``main`` last).
        """
        if not self.standalone:
            raise ValueError("This recipe has no standalone fragment snippet.")
        self.check()
        names = _names(self.standalone)
        header, _, rest = snippet_source(names[0]).partition("\n")
        if header.strip() != "//VTK::System::Dec":
            raise ValueError(f"Snippet {names[0]!r} must start with //VTK::System::Dec.")
        parts = [header, define_lines(self.defines), f"{MARKER}{names[0]}", rest]
        for name in names[1:]:
            parts += [f"{MARKER}{name}", snippet_source(name)]
        return "\n".join(parts)


def box_recipe(declarations: tuple[str, ...], fragment: str | tuple[str, ...],
               defines: dict | None = None, vertex: tuple[str, ...] = ("ea_box_vertex",),
               vertex_declarations: tuple[str, ...] = (), layers: bool = False
               ) -> ShaderRecipe:
    """The shader of a box actor that marches its pixels: every technique's skeleton.

    ``declarations`` go before VTK's colour declarations, ``fragment`` runs where VTK's
    lighting would (after the fragment's own colour), and the box's vertex code places it;
    ``vertex_declarations`` add to the vertex stage's. ``layers``: a translucent fragment
    (writing ``cm_layerColor``) runs where VTK sets the depth instead, so that VTK's depth
    peeling tests and sorts it by the depth it writes, and its colour is written after.
    VTK's clipping of the box by its mapper's planes is left out: a plane cuts rays, not
    the box (a grid's mapper planes: ``ClipPlaneSetting.follow_mapper_planes``).
    """
    if layers:
        declarations = (*declarations, "layer_output_declarations")
        replacements = [Replacement("//VTK::Color::Dec", tuple(declarations), keep_tag="after"),
                        Replacement("//VTK::Depth::Impl", fragment, keep_tag="before"),
                        Replacement("//VTK::Light::Impl", "layer_output", keep_tag="before")]
    else:
        replacements = [Replacement("//VTK::Color::Dec", tuple(declarations),
                                    keep_tag="after"),
                        Replacement("//VTK::Light::Impl", fragment, keep_tag="before")]
    replacements.append(Replacement("//VTK::Clip::Impl", "box_not_clipped"))
    # every box is drawn grown by its corners' margin (box.box_polydata), first
    replacements.append(Replacement("//VTK::PositionVC::Dec",
                                    ("box_grow_declarations", *vertex_declarations),
                                    stage="vertex", keep_tag="after"))
    replacements.append(Replacement("//VTK::PositionVC::Impl", ("box_grow_vertex", *vertex),
                                    stage="vertex", keep_tag="before"))
    return ShaderRecipe(replacements, defines=dict(defines or {}))


def _names(snippet: str | tuple[str, ...]) -> tuple[str, ...]:
    return (snippet,) if isinstance(snippet, str) else tuple(snippet)
