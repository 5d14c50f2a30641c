"""Progress bars for long steps: shown on a terminal, silent in logs and tests."""

from __future__ import annotations

from collections.abc import Iterable

from tqdm.auto import tqdm


def progress(iterable: Iterable | None = None, *, desc: str, total: int | None = None,
             enabled: bool | None = None):
    """Wrap ``iterable`` in a progress bar; ``enabled=None`` shows it only on a terminal.

    In a notebook ``tqdm.auto`` gives the notebook's bar; an empty step shows none.
    """
    if enabled is None and total is None and hasattr(iterable, "__len__") and not len(iterable):
        enabled = False
    if enabled is False and iterable is not None:
        return iterable   # no bar object at all (tqdm's first one makes a process lock)
    return tqdm(iterable, desc=desc, total=total, disable=None if enabled is None else not enabled,
                leave=False, unit="item")
