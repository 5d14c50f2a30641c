"""A text USD layer's nesting, checked before USD parses it.

USD's text parser recurses per nested block: 20,000 nested prims took 13 s and 1.9 GB to
open, 100,000 (a 2.3 MB file) crash the process inside ``Usd.Stage.Open``. Real scenes nest
tens of levels; a layer nesting more than :data:`MAX_NESTING` blocks is refused unopened,
and so is a stage whose text layers (sublayers, references, payloads: every ``@asset@``
that names a text layer beside it) do.
"""

from __future__ import annotations

import re
from pathlib import Path

from ...core.errors import SceneLoadError

#: The deepest nesting of ``{ }`` blocks (prims, dictionaries) a text layer may have.
MAX_NESTING = 1000
#: Strings (triple-quoted first), asset paths and comments, whose braces do not nest, or a
#: brace.
_TOKENS = re.compile(rb'"""(?:[^"\\]|\\.|"(?!""))*"""|\'\'\'(?:[^\'\\]|\\.|\'(?!\'\'))*\'\'\''
                     rb'|"(?:[^"\\\n]|\\.)*"|\'(?:[^\'\\\n]|\\.)*\'|@[^@\n]*@|#[^\n]*|[{}]')


def check_layer_nesting(path: Path, seen: set | None = None) -> None:
    """Raise ``SceneLoadError`` if the text layer ``path``, or one it names, nests too deep.

    A binary layer is left to USD's own reader.
    """
    seen = set() if seen is None else seen
    path = Path(path).resolve()
    if path in seen or not path.is_file():
        return
    seen.add(path)
    with open(path, "rb") as handle:
        if not handle.read(5) == b"#usda":
            return   # a crate (binary) layer or a package: USD's own reader bounds it
        text = b"#usda" + handle.read()
    depth = deepest = 0
    for token in _TOKENS.finditer(text):
        mark = token.group()
        if mark.startswith(b"@"):   # an asset: another layer, checked in turn
            name = mark.strip(b"@").decode("utf-8", "replace")
            if Path(name).suffix.lower() in (".usda", ".usd") and "://" not in name:
                check_layer_nesting(path.parent / name, seen)
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
