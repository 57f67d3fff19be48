"""Metadata of the turbulence-box files: attributes as JSON, spacing, HAWC2's sidecar and HTC snippet.

Shared by :mod:`cwlidar_sim.turbulence.io` (NetCDF attributes, HAWC2) and the
TurbSim / Bladed modules.  Nothing here reads or writes velocity data.

HAWC2 sidecar (``BASE.json``)
-----------------------------
A JSON object written beside ``BASE_u.bin``, ``BASE_v.bin``, ``BASE_w.bin``:
``format`` (:data:`SIDECAR_FORMAT`), ``format_version`` (1),
``cwlidar_sim_version``, ``files`` (the u, v, w file names, relative to the
sidecar's folder), ``dtype`` ("<f4"), ``value_order``, ``shape`` [Nx, Ny, Nz],
``spacing`` [dx, dy, dz] in m (an entry is null where the box did not say),
``convention`` and ``reverse_x`` (how the planes were laid out, see
:func:`cwlidar_sim.turbulence.write_hawc2`), ``mann_parameters``
(``alpha_eps`` [m^(4/3) s^-2], ``length_scale`` [m], ``gamma``; null where
unknown), ``seed`` (null where unknown) and ``attrs`` (every Dataset
attribute, JSON-encoded as for NetCDF), which the reader restores.

HAWC2 HTC snippet (``BASE.htc``)
--------------------------------
A ``begin mann; ... end mann;`` block for HAWC2's ``begin wind`` section,
with the keys HAWC2 reads there (their spelling checked against the DTU
Wind Energy Toolbox, ``wetb.hawc2.htc_extensions.add_mann_turbulence``, and
the HTC files in its test suite): ``filename_u``/``_v``/``_w`` (the files,
relative to the snippet's folder), ``box_dim_u``/``_v``/``_w`` as
"N spacing" (points and spacing [m] along x, y, z) and ``dont_scale 1`` (the
box is used as written, not rescaled to ``tint``).  HAWC2's own generator
line ``create_turb_parameters L alfaeps gamma seed highfrq`` is written as a
comment for the record: active, it would make HAWC2 generate a box of its own
where the files are missing.  ``turb_format 1`` must be set in ``begin wind``.
"""

from __future__ import annotations

import json
import math
import numbers
import os
from pathlib import Path

import numpy as np

from .._version import __version__

__all__: list = []  # private to the turbulence stage

#: ``format`` of a HAWC2 sidecar written here.
SIDECAR_FORMAT = "cwlidar_sim HAWC2 turbulence box"
SIDECAR_VERSION = 1
#: Global attribute listing the attributes stored as JSON text (NetCDF).
JSON_ATTR = "cwlidar_sim_json_attrs"
#: Largest sidecar read [bytes]: a few kB in practice; anything far larger is not one.
_MAX_SIDECAR_BYTES = 16 * 2**20


# ---------------------------------------------------------------------------
# spacing
# ---------------------------------------------------------------------------
def box_spacing(box, label: str) -> tuple:
    """(dx, dy, dz) [m] of a box Dataset: ``attrs['dx']``... or its evenly spaced coordinates (None if neither).

    Where both say, they must agree (to 1e-6 relative); the attribute (the number the user gave) is returned.
    """
    out = []
    for d in "xyz":
        from_coord = None
        if d in box.coords and box.sizes.get(d, 0) >= 2:
            c = np.asarray(box[d].values, dtype=np.float64)
            step = np.diff(c)
            if not (np.isfinite(step).all() and step[0] > 0 and np.ptp(step) <= 1e-6 * step[0]):
                raise ValueError(f"{label}: coordinate {d} is not evenly spaced and increasing "
                                 f"({c[:3].tolist()}...); allowed: {d} = i * d{d}")
            from_coord = float((c[-1] - c[0]) / (len(c) - 1))
        from_attr = box.attrs.get(f"d{d}")
        if from_attr is not None:
            if isinstance(from_attr, bool) or not isinstance(from_attr, (numbers.Real, np.floating, np.integer)) \
                    or not (math.isfinite(float(from_attr)) and float(from_attr) > 0):
                raise ValueError(f"{label}.attrs['d{d}'] = {from_attr!r}; allowed: a spacing > 0 [m]")
            from_attr = float(from_attr)
            if from_coord is not None and abs(from_attr - from_coord) > 1e-6 * from_attr:
                raise ValueError(f"{label}: attrs['d{d}'] = {from_attr!r} m but coordinate {d} is spaced "
                                 f"{from_coord!r} m; make them agree")
        out.append(from_attr if from_attr is not None else from_coord)
    return tuple(out)


# ---------------------------------------------------------------------------
# attributes as JSON
# ---------------------------------------------------------------------------
def attrs_to_json(attrs, label: str) -> str:
    """Dataset attributes as compact ASCII JSON text (sorted keys; NaN as ``NaN``, as Python writes it)."""
    out = {}
    for key, value in dict(attrs).items():
        if not isinstance(key, str):
            raise TypeError(f"{label} key {key!r} must be a str")
        try:
            out[key] = to_json(value)
        except TypeError:
            raise TypeError(f"{label}[{key!r}] = {value!r} ({type(value).__name__}) cannot be stored as JSON; allowed: "
                            "str, int, float, bool, None, 1-D numeric arrays, and lists/dicts of those") from None
    return json.dumps(out, sort_keys=True, allow_nan=True, separators=(",", ":"))


def attrs_from_json(text: str, where: str) -> dict:
    """Inverse of :func:`attrs_to_json`; a text that is not a JSON object is a ValueError naming ``where``."""
    try:
        out = json.loads(text)
    except ValueError as e:
        raise ValueError(f"{where}: the attributes are not valid JSON ({e.msg} at character {e.pos})") from None
    if not isinstance(out, dict):
        raise ValueError(f"{where}: the attributes are a JSON {type(out).__name__}, not an object")
    return out


def netcdf_native(value) -> bool:
    """True if netCDF-4 can hold ``value`` as an attribute as it is."""
    if isinstance(value, (bool, np.bool_)):
        return False
    if isinstance(value, (str, np.str_)):
        return True
    if isinstance(value, (numbers.Integral, np.integer)):
        return -(2**63) <= int(value) < 2**63
    if isinstance(value, (numbers.Real, np.floating)):
        return True
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        return (
            arr.ndim == 1
            and arr.size > 0
            and (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer))
            and arr.dtype != np.bool_
        )
    return False


def encode_attrs(attrs: dict, label: str) -> dict:
    out = {}
    json_names = []
    for key, value in attrs.items():
        if not isinstance(key, str):
            raise TypeError(f"{label} key {key!r} must be a str")
        if key == JSON_ATTR:
            continue
        if netcdf_native(value):
            out[key] = value
            continue
        try:
            out[key] = json.dumps(to_json(value), allow_nan=True)
        except TypeError:
            raise TypeError(
                f"{label}[{key!r}] = {value!r} ({type(value).__name__}) cannot be stored in NetCDF; allowed: "
                "str, int, float, bool, None, 1-D numeric arrays, and lists/dicts of those"
            ) from None
        json_names.append(key)
    if json_names:
        out[JSON_ATTR] = json.dumps(json_names)
    return out


def to_json(value):
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, (numbers.Integral, np.integer)):
        return int(value)
    if isinstance(value, (numbers.Real, np.floating)):
        return float(value)
    if isinstance(value, np.ndarray):
        return to_json(value.tolist())
    if isinstance(value, (list, tuple)):
        return [to_json(v) for v in value]
    if isinstance(value, dict) and all(isinstance(k, str) for k in value):
        return {k: to_json(v) for k, v in value.items()}
    raise TypeError(type(value).__name__)


def decode_attrs(attrs) -> dict:
    out = dict(attrs)
    names = out.pop(JSON_ATTR, None)
    if names is None:
        return out
    for key in json.loads(names):
        if key in out:
            out[key] = json.loads(out[key])
    return out


# ---------------------------------------------------------------------------
# HAWC2 sidecar and HTC snippet
# ---------------------------------------------------------------------------
def _rel(path, folder) -> str:
    return os.path.relpath(os.path.abspath(path), os.path.abspath(folder))


def _mann(attrs) -> dict:
    return {k: to_json(attrs[k]) if k in attrs else None for k in ("alpha_eps", "length_scale", "gamma")}


def sidecar_text(paths, sidecar_path, shape, spacing, convention, reverse_x, attrs, label) -> str:
    """The JSON sidecar of a HAWC2 triplet (see the module docstring)."""
    folder = os.path.dirname(os.path.abspath(sidecar_path))
    attrs_text = attrs_to_json(attrs, label)
    seed = attrs.get("seed")
    doc = {
        "format": SIDECAR_FORMAT,
        "format_version": SIDECAR_VERSION,
        "cwlidar_sim_version": __version__,
        "files": {c: _rel(p, folder) for c, p in zip("uvw", paths)},
        "dtype": "<f4",
        "value_order": "C order of u[ix, iy, iz]: z fastest, then y, x slowest",
        "shape": [int(n) for n in shape],
        "spacing": [None if s is None else float(s) for s in spacing],
        "convention": convention,
        "reverse_x": bool(reverse_x),
        "mann_parameters": _mann(attrs),
        "seed": to_json(seed) if seed is not None else None,
        "attrs": json.loads(attrs_text),
    }
    return json.dumps(doc, indent=2, allow_nan=True) + "\n"


def htc_text(paths, htc_path, shape, spacing, convention, reverse_x, attrs) -> str:
    """HAWC2's ``begin mann; ... end mann;`` block for a triplet (see the module docstring)."""
    folder = os.path.dirname(os.path.abspath(htc_path))
    names = [_rel(p, folder) for p in paths]
    mann = _mann(attrs)
    lines = [f"; HAWC2 Mann-box block written by cwlidar_sim {__version__}: paste it into 'begin wind; ... end wind;'",
             "; and set 'turb_format 1;' there.  File names are relative to this file's folder: make them",
             "; relative to the folder HAWC2 runs in."]
    if convention == "openfast":
        lines.append("; NOTE: these files are laid out for OpenFAST InflowWind (convention='openfast'); HAWC2 reading "
                     "them sees the field mirrored in x and y.")
    elif reverse_x:
        lines.append("; x planes in arrival order (reverse_x=True): for HAWC2 before 13.1, which brings file plane 0 "
                     "to the rotor first.")
    else:
        lines.append("; x planes in the generators' order (reverse_x=False): for HAWC2 13.1 and later.")
    if all(v is not None for v in mann.values()):
        seed = attrs.get("seed")
        hfc = attrs.get("hf_compensation")
        hfc = int(bool(hfc)) if hfc is not None else "-"
        lines.append(f";   create_turb_parameters {mann['length_scale']:.10g} {mann['alpha_eps']:.10g} "
                     f"{mann['gamma']:.10g} {seed if seed is not None else '-'} {hfc} ;"
                     "  L, alfaeps, gamma, seed, highfrq compensation: how this box was made (left a comment:"
                     " active, HAWC2 would generate its own box where the files are missing)")
    lines.append("  begin mann ;")
    lines += [f"    filename_{c} ./{n} ;" for c, n in zip("uvw", names)]
    for c, n, s in zip("uvw", shape, spacing):
        lines.append(f"    box_dim_{c} {int(n)} {'?' if s is None else format(float(s), '.10g')} ;"
                     + ("  spacing unknown: fill it in" if s is None else ""))
    lines.append("    dont_scale 1 ;  use the box as written (not rescaled to tint)")
    lines.append("  end mann ;")
    return "\n".join(lines) + "\n"


def read_sidecar(path) -> dict | None:
    """The validated content of a HAWC2 sidecar (None if there is no file at ``path``).

    Returns a dict with ``shape`` (tuple of 3 int), ``spacing`` (tuple of 3 float or None),
    ``convention``, ``reverse_x`` and ``attrs``.  Anything else is a ValueError naming the file.
    """
    path = Path(path)
    if not path.is_file():
        return None
    where = f"HAWC2 sidecar {str(path)!r}"
    size = path.stat().st_size
    if size > _MAX_SIDECAR_BYTES:
        raise ValueError(f"{where} holds {size} bytes; a sidecar is a few kB: not one written by cwlidar_sim")
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise ValueError(f"{where} is not UTF-8 text: not a sidecar") from None
    except ValueError as e:
        raise ValueError(f"{where} is not valid JSON ({e.msg} at line {e.lineno})") from None
    if not isinstance(doc, dict) or doc.get("format") != SIDECAR_FORMAT:
        raise ValueError(f"{where} is not a cwlidar_sim HAWC2 sidecar (its 'format' is not {SIDECAR_FORMAT!r})")
    version = doc.get("format_version")
    if version != SIDECAR_VERSION:
        raise ValueError(f"{where} has format_version {version!r}; this cwlidar_sim reads version {SIDECAR_VERSION}")
    shape, spacing = doc.get("shape"), doc.get("spacing")
    if not (isinstance(shape, list) and len(shape) == 3
            and all(isinstance(n, int) and not isinstance(n, bool) and n >= 1 for n in shape)):
        raise ValueError(f"{where}: 'shape' is {shape!r}; allowed: [Nx, Ny, Nz], integers >= 1")
    if not (isinstance(spacing, list) and len(spacing) == 3 and all(
            s is None or (isinstance(s, (int, float)) and not isinstance(s, bool) and math.isfinite(s) and s > 0)
            for s in spacing)):
        raise ValueError(f"{where}: 'spacing' is {spacing!r}; allowed: [dx, dy, dz] [m], each > 0 (or null)")
    convention, reverse_x, attrs = doc.get("convention"), doc.get("reverse_x"), doc.get("attrs", {})
    if convention not in ("hawc2", "openfast") or not isinstance(reverse_x, bool) or not isinstance(attrs, dict):
        raise ValueError(f"{where}: 'convention' {convention!r}, 'reverse_x' {reverse_x!r} or 'attrs' is malformed; "
                         "allowed: 'hawc2' or 'openfast', true or false, an object")
    return {"shape": tuple(shape), "spacing": tuple(None if s is None else float(s) for s in spacing),
            "convention": convention, "reverse_x": reverse_x, "attrs": attrs}
