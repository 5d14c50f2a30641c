"""A text USD layer's nesting, checked before USD parses it.

USD's text parser recurses per nested block: 20,000 nested prims took 13 s and 1.9 GB to
open, 100,000 (a 2.3 MB file) crash the process inside ``Usd.Stage.Open``. Real scenes nest
tens of levels; a layer nesting more than :data:`MAX_NESTING` blocks is refused unopened,
and so is a stage whose text layers (sublayers, references, payloads: every ``@asset@``
that names a text layer beside it, an expression such as ``@`"./${SHOT}.usda"`@`` as the
layers' ``expressionVariables`` evaluate it) do.
"""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

from ...core.errors import SceneLoadError

#: The deepest nesting of ``{ }`` blocks (prims, dictionaries) a text layer may have.
MAX_NESTING = 1000
#: Strings (triple-quoted first), asset paths and comments, whose braces do not nest, or a
#: brace.
_TOKENS = re.compile(rb'/\*.*?\*/|//[^\n]*'
                     rb'|"""(?:[^"\\]|\\.|"(?!""))*"""|\'\'\'(?:[^\'\\]|\\.|\'(?!\'\'))*\'\'\''
                     rb'|"(?:[^"\\\n]|\\.)*"|\'(?:[^\'\\\n]|\\.)*\'|@[^@\n]*@|#[^\n]*|[{}]',
                     re.DOTALL)


def check_layer_nesting(path: Path, seen: set | None = None,
                        variables: dict | None = None) -> None:
    """Raise ``SceneLoadError`` if the text layer ``path``, or one it names, nests too deep.

    A crate (binary) layer is read by Sdf for the layers it names; a ``.usdz`` package's
    text layers are scanned in place. ``variables``: the expression variables of the
    layers that name this one (they override its own).
    """
    seen = set() if seen is None else seen
    variables = variables or {}
    try:
        path = Path(path).resolve()
        key = (path, repr(sorted(variables.items())))   # another context may name others
        if key in seen or not path.is_file():
            return   # USD says what it cannot open
    except (OSError, RuntimeError, ValueError):   # a loop of links, a name too long
        return
    seen.add(key)
    with open(path, "rb") as handle:
        head = handle.read(8)
        if head.startswith(b"#usda"):
            _scan_text(head + handle.read(), path, path.parent, seen, variables)
        elif head.startswith(b"PK"):
            _scan_package(path, seen, variables)
        elif head.startswith(b"PXR-USDC"):
            _scan_crate(path, seen, variables)


def _scan_package(path: Path, seen: set, variables: dict) -> None:
    """Each text layer inside a ``.usdz`` (a zip, stored uncompressed)."""
    try:
        with zipfile.ZipFile(path) as package:
            for member in package.infolist():
                if Path(member.filename).suffix.lower() in (".usda", ".usd"):
                    with package.open(member) as handle:
                        text = handle.read()
                    if text.startswith(b"#usda"):
                        _scan_text(text, Path(f"{path}[{member.filename}]"), path.parent,
                                   seen, variables)
    except (zipfile.BadZipFile, OSError, RuntimeError):
        return   # USD says what it cannot open


def _scan_crate(path: Path, seen: set, variables: dict) -> None:
    """The layers a crate layer names (Sdf reads a crate's specs without recursion)."""
    layer = _sdf_layer(path)
    if layer is None:
        return
    variables = {**dict(layer.expressionVariables), **variables}
    for name in layer.GetCompositionAssetDependencies():
        _follow(str(name), path.parent, seen, variables)


def _sdf_layer(path: Path):
    """``path`` opened by Sdf (safe once its nesting is checked), or ``None``."""
    from pxr import Sdf, Tf

    try:
        return Sdf.Layer.FindOrOpen(str(path))
    except Tf.ErrorException:
        return None


def _follow(name: str, folder: Path, seen: set, variables: dict) -> None:
    """Check the layer an asset path names (an expression evaluated), where it is a file."""
    if name.startswith("`"):
        from pxr import Sdf

        result = Sdf.VariableExpression(name).Evaluate(variables)
        if result.errors or not isinstance(result.value, str):
            return   # USD cannot resolve it either, and opens nothing for it
        name = result.value
    name = name.split(":SDF_FORMAT_ARGS:")[0]
    if Path(name).suffix.lower() in (".usda", ".usd", ".usdc", ".usdz") and "://" not in name:
        check_layer_nesting(folder / name, seen, variables)


def _scan_text(text: bytes, path: Path, folder: Path, seen: set, variables: dict) -> None:
    """Raise if ``text`` nests blocks too deep; then check the layers its assets name."""
    depth = deepest = 0
    names = []
    for token in _TOKENS.finditer(text):
        mark = token.group()
        if mark.startswith(b"@"):   # an asset: another layer, checked once this one is
            names.append(mark.strip(b"@").decode("utf-8", "replace"))
        elif mark == b"{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > MAX_NESTING:
                    raise SceneLoadError(
                        f"USD file {str(path)!r} nests blocks more than {MAX_NESTING} deep "
                        f"(at byte {token.start():,}): refused unopened, as USD's parser "
                        "would crash or exhaust memory on it.")
        elif mark == b"}":
            depth = max(depth - 1, 0)
    if any(name.startswith("`") for name in names):   # its own variables: Sdf may read it now
        layer = _sdf_layer(path)
        own = dict(layer.expressionVariables) if layer is not None else {}
        variables = {**own, **variables}
    for name in names:
        _follow(name, folder, seen, variables)
