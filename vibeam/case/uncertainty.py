"""``[uncertainty]``: the measured spread of a scene's parameters, sampled by scrambled Sobol' points.

The paper's rig has no single R: Table 1 gives R = 0.80 +- 0.08 (gap -0.1 mm), 0.72 +- 0.11 (0 mm) and
0.59 +- 0.16 (+0.1 mm), and Sec. 6 (Fig. 21) shows the gap moving during a sweep.  A case describes
that spread as distributions of named parameters (any name or path that ``[map]`` accepts,
:mod:`vibeam.case.paths`)::

    [uncertainty]
    samples = 64                  # scrambled Sobol' points (a power of 2)
    seed = 1
    [[uncertainty.parameter]]
    name = "R"
    distribution = "truncnorm"    # normal | truncnorm | uniform | lognormal | triangular
    mean = 0.80
    std = 0.08
    bounds = [0.0, 1.0]

Each distribution is scipy.stats' (``norm``, ``truncnorm``, ``uniform``, ``lognorm``, ``triang``); a
sample is the inverse distribution function of a scrambled Sobol' point (scipy.stats.qmc; Owen
scrambling, so the estimates are unbiased and their spread over seeds measures their error).  The
numbers of a distribution are the parameter's own, in its case unit:

========== ===================================================================================
normal     ``mean``, ``std``
truncnorm  ``mean``, ``std`` of the normal before truncation, ``bounds = [lo, hi]``
uniform    ``bounds = [lo, hi]``
lognormal  ``mean``, ``std`` of the (positive) parameter itself
triangular ``bounds = [lo, hi]``, ``mode``
========== ===================================================================================

References
----------
I. M. Sobol', USSR Comput. Math. Math. Phys. 7 (1967) 86-112; A. B. Owen, "Scrambling Sobol' and
Niederreiter-Xing points", J. Complexity 14 (1998) 466-489 (why a power of 2: the balance of the
first ``2^m`` points).
"""
from __future__ import annotations

import math
import sys
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from vibeam.case.paths import flat_key

__all__ = ["UncertaintyParameterSpec", "UncertaintySpec", "DISTRIBUTIONS", "MAX_SAMPLES", "MAX_PARAMETERS",
           "SUPPORT_TAIL"]

#: the most samples of one ``[uncertainty]`` (each is a whole sweep per run)
MAX_SAMPLES = 2 ** 16
#: the most parameters sampled at once (scipy's Sobol' engine takes up to 21201 dimensions; a
#: sweep per sample makes more than a few dozen pointless)
MAX_PARAMETERS = 32
#: the probability below and above which an unbounded distribution's support is checked against the
#: parameter's allowed range (no scrambled Sobol' point of up to MAX_SAMPLES lies closer to 0 or 1
#: than about 2^-40 in practice; a normal R of mean 0.8, std 0.08 reaches 1 at 1e-2 already)
SUPPORT_TAIL = 1e-12
#: the distributions and the keys each needs
DISTRIBUTIONS = {"normal": ("mean", "std"), "truncnorm": ("mean", "std", "bounds"), "uniform": ("bounds",),
                 "lognormal": ("mean", "std"), "triangular": ("bounds", "mode")}


class UncertaintyParameterSpec(BaseModel):
    """One ``[[uncertainty.parameter]]``: a parameter name or path and its distribution."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)

    name: Annotated[str, Field(min_length=1)]
    distribution: Literal["normal", "truncnorm", "uniform", "lognormal", "triangular"]
    mean: float | None = None
    std: Annotated[float, Field(gt=0.0)] | None = None
    bounds: list[float] | None = None
    mode: float | None = None

    @field_validator("name")
    @classmethod
    def _flat(cls, v):
        return flat_key(v)          # system.<key> / excitation.<key>: the flat key (vibeam.case.paths)

    @field_validator("bounds")
    @classmethod
    def _bounds(cls, v):
        if v is not None and (len(v) != 2 or not v[0] < v[1]):
            raise ValueError(f"allowed: [lo, hi] with lo < hi, got {v}")
        if v is not None and not math.isfinite(v[1] - v[0]):     # the distributions' scale hi - lo
            raise ValueError(f"allowed: [lo, hi] with hi - lo a finite number (at most {sys.float_info.max:.4g}), "
                             f"got {v}")
        return v

    @model_validator(mode="after")
    def _keys(self):
        need = DISTRIBUTIONS[self.distribution]
        missing = [k for k in need if getattr(self, k) is None]
        extra = [k for k in ("mean", "std", "bounds", "mode") if k not in need and getattr(self, k) is not None]
        if missing or extra:
            raise ValueError(f"distribution {self.distribution!r} takes {', '.join(need)}"
                             + (f"; missing {', '.join(missing)}" if missing else "")
                             + (f"; not {', '.join(extra)}" if extra else ""))
        if self.distribution == "lognormal" and not self.mean > 0.0:
            raise ValueError(f"a lognormal parameter is positive: its mean must be > 0, got {self.mean}")
        if self.distribution == "triangular" and not self.bounds[0] <= self.mode <= self.bounds[1]:
            raise ValueError(f"mode = {self.mode} lies outside bounds = {self.bounds}")
        if self.distribution == "truncnorm":
            lo, hi = ((b - self.mean) / (self.std * math.sqrt(2.0)) for b in self.bounds)
            if not 0.5 * (math.erf(hi) - math.erf(lo)) > 1e-12:          # the normal's probability in bounds
                raise ValueError(f"bounds = {self.bounds} hold no probability of the normal (mean {self.mean}, "
                                 f"std {self.std})")
        return self

    def frozen(self):
        """The scipy.stats distribution (a frozen ``rv_continuous``)."""
        from scipy import stats  # lazy: keeps scipy.stats (0.3 s) out of load_case

        d, m, s = self.distribution, self.mean, self.std
        if d == "normal":
            return stats.norm(loc=m, scale=s)
        if d == "truncnorm":
            a, b = ((x - m) / s for x in self.bounds)
            return stats.truncnorm(a, b, loc=m, scale=s)
        if d == "uniform":
            lo, hi = self.bounds
            return stats.uniform(loc=lo, scale=hi - lo)
        if d == "lognormal":         # the parameter's own mean and std: sigma^2 = ln(1 + (s/m)^2)
            v = math.log1p((s / m) ** 2)
            return stats.lognorm(math.sqrt(v), scale=m / math.sqrt(1.0 + (s / m) ** 2))
        lo, hi = self.bounds
        return stats.triang((self.mode - lo) / (hi - lo), loc=lo, scale=hi - lo)

    def support(self) -> tuple[float, float]:
        """The values a sample can take: the distribution's support, an unbounded end replaced by its
        :data:`SUPPORT_TAIL` quantile."""
        dist = self.frozen()
        with np.errstate(over="ignore", invalid="ignore"):     # beyond double precision: +-inf, refused by the caller
            lo, hi = dist.support()
            if not math.isfinite(lo):
                lo = float(dist.ppf(SUPPORT_TAIL))
            if not math.isfinite(hi):
                hi = float(dist.ppf(1.0 - SUPPORT_TAIL))
        return float(lo), float(hi)


class UncertaintySpec(BaseModel):
    """``[uncertainty]``: scrambled Sobol' samples of the parameters' distributions, one sweep of
    every sweep run per sample (module docstring)."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)

    samples: Annotated[int, Field(ge=2, le=MAX_SAMPLES)] = 64
    seed: Annotated[int, Field(ge=0)] = 0
    sobol: bool = False           # Saltelli's design and Sobol' indices (scipy.stats.sobol_indices)
    parameter: Annotated[list[UncertaintyParameterSpec], Field(min_length=1, max_length=MAX_PARAMETERS)]

    @field_validator("samples")
    @classmethod
    def _power_of_two(cls, v):
        if v & (v - 1):
            raise ValueError(f"allowed: a power of 2 (the balance of scrambled Sobol' points), e.g. "
                             f"{1 << (v.bit_length() - 1)} or {1 << v.bit_length()}")
        return v

    @field_validator("parameter")
    @classmethod
    def _unique(cls, v):
        names = [p.name for p in v]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"each parameter once; {dup} given twice")
        return v

    def runs_per_sample(self) -> int:
        """Model runs per sample: 1, or ``d + 2`` with ``sobol`` (Saltelli's design: A, B and A with
        each column from B)."""
        return len(self.parameter) + 2 if self.sobol else 1

    def saltelli(self, samples: int | None = None) -> tuple[np.ndarray, list]:
        """Saltelli's design for Sobol' indices: ``A`` and ``B`` (each ``samples`` rows, the two halves
        of ``2 d``-dimensional scrambled Sobol' points through the inverse distribution functions) and
        ``A_B^(i)``, ``A`` with column ``i`` from ``B``, for each parameter ``i``.

        Returns
        -------
        rows : ndarray, shape (samples (d + 2), d)
            ``A``, ``B``, then ``A_B^(1)`` ... ``A_B^(d)``.
        roles : list of str
            ``"A"``, ``"B"`` or ``"AB:<name>"`` per row.

        References
        ----------
        A. Saltelli et al., Comput. Phys. Commun. 181 (2010) 259-270 (the design and the estimators
        of scipy.stats.sobol_indices).
        """
        from scipy.stats import qmc  # lazy: keeps scipy.stats (0.3 s) out of load_case

        n = int(self.samples if samples is None else samples)
        if n < 2 or n & (n - 1):
            raise ValueError(f"samples = {n}: allowed a power of 2")
        d = len(self.parameter)
        u = qmc.Sobol(2 * d, scramble=True, seed=self.seed).random_base2(int(n).bit_length() - 1)
        x = np.column_stack([p.frozen().ppf(u[:, k % d] if k < d else u[:, k])
                             for k, p in enumerate(list(self.parameter) * 2)])
        A, B = x[:, :d], x[:, d:]
        rows, roles = [A, B], ["A"] * n + ["B"] * n
        for i, p in enumerate(self.parameter):
            ab = A.copy()
            ab[:, i] = B[:, i]
            rows.append(ab)
            roles += [f"AB:{p.name}"] * n
        return np.vstack(rows), roles

    def design(self, samples: int | None = None) -> np.ndarray:
        """The sampled parameter values.

        Parameters
        ----------
        samples : int, optional
            Instead of ``samples`` (a power of 2).

        Returns
        -------
        ndarray, shape (samples, n_parameters)
            Row ``i`` is sample ``i``: each column the inverse distribution function of column of
            the scrambled Sobol' points ``scipy.stats.qmc.Sobol(d, scramble=True, seed=seed)``.
        """
        from scipy.stats import qmc  # lazy: keeps scipy.stats (0.3 s) out of load_case

        n = int(self.samples if samples is None else samples)
        if n < 1 or n & (n - 1):
            raise ValueError(f"samples = {n}: allowed a power of 2")
        u = qmc.Sobol(len(self.parameter), scramble=True, seed=self.seed).random_base2(int(n).bit_length() - 1)
        return np.column_stack([p.frozen().ppf(u[:, k]) for k, p in enumerate(self.parameter)])
