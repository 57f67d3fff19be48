"""Short reprs for the dataclasses that hold arrays: shapes and dtypes, not the numbers.

A record of 900 estimates printed by the dataclass's own repr is some
10,000 characters of numbers (numpy abbreviates only arrays of more than 1000
elements); :func:`summary_repr` prints ``speed_e=<float64 (900,)>`` instead,
and small arrays (at most :data:`SHOW` elements) in full.  A class takes it
with ``__repr__ = summary_repr`` in its body.
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["summary_repr", "short", "SHOW"]

#: Arrays of at most this many elements are printed with their values.
SHOW = 6


def short(value) -> str:
    """A value's repr with every array in it (also in a dict, list or tuple) as its dtype and shape."""
    if isinstance(value, np.ndarray):
        if value.size <= SHOW:
            return np.array2string(value, separator=", ", precision=6, threshold=SHOW)
        return f"<{value.dtype} {value.shape}>"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k!r}: {short(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)) and any(isinstance(v, (np.ndarray, dict, list, tuple)) for v in value):
        inner = ", ".join(short(v) for v in value)
        return f"[{inner}]" if isinstance(value, list) else f"({inner}{',' if len(value) == 1 else ''})"
    if hasattr(value, "sizes") and hasattr(value, "dims") and type(value).__module__.startswith("xarray"):
        return f"<{type(value).__name__} {dict(value.sizes)}>"
    return repr(value)


def summary_repr(self) -> str:
    """``ClassName(field=value, ...)`` of a dataclass, arrays as ``<dtype shape>`` (:func:`short`)."""
    fields = ", ".join(f"{f.name}={short(getattr(self, f.name))}" for f in dataclasses.fields(self) if f.repr)
    return f"{type(self).__name__}({fields})"
