"""How long numba spends compiling kernels for first use, measured apart from run times.

numba compiles a kernel the first time it is called with new argument types and keeps the
machine code in its cache (``__pycache__``, or ``NUMBA_CACHE_DIR``), so a first run on a fresh
install pays seconds that no later run pays.  :class:`CompileClock` listens to numba's
``"numba:compile"`` events (numba's event API, ``numba.core.event``) in this process and sums the
outermost compilations, so that the sweep engine can report that time once, in one line, and
subtract it from the run times it prints and stores.  Compilations in other processes (pool
workers) are not seen here: the engine loads the kernels before it starts a pool, so that
workers inherit them.
"""
from __future__ import annotations

import time

from numba.core import event


class CompileClock:
    """Context manager: ``seconds`` spent compiling (outermost compilations) and ``count`` of
    specialisations compiled while it was open; ``notice`` (a callable, optional) is called once
    when the first compilation starts -- loading a kernel from numba's cache is not one -- so
    that a first run can say it is compiling before the wait, not after it (issue 44).

    Examples
    --------
    >>> with CompileClock() as c:            # doctest: +SKIP
    ...     run_something()
    >>> c.seconds, c.count
    """

    def __init__(self, notice=None):
        self.seconds = 0.0
        self.count = 0
        self._depth = 0
        self._t0 = 0.0
        self._listener = None
        self._notice = notice

    def __enter__(self):
        clock = self

        class _Listener(event.Listener):
            def on_start(self, ev):
                if clock._depth == 0:
                    clock._t0 = time.perf_counter()
                    if clock._notice is not None:      # said once, when the first compilation starts
                        notice, clock._notice = clock._notice, None
                        notice()
                clock._depth += 1

            def on_end(self, ev):
                clock._depth -= 1
                clock.count += 1
                if clock._depth == 0:
                    clock.seconds += time.perf_counter() - clock._t0

        self._listener = _Listener()
        event.register("numba:compile", self._listener)
        return self

    def __exit__(self, *exc):
        event.unregister("numba:compile", self._listener)
        return False
