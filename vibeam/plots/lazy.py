"""``plt``: :mod:`matplotlib.pyplot`, imported when a figure is first drawn.

Importing pyplot costs 0.4-0.6 s (its backend and font set-up).  The modules that draw figures
import ``plt`` from here at their top, so a command that draws nothing (``vibeam run
--no-plots``, ``vibeam regress``, ``vibeam derive``) does not pay for it: the first attribute
read (``plt.subplots``, ``plt.close``) imports pyplot and returns its attribute, each later one
too (a module attribute replaced in tests is what is read).
"""
from __future__ import annotations

import importlib

__all__ = ["plt"]


class LazyPyplot:
    """A stand-in for :mod:`matplotlib.pyplot` that imports it on the first attribute read."""

    def __getattr__(self, name):
        return getattr(importlib.import_module("matplotlib.pyplot"), name)

    def __repr__(self) -> str:
        return "<matplotlib.pyplot, imported on first use>"


plt = LazyPyplot()
