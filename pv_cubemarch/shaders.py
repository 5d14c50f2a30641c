"""The GLSL assembler: snippets from ``glsl_replacements/``, feature ``#define``s, VTK tags.

A technique declares a :class:`ShaderRecipe` (which snippet replaces which VTK tag, and
which features are on); the assembler loads the ``.glsl`` files, prefixes the defines so
the compiled shader holds only the scene's features, and applies them as VTK shader
replacements. Compile and link errors become :class:`ShaderCompileError`.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field
from functools import cache
from importlib import resources

import vtk

from .errors import ShaderCompileError

SNIPPET_PACKAGE = "pv_cubemarch.glsl_replacements"
MARKER = "// pv_cubemarch snippet: "


@cache
def snippet_source(name: str) -> str:
    """The text of ``glsl_replacements/<name>.glsl``."""
    root = resources.files(SNIPPET_PACKAGE)
    path = root / f"{name}.glsl"
    if not path.is_file():
        known = sorted(p.name[:-5] for p in root.iterdir() if p.name.endswith(".glsl"))
        raise FileNotFoundError(f"No GLSL snippet {name!r}; known snippets: {known}.")
    text = path.read_text()
    # VTK fills its tags after ours: a tag left in a snippet (even in a comment) gets VTK's
    # code pasted into it. Only a standalone pass may start with the system tag.
    stray = [tag for tag in re.findall(r"//VTK::[\w:]+", text) if tag != "//VTK::System::Dec"
             and tag != "//VTK::Output::Dec"]
    if stray:
        raise ValueError(f"GLSL snippet {name!r} contains VTK tag(s) {stray}; VTK would fill "
                         "them. Describe tags in words in comments.")
    return text


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

    def apply(self, shader_property) -> None:
        """Install the replacements on a ``vtkShaderProperty`` (actor or volume)."""
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
        names = _names(self.standalone)
        header, _, rest = snippet_source(names[0]).partition("\n")
        if header.strip() != "//VTK::System::Dec":
            raise ValueError(f"Snippet {names[0]!r} must start with //VTK::System::Dec.")
        parts = [header, define_lines(self.defines), f"{MARKER}{names[0]}", rest]
        for name in names[1:]:
            parts += [f"{MARKER}{name}", snippet_source(name)]
        return "\n".join(parts)


def _names(snippet: str | tuple[str, ...]) -> tuple[str, ...]:
    return (snippet,) if isinstance(snippet, str) else tuple(snippet)


def _snippet_at_error(log: str, snippets: tuple[str, ...]) -> tuple[str, ...]:
    """Snippets whose lines the driver's errors point at, found through our markers."""
    source_lines = {}
    for match in re.finditer(r"^\s*(\d+):\s?(.*)$", log, re.MULTILINE):
        source_lines[int(match.group(1))] = match.group(2)
    hits = []
    for match in re.finditer(r"\d+:(\d+)\(\d+\): error", log):
        line = int(match.group(1))
        for number in range(line, 0, -1):
            text = source_lines.get(number, "")
            if MARKER in text:
                hits.append(text.split(MARKER, 1)[1].strip())
                break
    found = tuple(dict.fromkeys(hits))
    return found or snippets


@contextlib.contextmanager
def watch_shader_errors(snippets: tuple[str, ...] = ()):
    """Turn GLSL compile/link errors reported by VTK inside the block into an exception."""
    from vtkmodules.util.misc import calldata_type

    window = vtk.vtkOutputWindow.GetInstance()
    messages: list[str] = []

    @calldata_type(vtk.VTK_STRING)
    def collect(_caller, _event, text):
        messages.append(str(text))

    tag = window.AddObserver(vtk.vtkCommand.ErrorEvent, collect)
    try:
        yield messages
    finally:
        window.RemoveObserver(tag)
    raise_for_shader_errors(messages, snippets)


def raise_for_shader_errors(messages: list[str], snippets: tuple[str, ...]) -> None:
    """Raise :class:`ShaderCompileError` if ``messages`` hold a shader compile or link error."""
    shader_lines = [m for m in messages if re.search(
        r"shader|link|compile", m, re.IGNORECASE)]
    if not shader_lines:
        return
    log = "\n".join(shader_lines)
    culprits = _snippet_at_error(log, snippets)
    driver = re.search(r"\d+:\d+\(\d+\): error:.*", log)
    first_error = driver.group(0) if driver else next(
        (line for line in log.splitlines() if "error" in line.lower()), "")
    raise ShaderCompileError(
        f"GLSL compile/link failed in snippet(s) {', '.join(culprits) or '(unknown)'}: "
        f"{first_error.strip()[:300]}", log=log, snippets=culprits)
