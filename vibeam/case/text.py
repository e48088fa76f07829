"""Case files written back: the TOML text of the keys a case set (``vibeam fit`` and ``vibeam
identify`` write fitted cases)."""
from __future__ import annotations

import json
import re

import numpy as np


_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _tkey(k) -> str:
    return k if _BARE.match(str(k)) else json.dumps(str(k), ensure_ascii=False)


def _tval(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_tval(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def to_toml(data: dict, prefix: str = "") -> str:
    """TOML text of nested dicts/lists of scalars (tables and arrays of tables)."""
    lines = []
    for k, v in data.items():
        if v is None or isinstance(v, dict) or (isinstance(v, list) and v and all(isinstance(x, dict) for x in v)):
            continue
        lines.append(f"{_tkey(k)} = {_tval(v)}")
    for k, v in data.items():
        if isinstance(v, dict) and v:
            lines.append(f"\n[{prefix}{_tkey(k)}]")
            body = to_toml(v, prefix + _tkey(k) + ".")
            if body:
                lines.append(body)
    for k, v in data.items():
        if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for item in v:
                lines.append(f"\n[[{prefix}{_tkey(k)}]]")
                body = to_toml(item, prefix + _tkey(k) + ".")
                if body:
                    lines.append(body)
    return "\n".join(lines)


def case_dump(case) -> dict:
    """The keys a case file set (not the defaults filled in), grids' point counts as integers."""
    data = case.model_dump(exclude_unset=True, exclude_none=True)
    for tab, key in (("sweep", "Omega"), ("sweep", "frequency_hz"), ("map", "values")):
        g = data.get(tab, {}).get(key)
        if isinstance(g, list) and len(g) == 3 and float(g[2]).is_integer():
            g[2] = int(g[2])
    return data
