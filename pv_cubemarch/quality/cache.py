"""Choices kept per scene, GPU and view size, in memory and in one JSON file.

The file is ``quality.json`` under ``PV_CUBEMARCH_CACHE_DIR`` (``~/.cache/pv_cubemarch``
by default). It is read as untrusted: an entry that is not a well-formed choice is ignored
and calibrated again.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

CACHE_ENV = "PV_CUBEMARCH_CACHE_DIR"
_MEMORY: dict[str, dict] = {}


def cache_file() -> Path:
    """Where choices are kept between sessions."""
    folder = os.environ.get(CACHE_ENV) or Path.home() / ".cache" / "pv_cubemarch"
    return Path(folder) / "quality.json"


def choice_key(*parts) -> str:
    """A digest of everything a choice depends on (arrays by their bytes and shape)."""
    digest = hashlib.blake2b(digest_size=20)
    for part in parts:
        if isinstance(part, np.ndarray):
            array = np.ascontiguousarray(part)
            digest.update(f"{array.dtype.str}{array.shape}".encode())
            digest.update(array.view(np.uint8).reshape(-1))
        else:
            digest.update(repr(part).encode())
        digest.update(b"\x00")
    return digest.hexdigest()


def _well_formed(entry) -> bool:
    return (isinstance(entry, dict) and isinstance(entry.get("setting"), dict)
            and all(isinstance(k, str) and isinstance(v, (int, float, str)) and not
                    isinstance(v, bool) for k, v in entry["setting"].items())
            and isinstance(entry.get("psnr"), (int, float))
            and isinstance(entry.get("met"), bool))


def _read() -> dict:
    try:
        data = json.loads(cache_file().read_text())
    except (OSError, ValueError, RecursionError):   # unreadable, not JSON, nested to death
        return {}
    return {k: v for k, v in data.items() if isinstance(k, str) and _well_formed(v)} \
        if isinstance(data, dict) else {}


def lookup(key: str) -> dict | None:
    """The stored choice for ``key`` (memory first, then the file), or None."""
    if key not in _MEMORY:
        found = _read().get(key)
        if found is None:
            return None
        _MEMORY[key] = found
    return _MEMORY[key]


def store(key: str, entry: dict) -> None:
    """Keep ``entry`` for ``key`` in memory and in the file (written whole, then renamed)."""
    _MEMORY[key] = entry
    path = cache_file()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        data = _read()
        data[key] = entry
        with tempfile.NamedTemporaryFile("w", dir=path.parent, delete=False,
                                         suffix=".tmp") as handle:
            json.dump(data, handle)
        os.replace(handle.name, path)
    except OSError:
        pass   # a read-only home: the choice is kept for this session only


def forget() -> None:
    """Drop the choices kept in memory (the file stays)."""
    _MEMORY.clear()
