"""Hand-chosen mutants and the default-step tests that must catch each one.

Each mutant is a small plausible bug: one exact text replacement in one source file.  Run::

    .venv/bin/python tests/mutants.py            # every mutant
    .venv/bin/python tests/mutants.py 3 7        # some of them (numbers of ``--list``)
    .venv/bin/python tests/mutants.py --list

For each mutant the file is changed, its tests run (``pytest -x -q``, the default step's
markers: no slow test may be needed to catch a mutant), and the file restored byte for byte
(also on Ctrl-C).  A mutant is *killed* when pytest exits 1 (a test failed); it *survives* when
the tests pass (exit 0); anything else (collection error, exit 2-5) is reported as an error of the
list, as is a replacement text that no longer occurs exactly once.  The exit code is 0 only
when every mutant was killed.  The numba cache is keyed on the whole ``models/`` package, so a
mutant of a kernel recompiles the kernels it touches (up to a minute each).  The list is kept in
``tests/README.md`` ("Mutation run").
"""
from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    what: str           # the bug, in words
    file: str           # path from the repository root
    old: str            # exact text, occurring once
    new: str
    tests: tuple        # pytest node ids (or files) that must catch it


MUTANTS: list[Mutant] = [
]


def run(m: Mutant, python: str = sys.executable) -> tuple[str, float]:
    path = ROOT / m.file
    text = path.read_bytes()
    src = text.decode()
    if src.count(m.old) != 1:
        return f"ERROR: the text occurs {src.count(m.old)} times in {m.file}", 0.0
    t0 = time.perf_counter()
    try:
        path.write_bytes(src.replace(m.old, m.new).encode())
        p = subprocess.run([python, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *m.tests],
                           cwd=ROOT, capture_output=True, text=True)
    finally:
        path.write_bytes(text)
    dt = time.perf_counter() - t0
    if p.returncode == 1:
        failed = [ln.split(" ")[1] for ln in p.stdout.splitlines() if ln.startswith("FAILED ")]
        return "killed by " + (failed[0] if failed else "a failing test"), dt
    if p.returncode == 0:
        return "SURVIVED", dt
    tail = (p.stdout + p.stderr).strip().splitlines()[-1:] or [""]
    return f"ERROR: pytest exit {p.returncode}: {tail[0][:120]}", dt


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "--list" in argv:
        for i, m in enumerate(MUTANTS, 1):
            print(f"{i:3d}. {m.what}  [{m.file}]  <- {', '.join(m.tests)}")
        return 0
    pick = [int(a) for a in argv] or range(1, len(MUTANTS) + 1)
    bad = 0
    for i in pick:
        m = MUTANTS[i - 1]
        verdict, dt = run(m)
        bad += not verdict.startswith("killed")
        print(f"{i:3d}. {verdict:<90} {dt:6.1f} s  {m.what}", flush=True)
    print(f"{len(list(pick)) - bad} of {len(list(pick))} mutants killed")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
