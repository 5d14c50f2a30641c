"""Arrays saved by numpy (``.npy``, ``.npz``), read within the memory budget, never unpickled."""

from __future__ import annotations

import numpy as np

from ..core.budgets import host_budget
from ..core.errors import SceneLoadError
from .image_files import ARRAY_BYTES_ENV

#: The suffixes of numpy's array files.
ARRAY_SUFFIXES = (".npy", ".npz")


def read_array_file(path, suffix: str, field_name, where: str, shown: str,
                    error=SceneLoadError) -> np.ndarray:
    """The array of a ``.npy`` (or the ``field_name`` array of a ``.npz``, else its first).

    Hostile headers are refused before any allocation: an array larger than the budget
    (:data:`ARRAY_BYTES_ENV`), a ``.npy`` shorter than its header says, a ``.npz`` member
    that inflates past the budget.
    """
    budget = host_budget(ARRAY_BYTES_ENV, error)
    try:
        if suffix == ".npy":
            mapped = np.load(str(path), mmap_mode="r", allow_pickle=False)
            size = mapped.nbytes
        else:
            archive = np.load(str(path), allow_pickle=False)
            # the arrays: members that are .npy files (others, say a readme, are bytes)
            keys = [n[:-4] for n in archive.zip.namelist() if n.endswith(".npy")]
            if not keys:
                raise error(f"{where}: {shown!r} holds no arrays.")
            if field_name and str(field_name) not in keys:   # not another array, in silence
                raise error(f"{where}: {shown!r} has no array named {field_name!r} "
                            f"(its arrays: {', '.join(keys)}).")
            key = str(field_name) if field_name else keys[0]
            size = archive.zip.getinfo(f"{key}.npy").file_size   # inflated, header included
    except error:
        raise
    except Exception as exc:
        raise error(f"{where}: could not read {shown!r}: {_unpickled(exc)}") from exc
    if budget is not None and size > budget:
        raise error(
            f"{where}: {shown!r} holds an array of {size:,} bytes, more than the "
            f"{budget:,} it may take ({ARRAY_BYTES_ENV}, by default 80 % of the memory "
            "available): read a smaller array, or stream it as a zarr store.")
    try:
        values = np.array(mapped) if suffix == ".npy" else archive[key]
        if not isinstance(values, np.ndarray):
            raise TypeError(f"its member {key!r} is not an array")
        return values
    except Exception as exc:
        raise error(f"{where}: could not read {shown!r}: {_unpickled(exc)}") from exc


def _unpickled(error: Exception) -> str:
    """Numpy's reason, less its advice to unpickle a file it cannot read as an array."""
    if "allow_pickle" in str(error):
        return ("it holds pickled Python objects, or its header is damaged; it is not read "
                "(a pickle can run code): save a plain numeric array with numpy.save")
    return str(error)
