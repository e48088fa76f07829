"""numba's inliner with one scope per copied callee (:mod:`vibeam.models._inline_copy`): the same code,
less copying.

The patch must not change what numba compiles (the LLVM IR of a kernel with inlined callees is
the same text with and without it, compared in two fresh interpreters) and must do what it is
for: the blocks of an inlined copy share one scope object (numba's own copy gives each block its
own), and the patch is gone from ``Scope`` once the inlining call returns.
"""
from __future__ import annotations

import hashlib
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import vibeam.models  # noqa: F401  (installs the patch)
from numba import njit
from numba.core import inline_closurecall as icc, ir

from vibeam.models import _inline_copy

# a caller with two inlined callees, each with loops and branches (several blocks, many variables)
SOURCE = textwrap.dedent('''
    import numpy as np
    from numba import njit

    @njit(inline="always")
    def clip_sum(a, lo, hi):
        s = 0.0
        for i in range(a.shape[0]):
            v = a[i]
            if v < lo:
                v = lo
            elif v > hi:
                v = hi
            s += v
        return s

    @njit(inline="always")
    def count_sign(a):
        pos = 0
        neg = 0
        for i in range(a.shape[0]):
            if a[i] > 0.0:
                pos += 1
            elif a[i] < 0.0:
                neg += 1
        return pos - neg

    @njit
    def caller(a, lo, hi):
        t = clip_sum(a, lo, hi)
        if t > 0.0:
            t += count_sign(a)
        else:
            t -= clip_sum(a, hi, lo) + count_sign(a)
        return t
''')

PROBE = '''
import hashlib, sys
import numpy as np
if sys.argv[1] == "plain":
    from numba.core import inline_closurecall as icc
    icc.InlineWorker.inline_ir.vibeam_shared_scope = True      # install() then leaves numba alone
import vibeam.models
ns = {"__name__": "vibeam.models._toy"}
exec(compile(sys.argv[2], "<caller>", "exec"), ns)
f = ns["caller"]
f(np.linspace(-1.0, 2.0, 7), -0.5, 1.5)
print(hashlib.sha256(f.inspect_llvm(f.signatures[0]).encode()).hexdigest())
'''


def _llvm_digest(mode):
    p = subprocess.run([sys.executable, "-c", PROBE, mode, SOURCE], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout.strip().splitlines()[-1]


def test_the_patch_compiles_the_same_llvm_ir():
    # checked once by hand on the quick start's integrate_work and _held_step: LLVM IR (1.9 MB) and
    # assembly identical, sha256 for sha256
    assert _llvm_digest("plain") == _llvm_digest("patch")


@pytest.mark.parametrize("module, ours", [("vibeam.models._toy", True), ("another_library.kernels", False)])
def test_the_blocks_of_an_inlined_copy_share_one_scope_and_the_patch_is_scoped(monkeypatch, module, ours):
    """vibeam's own inlined callees share one scope per copy; another library's inlining is numba's
    own (issue 56: a patch of numba's internals is scoped to vibeam's compile calls)."""
    assert _inline_copy.install() is True            # idempotent: already installed by vibeam.models
    assert getattr(icc.InlineWorker.inline_ir, "vibeam_shared_scope", False)
    scopes_per_copy = []
    original = icc._get_all_scopes

    def spy(blocks):
        scopes_per_copy.append((len(blocks), len({id(b.scope) for b in blocks.values()})))
        assert ("__deepcopy__" in vars(ir.Scope)) is ours     # patched while our inline_ir runs only
        return original(blocks)

    monkeypatch.setattr(icc, "_get_all_scopes", spy)
    ns: dict = {"__name__": module}
    exec(compile(SOURCE, "<caller>", "exec"), ns)
    a = np.linspace(-1.0, 2.0, 7)
    got = ns["caller"](a, -0.5, 1.5)
    want = np.clip(a, -0.5, 1.5).sum() + (np.sum(a > 0) - np.sum(a < 0))
    assert got == want
    assert len(scopes_per_copy) == 4                  # four inlined call sites
    for n_blocks, n_scopes in scopes_per_copy:
        # numba's own copy: one scope object per block
        assert n_blocks > 3 and n_scopes == (1 if ours else n_blocks)
    assert "__deepcopy__" not in vars(ir.Scope)       # gone after the inlining call
