"""Input checks shared by every public function.

Each check raises ValueError or TypeError whose message names the field, the
offending value and the allowed range, so that a user reading the message
knows what to change.  Never use ``assert`` for these: it vanishes under
``python -O``.
"""

from __future__ import annotations

import math
import numbers

import numpy as np


def check_real(name: str, value, *, lo=None, hi=None, lo_open=False, hi_open=False) -> float:
    """Return ``value`` as a float after checking it is finite and in range.

    Parameters
    ----------
    name : str
        Field name used in the error message.
    value : real number
    lo, hi : float, optional
        Bounds of the allowed range.
    lo_open, hi_open : bool
        Exclude the bound itself.
    """
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    v = float(value)
    rng = _range_text(lo, hi, lo_open, hi_open)
    if not math.isfinite(v):
        raise ValueError(f"{name}={value!r} is not finite; allowed: {rng}")
    if lo is not None and (v < lo or (lo_open and v == lo)):
        raise ValueError(f"{name}={value!r} is out of range; allowed: {rng}")
    if hi is not None and (v > hi or (hi_open and v == hi)):
        raise ValueError(f"{name}={value!r} is out of range; allowed: {rng}")
    return v


def check_int(name: str, value, *, lo=None, hi=None) -> int:
    """Return ``value`` as an int after checking type and range."""
    if isinstance(value, bool) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    v = int(value)
    rng = _range_text(lo, hi, False, False)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ValueError(f"{name}={v} is out of range; allowed: {rng}")
    return v


def check_choice(name: str, value, choices) -> str:
    """Return ``value`` if it is one of ``choices``."""
    if value not in choices:
        raise ValueError(f"{name}={value!r} is not allowed; allowed: {', '.join(map(repr, choices))}")
    return value


def check_seed(name: str, value) -> int:
    """Seeds are non-negative integers below 2**63."""
    return check_int(name, value, lo=0, hi=2**63 - 1)


def check_bool(name: str, value) -> bool:
    """Return ``value`` as a bool after checking it is one (``numpy.bool_`` too; not 0/1 or a string)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool (true or false), got {type(value).__name__} {value!r}")
    return bool(value)


def check_str(name: str, value, *, allow_empty: bool = False) -> str:
    """Return ``value`` after checking it is a string (non-empty unless ``allow_empty``)."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, got {type(value).__name__} {value!r}")
    if not allow_empty and not value:
        raise ValueError(f"{name} must not be empty; allowed: a non-empty string")
    return value


def check_vec3(name: str, value, *, bound: float = 1e6) -> tuple:
    """Return a 3-vector [m] as a tuple of floats, each finite and within ``+-bound``."""
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ValueError(f"{name} must be a list of 3 numbers [m], got {value!r}")
    return tuple(check_real(f"{name}[{i}]", v, lo=-bound, hi=bound) for i, v in enumerate(value))


def check_tuple(name: str, value, n: int, item_check):
    """Check a length-``n`` sequence element by element with ``item_check(label, v)``."""
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise TypeError(f"{name} must be a sequence of {n} values, got {value!r}")
    if len(value) != n:
        raise ValueError(f"{name} must have {n} values, got {len(value)}: {tuple(value)!r}")
    return tuple(item_check(f"{name}[{i}]", v) for i, v in enumerate(value))


def check_memory(name: str, nbytes: int, *, fraction: float = 0.8) -> None:
    """Refuse an allocation larger than ``fraction`` of the available memory."""
    avail = available_memory()
    if avail is not None and nbytes > fraction * avail:
        raise ValueError(
            f"{name} needs about {nbytes / 2**30:.2f} GiB, more than {fraction:.0%} of the "
            f"{avail / 2**30:.2f} GiB available; allowed: at most {fraction * avail / 2**30:.2f} GiB"
        )


def available_memory() -> int | None:
    """Bytes of memory this process may still allocate, or None if unknown.

    psutil's available memory (any platform; on Linux the kernel's
    ``MemAvailable``), capped by Dask's :data:`distributed.system.MEMORY_LIMIT`
    (the least of the host's memory, a cgroup limit: Slurm, containers, and
    ``RLIMIT_RSS``) less this process's resident memory: inside a cgroup of
    4 GiB on a host with 200 GiB free, 4 GiB less what the process holds.
    """
    try:
        import psutil  # a dependency of dask.distributed (imported here: only the checks need it)
    except ImportError:
        return None
    try:
        vm = psutil.virtual_memory()
        avail = int(vm.available)
        limit = _memory_limit()
        if limit is not None and limit < vm.total:
            avail = min(avail, max(0, limit - int(psutil.Process().memory_info().rss)))
    except (OSError, AttributeError, RuntimeError):
        return None
    return avail


def _memory_limit() -> int | None:
    """Dask's limit of this system's memory (host, cgroup, RLIMIT_RSS) [bytes], or None without distributed."""
    try:
        from distributed.system import MEMORY_LIMIT  # read once, at its first import (cgroups v1 and v2)
    except ImportError:
        return None
    return int(MEMORY_LIMIT)


def _range_text(lo, hi, lo_open, hi_open) -> str:
    if lo is None and hi is None:
        return "any finite value"
    if hi is None:
        return f"{'>' if lo_open else '>='} {lo}"
    if lo is None:
        return f"{'<' if hi_open else '<='} {hi}"
    return f"{'(' if lo_open else '['}{lo}, {hi}{')' if hi_open else ']'}"


def closest_key(key, allowed) -> str | None:
    """The allowed key closest to ``key``, or None: the same letters in another case, a key it begins
    (``'cnr'`` for ``'cnr_db'``, 3 letters or more), difflib's closest (ratio >= 0.6), a key it extends."""
    import difflib

    k = str(key)
    allowed = sorted(str(a) for a in allowed)
    lowered = {a.lower(): a for a in allowed}
    if k.lower() in lowered:
        return lowered[k.lower()]
    longer = [a for a in allowed if len(k) >= 3 and a.startswith(k)]
    if longer:
        return longer[0]
    near = difflib.get_close_matches(k, allowed, n=1, cutoff=0.6)
    if near:
        return near[0]
    return next((a for a in allowed if k.startswith(a)), None)


def did_you_mean(unknown, allowed) -> str:
    """`` (did you mean 'heights' for 'height'?)`` for the unknown keys that have a close allowed key
    (:func:`closest_key`); else ``''``."""
    pairs = [f"{near!r} for {str(k)!r}" for k in unknown for near in [closest_key(k, allowed)] if near]
    return f" (did you mean {', '.join(pairs)}?)" if pairs else ""


def check_keys(cls, d, *, required=()) -> None:
    """Reject keys of ``d`` that are not fields of the dataclass ``cls``, by name.

    Parameters
    ----------
    cls : dataclass type
    d : dict
        Mapping to check (e.g. a TOML table or the argument of ``from_dict``).
    required : iterable of str
        Field names that must be present.
    """
    import dataclasses

    if not isinstance(d, dict):
        raise TypeError(f"{cls.__name__} expects a dict, got {type(d).__name__}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(d) - names)
    if unknown:
        raise ValueError(f"unknown key(s) for {cls.__name__}: {unknown}{did_you_mean(unknown, names)}; "
                         f"allowed: {sorted(names)}")
    missing = sorted(set(required) - set(d))
    if missing:
        raise ValueError(f"missing key(s) for {cls.__name__}: {missing}")
