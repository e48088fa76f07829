"""What the API's functions share: a private temporary folder for in-memory results, a Figure
saved when asked, and the checks of the arguments every run takes."""
from __future__ import annotations

import shutil
import tempfile
import weakref

from vibeam.case.arguments import check_flag, check_jobs, check_path
from vibeam.errors import quote_value


class PrivateFolder:
    """A temporary folder removed with its last reference (or at exit), quietly: the file behind an
    in-memory result's ``to_xarray()`` lives there."""

    def __init__(self, prefix: str):
        self.name = tempfile.mkdtemp(prefix=prefix)
        self._finalizer = weakref.finalize(self, shutil.rmtree, self.name, True)

    def cleanup(self) -> None:
        self._finalizer()


def saved(fig, path):
    """``fig``, saved atomically to ``path`` first when both are given."""
    if fig is not None and path is not None:
        # by the module: its save_figure may be replaced (tests)
        from vibeam.plots import sweep as plot_sweep  # lazy: matplotlib.pyplot (0.5 s) out of `vibeam derive`

        plot_sweep.save_figure(fig, path)
    return fig


def check_run_args(jobs, out, executor, **flags):
    """``(jobs, out)`` checked by the rules of ``--jobs`` and a path, each flag a bool and the
    executor one with ``submit`` (TypeError/ValueError naming the argument)."""
    jobs = check_jobs(jobs)
    out = check_path(out, "out")
    for name, flag in flags.items():
        check_flag(flag, name)
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise TypeError(f"executor = {quote_value(executor)}: not an executor; allowed: a "
                        f"concurrent.futures.Executor (with submit) or None")
    return jobs, out
