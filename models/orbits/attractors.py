"""Attractors of a stroboscopic map found by recurrences on a cell grid, and their basins.

The stroboscopic map ``P`` (the state at forcing phase 0, one forcing period later) of any
fidelity is iterated from an initial state; its samples are located on a grid of cells of
width ``h_i`` in each state coordinate ``x_i``, cell ``floor((x_i - o_i) / h_i)``.  Cells
carry a label -- part of attractor ``k``, part of the basin of attractor ``k``, or visited by
the trajectory being followed -- and a small finite-state machine decides, sample by sample,
what the trajectory does (Datseris & Wagemakers, *Effortless estimation of basins of
attraction*, Chaos 32, 023104, 2022; the recurrence method of Attractors.jl,
``AttractorsViaRecurrences``; Datseris, Luiz & Wagemakers, Chaos 33, 2023):

search
    a cell not visited before is labelled *visited*; ``n_found`` consecutive samples in cells
    this trajectory has already visited mean that it has settled on an attractor not yet
    known (a period-n orbit revisits its n cells at once, a chaotic or quasi-periodic set once
    its cells are covered); ``n_hit_attractor`` consecutive samples in the cells of a known
    attractor ``k`` decide ``k`` (``n_found`` consecutive samples in cells of known attractors,
    alternating between two that share cells on a coarse grid, decide the last); ``n_hit_basin`` consecutive samples in the basin cells of
    one attractor ``k`` decide ``k`` (the map is deterministic: a trajectory that keeps to
    cells whose states went to ``k`` goes there too, up to the cell size);
locate
    the next ``n_locate`` samples are the new attractor's: their cells are labelled as its
    cells and the samples kept (its stroboscopic set);
decided
    every cell the trajectory visited becomes basin of the attractor it reached, so later
    trajectories stop as soon as they enter them.

A trajectory that has neither decided after ``max_periods`` samples is *unsettled* (label
:data:`UNSETTLED`), never forced into an attractor; a state that is not finite, or a period
the solver could not compute, is *failed* (:data:`FAILED`).  Results are exact where the
attractor is resolved by the grid: two attractors sharing a cell, or a basin boundary finer
than a cell, are the method's limits (refine ``width``); basin hits may be switched off
(``basin_hits = False``) so that every trajectory is followed to an attractor's own cells.

Cells are stored sparsely in a numba typed dictionary keyed by a 64-bit hash of the integer
cell indices (FNV-1a): any number of state coordinates (the SDOF's ``(q, q', stuck)``, a
beam's ``2N + 1``) at no memory cost for the empty space.  Two cells share a key with
probability about ``n_cells^2 / 2^64`` (below 1e-7 for 10^6 cells).

Nothing here knows a fidelity: the map is any callable returning the states after
``1 ... n`` periods (:meth:`Recurrences.label`).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.typed import Dict

from ..interrupts import check as check_interrupt

#: labels of :meth:`Recurrences.label` that are not an attractor's index
UNSETTLED = -2
FAILED = -3

# cell kinds (low two bits of a cell's value; the rest is the attractor index or the stamp)
_ATTRACTOR = 1
_BASIN = 2
_VISITED = 3

# finite-state machine record (int64 array)
_MODE, _STAMP, _REVISITS, _ATT_HITS, _ATT_ID, _BAS_HITS, _BAS_ID, _STEPS, _NEW_ID, _LOCATED, \
    _N_VISITED, _DECISION, _NEXT_ID, _ANY_HITS = range(14)
_SEARCH, _LOCATE, _DONE = 0, 1, 2
# parameters (int64 array)
_N_FOUND, _N_LOCATE, _N_HIT_ATT, _N_HIT_BAS, _MAX_STEPS, _BASIN_HITS = range(6)

_NO_KEY = np.int64(-1)


@njit(cache=True)
def cell_key(x, origin, width):
    """64-bit key of the cell holding ``x`` (shape (d,)); -1 when ``x`` is not finite or
    farther than 2**40 cells from ``origin``."""
    h = np.int64(-3750763034362895579)          # FNV-1a offset basis 14695981039346656037
    for i in range(x.shape[0]):
        c = (x[i] - origin[i]) / width[i]
        if not (abs(c) < 1.0995e12):
            return _NO_KEY
        h = (h ^ np.int64(math.floor(c))) * np.int64(1099511628211)
    if h == _NO_KEY:
        h = np.int64(0)
    return h


@njit(cache=True)
def _decide(cells, st, visited, k, basin):
    """End the trajectory with label ``k``; with ``basin``, the cells it labelled become basin
    of ``k``."""
    stamp = st[_STAMP]
    for j in range(st[_N_VISITED]):
        key = visited[j]
        v = cells.get(key, np.int64(0))
        if v & 3 == _VISITED and v >> 2 == stamp:
            if k >= 0 and basin:
                cells[key] = (k << 2) | _BASIN
    st[_DECISION] = k
    st[_MODE] = _DONE


@njit(cache=True)
def _basin_hit(cells, st, visited, v, par):
    """A sample in the basin cell ``v`` of an attractor: ``n_hit_basin`` in a row of one
    attractor decide it (returns True)."""
    a = v >> 2
    if st[_BAS_HITS] > 0 and st[_BAS_ID] == a:
        st[_BAS_HITS] += 1
    else:
        st[_BAS_HITS] = 1
        st[_BAS_ID] = a
    if st[_BAS_HITS] >= par[_N_HIT_BAS]:
        _decide(cells, st, visited, a, True)
        return True
    return False


@njit(cache=True)
def feed(X, origin, width, cells, mine, st, visited, located, par):
    """Advance the recurrence machine over the samples ``X`` (shape (m, d)) in order.

    ``st`` (int64) is the machine's record, ``mine`` the cells this trajectory has been in (a
    typed dict, emptied for each trajectory), ``visited`` (int64, capacity ``max_periods + 1``)
    the keys it labelled, ``located`` (shape (n_locate, d)) receives a new
    attractor's samples, ``par`` the parameters (module docstring).  Returns the number of
    samples used; ``st[_DECISION]`` is the label once ``st[_MODE]`` is done (-1 before).
    """
    m = X.shape[0]
    for i in range(m):
        if st[_MODE] == _DONE:
            return i
        x = X[i]
        key = cell_key(x, origin, width)
        st[_STEPS] += 1
        if key == _NO_KEY:
            _decide(cells, st, visited, FAILED, False)
            return i + 1
        v = cells.get(key, np.int64(0))
        kind = v & 3
        if st[_MODE] == _LOCATE:
            if kind != _ATTRACTOR:
                cells[key] = (st[_NEW_ID] << 2) | _ATTRACTOR
            located[st[_LOCATED], :] = x
            st[_LOCATED] += 1
            if st[_LOCATED] >= par[_N_LOCATE]:
                _decide(cells, st, visited, st[_NEW_ID], par[_BASIN_HITS] != 0)
                return i + 1
            continue
        # search
        if kind == _ATTRACTOR:
            a = v >> 2
            if st[_ATT_HITS] > 0 and st[_ATT_ID] == a:
                st[_ATT_HITS] += 1
            else:
                st[_ATT_HITS] = 1
                st[_ATT_ID] = a
            st[_BAS_HITS] = 0
            st[_ANY_HITS] += 1
            if st[_ATT_HITS] >= par[_N_HIT_ATT]:
                _decide(cells, st, visited, a, par[_BASIN_HITS] != 0)
                return i + 1
            if st[_ANY_HITS] >= par[_N_FOUND]:
                # n_found samples in a row on known attractors' cells, never two in a row of one:
                # cells shared by two attractors (a grid too coarse to tell them apart); the last
                _decide(cells, st, visited, a, par[_BASIN_HITS] != 0)
                return i + 1
        elif key in mine:
            # a cell this trajectory has been in (whatever earlier ones made of it): a recurrence
            st[_ANY_HITS] = 0
            st[_ATT_HITS] = 0
            st[_REVISITS] += 1
            if kind == _BASIN and par[_BASIN_HITS] != 0:
                if _basin_hit(cells, st, visited, v, par):
                    return i + 1
            else:
                st[_BAS_HITS] = 0
            if st[_REVISITS] >= par[_N_FOUND]:
                st[_MODE] = _LOCATE
                st[_NEW_ID] = st[_NEXT_ID]
                st[_NEXT_ID] += 1
                st[_LOCATED] = 0
        else:
            # a cell new to this trajectory: empty, visited by an earlier trajectory that did not
            # settle, or the basin cell of an attractor
            st[_ANY_HITS] = 0
            st[_ATT_HITS] = 0
            st[_REVISITS] = 0
            mine[key] = 1
            if kind == _BASIN:
                if par[_BASIN_HITS] != 0 and _basin_hit(cells, st, visited, v, par):
                    return i + 1
            else:
                st[_BAS_HITS] = 0
                cells[key] = (st[_STAMP] << 2) | _VISITED
                if st[_N_VISITED] < visited.shape[0]:
                    visited[st[_N_VISITED]] = key
                    st[_N_VISITED] += 1
        if st[_STEPS] >= par[_MAX_STEPS]:
            _decide(cells, st, visited, UNSETTLED, False)
            return i + 1
    return m


def _new_cells():
    return Dict.empty(key_type=types.int64, value_type=types.int64)


@njit(cache=True)
def clear_cells(cells):
    """Empty a typed dict of cells in compiled code: the dict's ``clear()`` from Python is
    ``MutableMapping.clear``, one ``popitem`` (and ``len``) through the interpreter per key, about
    15 us a cell (a sixth of a basin's time on the two-sided Fig. 7 scene, issue 60)."""
    cells.clear()


class Recurrences:
    """Labels of initial states by the attractor they reach (module docstring).

    Parameters
    ----------
    origin, width : array_like, shape (d,)
        The cell grid: cell ``floor((x - origin) / width)`` (units of the state).
    n_found : int
        Consecutive samples in cells already visited that mean a new attractor (>= 2).
    n_locate : int
        Samples labelled as a new attractor's cells and kept as its stroboscopic set.
    n_hit_attractor, n_hit_basin : int
        Consecutive samples in a known attractor's cells, or in one attractor's basin cells,
        that decide it.
    max_periods : int
        Periods after which a trajectory that has not decided is :data:`UNSETTLED`.
    basin_hits : bool
        Decide by basin cells at all.

    Attributes
    ----------
    attractors : dict
        ``{k: ndarray (n_locate, d)}``, the stroboscopic set of each attractor found.
    periods : int
        Map iterations spent so far.
    """

    def __init__(self, origin, width, n_found: int = 100, n_locate: int = 1000, n_hit_attractor: int = 2,
                 n_hit_basin: int = 10, max_periods: int = 20000, basin_hits: bool = True):
        self.origin = np.ascontiguousarray(origin, dtype=float)
        self.width = np.ascontiguousarray(width, dtype=float)
        if self.origin.shape != self.width.shape or self.origin.ndim != 1:
            raise ValueError(f"origin {self.origin.shape} and width {self.width.shape}: two vectors of one size")
        if not (np.all(np.isfinite(self.width)) and np.all(self.width > 0) and np.all(np.isfinite(self.origin))):
            raise ValueError(f"width = {self.width}: finite numbers > 0 needed (and a finite origin)")
        for name, v, lo in (("n_found", n_found, 2), ("n_locate", n_locate, 1), ("n_hit_attractor", n_hit_attractor, 1),
                            ("n_hit_basin", n_hit_basin, 1), ("max_periods", max_periods, 1)):
            if int(v) != v or v < lo:
                raise ValueError(f"{name} = {v!r}: a whole number >= {lo}")
        self.par = np.array([n_found, n_locate, n_hit_attractor, n_hit_basin, max_periods, int(bool(basin_hits))],
                            np.int64)
        self.cells = _new_cells()
        self.mine = _new_cells()
        self.st = np.zeros(14, np.int64)
        self.visited = np.zeros(int(max_periods) + 2, np.int64)
        self.located = np.zeros((int(n_locate), self.origin.size))
        self.attractors: dict = {}
        self.periods = 0

    @property
    def d(self) -> int:
        return self.origin.size

    def label(self, step, x0, chunk: int = 16) -> int:
        """The label of the initial state ``x0`` (shape (d,)).

        ``step(x, n)`` iterates the map: it returns the states after ``1 ... n`` periods
        (shape (n, d)), or None when the solver could not compute them (label
        :data:`FAILED`).  Calls ask for ``chunk`` periods, then for more as the trajectory
        goes on (at most 256).

        Returns
        -------
        int
            An attractor's index (a key of :attr:`attractors`), :data:`UNSETTLED` or
            :data:`FAILED`.
        """
        st = self.st
        nxt = st[_NEXT_ID]
        st[:] = 0
        st[_NEXT_ID] = nxt
        self._stamp = getattr(self, "_stamp", 0) + 1
        st[_STAMP] = self._stamp
        st[_DECISION] = -1
        clear_cells(self.mine)
        x = np.ascontiguousarray(x0, dtype=float)
        feed(x[None, :], self.origin, self.width, self.cells, self.mine, st, self.visited, self.located, self.par)
        n = max(1, int(chunk))
        while st[_MODE] != _DONE:
            check_interrupt()     # a signal swallowed inside compiled code (numba's typed dict) stops here
            want = n
            if st[_MODE] == _LOCATE:
                want = max(1, min(int(self.par[_N_LOCATE] - st[_LOCATED]), 256))
            X = step(x, want)
            if X is None:
                self.periods += want
                from_st = FAILED
                _decide(self.cells, st, self.visited, from_st, False)
                break
            X = np.ascontiguousarray(X, dtype=float)
            used = feed(X, self.origin, self.width, self.cells, self.mine, st, self.visited, self.located, self.par)
            self.periods += used
            x = X[-1]
            n = min(2 * n, 256)
        k = int(st[_DECISION])
        if k >= 0 and k not in self.attractors:
            self.attractors[k] = self.located[:int(st[_LOCATED])].copy()
        return k

def set_distance(A, B, scale) -> float:
    """Symmetric mean nearest-neighbour distance between two stroboscopic sets (shapes (m, d)
    and (l, d)) in units of ``scale`` (shape (d,)): 0 for one set, about the sets' separation
    for two; what attractors are matched by from one parameter value to the next."""
    A = np.asarray(A, float) / scale
    B = np.asarray(B, float) / scale
    if A.size == 0 or B.size == 0:
        return math.inf
    A = A[:: max(1, A.shape[0] // 200)]
    B = B[:: max(1, B.shape[0] // 200)]
    D = np.sqrt(((A[:, None, :] - B[None, :, :]) ** 2).sum(-1))
    return 0.5 * (float(D.min(1).mean()) + float(D.min(0).mean()))
