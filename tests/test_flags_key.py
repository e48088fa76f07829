"""numba's compile flags hashed and compared by :mod:`vibeam.models._flags_key`: numba's own results.

The oracle is numba's definition, written out here: ``hash(tuple(sorted(flags.values())))`` and
``a.values() == b.values()``.  Flags objects with random options set (some set to their
defaults, which must still compare equal to unset ones) are hashed and compared both ways.
"""
from __future__ import annotations

import random

import vibeam.models  # noqa: F401  (installs the patch)
from numba.core import targetconfig
from numba.core.compiler import Flags

from vibeam.models import _flags_key


def _numba_hash(f):
    return hash(tuple(sorted(f.values())))


def _random_flags(rng):
    f = Flags()
    names = sorted(Flags.options)
    for name in rng.sample(names, rng.randint(0, 6)):
        opt = Flags.options[name]
        if opt.type is bool:
            setattr(f, name, rng.random() < 0.5)          # half of them set to the default
        else:
            try:
                setattr(f, name, opt.default)             # set explicitly, equal to the default
            except Exception:                             # an option whose type refuses its default
                pass
    return f


def test_installed_and_idempotent():
    assert targetconfig.TargetConfig.vibeam_fast_key is True
    assert _flags_key.install() is True
    assert targetconfig.TargetConfig.__hash__.__module__ == _flags_key.__name__


def test_hash_and_equality_are_numbas():
    rng = random.Random(7)
    flags = [_random_flags(rng) for _ in range(300)] + [Flags(), Flags()]
    n_equal = 0
    for a in flags:
        assert hash(a) == _numba_hash(a)
    for _ in range(3000):
        a, b = rng.choice(flags), rng.choice(flags)
        want = a.values() == b.values()
        assert (a == b) is want
        assert (a != b) is (not want)
        n_equal += want
    # both outcomes were exercised, including equal flags whose explicitly set options differ
    assert 0 < n_equal < 3000
    a, b = Flags(), Flags()
    b.nrt = Flags.options["nrt"].default
    assert a._values != b._values and a == b


def test_flags_as_cache_keys_find_their_entries():
    # the use numba makes of them: a dict keyed on (types, flags) hit by another, equal, flags object
    a, b = Flags(), Flags()
    a.nrt = b.nrt = True
    cache = {(("int64",), a): 1}
    assert cache[(("int64",), b)] == 1
    c = Flags()
    c.nrt = False
    assert (("int64",), c) not in cache
