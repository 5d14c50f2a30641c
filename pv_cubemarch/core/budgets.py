"""Byte budgets a user may raise through an environment variable (file reads, textures)."""

from __future__ import annotations

import os


def budget_from_env(name: str, default: int, error: type[Exception]) -> int:
    """The bytes in environment variable ``name`` (``4e9`` allowed), else ``default``.

    A value that is not a number raises ``error`` naming the variable.
    """
    value = os.environ.get(name, "").strip()
    try:
        return int(float(value)) if value else int(default)
    except ValueError:
        raise error(f"{name}={value!r} is not a number of bytes; set it to e.g. 4e9 or "
                    "unset it") from None


def host_bytes_available() -> int | None:
    """Bytes of host memory the system says it can give now, or None where it cannot say.

    Linux's ``MemAvailable`` (free memory and what the page cache would give back), else the
    free pages ``sysconf`` counts; no more than the process's address-space limit leaves
    (``ulimit -v``, a batch job's cap) beyond what it maps now.
    """
    available = None
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    available = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if available is None:
        try:
            available = int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            pass
    left = _address_space_left()
    return left if available is None else available if left is None else min(available, left)


def _address_space_left() -> int | None:
    """What the address-space limit leaves the process now (None: no limit, or unknown)."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
        if limit == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/statm") as statm:
            mapped = int(statm.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        return max(int(limit) - mapped, 0)
    except (ImportError, OSError, ValueError, IndexError):
        return None


def host_budget(name: str, error: type[Exception]) -> int | None:
    """The bytes in environment variable ``name``, else 80 % of the memory available now.

    None where neither says (no limit known).
    """
    available = host_bytes_available()
    value = budget_from_env(name, -1 if available is None else int(0.8 * available), error)
    return None if value < 0 else value
