"""numba compilation: a clock on numba's ``numba:compile`` events, and loading what numba's cache holds.

A kernel compiles on its first call with new argument types (or, with ``cache=True``, loads its machine code from
numba's cache, which is not a compile event and costs milliseconds). A compile event nested in another (a kernel
calling a kernel not compiled yet) is counted once, with the outer one, so :attr:`CompileClock.seconds` is the wall
time this process spent inside numba's compiler. ``on_change(seconds)`` is called each time an outermost compilation
ends (the cell process writes it where its supervisor can read it even if the cell is then killed).

    with CompileClock() as clock:
        estimate = method.run(sequence)
    clock.seconds          # one-off compilation, to report apart from the per-step cost

:func:`load_cached_kernels` loads into this process every machine code numba's on-disk cache holds for the project's
kernels (``cache=True``; only entries made for this machine, numba version and source). The local runner's worker
calls it before it forks each cell, so that a cell starts with the kernels its method's earlier cells compiled or
loaded instead of each cell reading them from disk again (≈ 0.4 s of CPU per EKF-SLAM cell).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

__all__ = ["CompileClock", "load_cached_kernels"]


class CompileClock:
    """Accumulates the wall time of numba compilations while installed (a context manager)."""

    def __init__(self, on_change: Callable[[float], None] | None = None):
        self.seconds = 0.0
        self._depth = 0
        self._start = 0.0
        self._on_change = on_change
        self._listener = None

    def __enter__(self) -> CompileClock:
        from numba.core import event

        clock = self

        class _Listener(event.Listener):
            def on_start(self, _event):
                if clock._depth == 0:
                    clock._start = time.perf_counter()
                clock._depth += 1

            def on_end(self, _event):
                clock._depth -= 1
                if clock._depth == 0:
                    clock.seconds += time.perf_counter() - clock._start
                    if clock._on_change is not None:
                        clock._on_change(clock.seconds)

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc) -> None:
        from numba.core import event

        event.unregister("numba:compile", self._listener)


def load_cached_kernels(prefix: str = "slamarena.") -> int:
    """Load every overload numba's cache holds for the module-level kernels of the imported modules named
    ``prefix…``, skipping those loaded already; returns how many were loaded.

    An entry is loaded only if numba would itself take it for that signature (its index key: the signature, this
    machine's codegen and the function's bytecode); ``Dispatcher.compile`` then finds it in the cache. Nothing is
    compiled here unless an indexed entry's data file vanished in between (numba then compiles it, as the cell would).
    The code loaded is the code a cell would load: results do not change."""
    from numba.core import sigutils
    from numba.core.dispatcher import Dispatcher

    loaded = 0
    for name, module in list(sys.modules.items()):
        if not name.startswith(prefix) or module is None:
            continue
        for kernel in list(vars(module).values()):
            cache = getattr(kernel, "_cache", None) if isinstance(kernel, Dispatcher) else None
            if cache is None or not hasattr(cache, "_cache_file"):  # not a dispatcher, or cache=False (NullCache)
                continue
            codegen = kernel.targetctx.codegen()
            for key in cache._cache_file._load_index():
                args, _ = sigutils.normalize_signature(key[0])
                if tuple(args) not in kernel.overloads and key == cache._index_key(key[0], codegen):
                    kernel.compile(key[0])
                    loaded += 1
    return loaded
