"""How long numba spent compiling: a clock on numba's ``numba:compile`` events.

A kernel compiles on its first call with new argument types (or, with ``cache=True``, loads its machine code from
numba's cache, which is not a compile event and costs milliseconds). A compile event nested in another (a kernel
calling a kernel not compiled yet) is counted once, with the outer one, so :attr:`CompileClock.seconds` is the wall
time this process spent inside numba's compiler. ``on_change(seconds)`` is called each time an outermost compilation
ends (the cell process writes it where its supervisor can read it even if the cell is then killed).

    with CompileClock() as clock:
        estimate = method.run(sequence)
    clock.seconds          # one-off compilation, to report apart from the per-step cost
"""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["CompileClock"]


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
