"""What the machine can hold: the memory available now, to bound sizes before they are allocated.

A size (a grid grown by a scan, a simulated world of ``n_landmarks``) is checked against the memory available
before any work starts, so that an absurd value is rejected with a message that names it and the bound, not an
empty ``MemoryError`` (or the kernel's OOM killer) minutes later.
"""

from __future__ import annotations

import os

__all__ = ["available_memory", "fits_in_memory", "require_memory", "gib"]


def available_memory() -> int:
    """Bytes of memory available to a new allocation without swapping: Linux's ``MemAvailable`` (free memory plus the
    page cache and reclaimable slabs, /proc/meminfo); elsewhere the physical memory (``SC_PHYS_PAGES``)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def gib(n_bytes: float) -> str:
    """``n_bytes`` in GiB, for messages."""
    return f"{n_bytes / 2**30:.3g} GiB"


def fits_in_memory(n_bytes: float) -> tuple[bool, int]:
    """Whether ``n_bytes`` fit in the memory available now, and that memory [bytes]."""
    free = available_memory()
    return n_bytes <= free, free


def require_memory(n_bytes: float, what: str) -> None:
    """``ValueError`` unless ``n_bytes`` fit in the memory available now; ``what`` says what needs them and how the
    size was derived (it starts the message)."""
    fits, free = fits_in_memory(n_bytes)
    if not fits:
        raise ValueError(f"{what}: ≈ {gib(n_bytes)}, beyond the {gib(free)} of memory available on this machine")
