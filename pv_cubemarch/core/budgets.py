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
    free pages ``sysconf`` counts.
    """
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def host_budget(name: str, error: type[Exception]) -> int | None:
    """The bytes in environment variable ``name``, else 80 % of the memory available now.

    None where neither says (no limit known).
    """
    available = host_bytes_available()
    value = budget_from_env(name, -1 if available is None else int(0.8 * available), error)
    return None if value < 0 else value
