"""Progress bars for long steps: shown on a terminal, silent in logs and tests."""

from __future__ import annotations

from collections.abc import Iterable

from tqdm.auto import tqdm


def progress(iterable: Iterable | None = None, *, desc: str, total: int | None = None,
             enabled: bool | None = None):
    """Wrap ``iterable`` in a progress bar; ``enabled=None`` shows it only on a terminal."""
    return tqdm(iterable, desc=desc, total=total, disable=None if enabled is None else not enabled,
                leave=False, unit="item")
