"""Bladed-style full-field wind files (``.wnd`` with a ``.sum`` summary), TurbSim's variant: read and write.

Which variant
-------------
The ``.wnd`` file TurbSim writes (``WrBLFF``) and OpenFAST InflowWind reads
as ``WindType = 4`` with the summary file ``ROOT.sum`` beside it: the "new"
Bladed header (id -99) of turbulence type 4 ("improved von Karman"), whose
header carries the turbulence intensities that scale the integers.  Sources:
TurbSim's writer ``WrBinBLADED`` (OpenFAST
``modules/turbsim/src/TS_FileIO.f90``), InflowWind's readers
``IfW_Bladed_Init``, ``Bladed_ReadHeader1``, ``Bladed_ReadGrids`` and
``Bladed_ReadTurbSimSummary`` (``modules/inflowwind/src/InflowWind_IO.f90``);
``hipersim`` 0.1.22 writes and reads the same header
(``hipersim/turbgen/turb_utils.py: output_field``,
``hipersim/_hipersim.py: from_bladed``).  Not read: Bladed's own native
files (other turbulence types, data normalised to unit variance and scaled by
a project file) and the old Bladed header (ids -1 to -3).

Layout (little-endian, 104-byte header)
---------------------------------------
=======  =======  ============================================================
bytes    type     field
=======  =======  ============================================================
0-3      int16    -99, then 4 (the turbulence type)
4-7      int32    3 components
8-31     float32  latitude [deg], roughness z0 [m], height of the grid's
                  centre [m], TI of u, v, w [%]
32-43    float32  dz, dy, dx [m] (``dx = U dt``)
44-47    int32    half the number of time steps (``nt // 2``)
48-63    float32  U [m/s], then three length scales (0)
64-79    int32    unused (0), seed, nz, ny
80-103   float32  six more length scales (0)
104-     int16    per time step: ``nz*ny`` points (y fastest, then z), each
                  as u, v, w
=======  =======  ============================================================

A stored integer ``i`` of component c is ``U * TI_c / 100 * i / 1000``
[m/s] about the mean (u: ``U + ...``, v and w: about 0): a step of a
thousandth of the component's sigma.  With "BLADED LEFT-HAND RULE" in the
summary, as TurbSim writes (and here), v is stored with its sign reversed
(Bladed's v points along -y).  The number of time steps is the file's:
``nt // 2`` in the header allows an odd one more, as InflowWind reads.

Summary file (``ROOT.sum``)
---------------------------
InflowWind finds, in this order, the hub height (the first number on a line
holding "HUB HEIGHT"; a "CLOCKWISE" line before it reverses y), "UBAR" with
the three TI lines right after it, "HEIGHT OFFSET" (hub height less the grid
centre's), and then "PERIODIC" and "BLADED LEFT-HAND RULE".  The writer here
writes those lines (and "Grid Base") and then, after them, where InflowWind
stops reading, the Dataset's attributes as JSON (``cwlidar_sim attrs:
{...}``).  The reader follows InflowWind's search; a ``.wnd`` without a
``.sum`` (``hipersim`` writes none) needs ``left_hand_rule`` said.

The TI a writer chooses only scales the integers: TurbSim's rule, sigma =
max(standard deviation, |value|max / 20, 0.01 m/s) per component, keeps every
value within 20000 steps.  Grid, x and time: as
``cwlidar_sim.turbulence._io_fullfield`` (time step j = our plane Nx-1-j,
file y = our y).  Round trip: to within half a step, ``U TI_c / 2e5``
[m/s]; the TIs are kept in ``bladed_ti`` so a file read and written again is
bit-identical.
"""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path

import numpy as np

from .._atomic import atomic_paths, check_output_file
from .._validation import check_bool, check_int
from . import _io_fullfield as ff
from . import _io_meta
from .._version import __version__
from .io import _check_path

__all__ = ["read_bladed", "write_bladed"]

_HEADER = "<hhi6f3fi4f4i6f"
_HEADER_BYTES = struct.calcsize(_HEADER)  # 104
_WHAT = "Bladed wind file"
_ATTRS_LINE = "cwlidar_sim attrs: "
_MAX_SUMMARY_BYTES = 16 * 2**20


def _summary_path(path: Path) -> Path:
    """InflowWind's ``GetRoot(name) // '.sum'``: the extension replaced."""
    return path.with_suffix(".sum") if path.suffix else path.with_name(path.name + ".sum")


def write_bladed(box, path, *, mean_speed=None, hub_height=None, z_bottom=None,
                 max_chunk_bytes: int = 16 * 2**20) -> tuple[Path, Path]:
    """Write a 3-D box as a periodic Bladed-style ``.wnd`` file and its ``.sum`` summary (TurbSim's variant).

    Parameters
    ----------
    box : xarray.Dataset
        ``u``, ``v``, ``w`` [m/s] (fluctuations) on dims ("x", "y", "z"), with
        a spacing (``attrs['dx']``... or evenly spaced coordinates).
    path : str or os.PathLike
        The ``.wnd`` file; the summary is written beside it with the
        extension replaced by ``.sum`` (where InflowWind looks for it).
    mean_speed : float, optional
        U [m/s], the mean of u in the file and the convection speed.
        Default ``box.attrs['mean_speed']``.
    hub_height : float, optional
        Hub height [m].  Default ``box.attrs['hub_height']``, else the grid's
        centre with its bottom row at z = 0.
    z_bottom : float, optional
        Height of the grid's bottom row [m], >= 0.  Default the attribute
        (with the attribute's hub height), else ``hub_height - (Nz-1) dz / 2``.
    max_chunk_bytes : int, optional
        About the largest float64 slab of one component converted at a time.

    Returns
    -------
    tuple of pathlib.Path
        The ``.wnd`` file (``104 + 6 Nx Ny Nz`` bytes) and the ``.sum`` file,
        written together atomically (both or neither).

    Raises
    ------
    TypeError, ValueError
        A bad box (no spacing, a non-finite value), mean speed or heights; a
        path ending in ``.sum``; an output path that cannot receive a file.
    OSError
        Writing failed; the old files are unchanged.
    """
    path = _check_path("path", path)
    max_chunk_bytes = check_int("max_chunk_bytes", max_chunk_bytes, lo=1)
    summary = _summary_path(path)
    if summary == path:
        raise ValueError(f"path={str(path)!r} ends in .sum, the summary's name; allowed: a .wnd file")
    g = ff.Grid(box, "box", mean_speed, hub_height, z_bottom)
    nx, ny, nz = g.shape
    attrs_text = _io_meta.attrs_to_json(g.json_attrs, "box.attrs")
    for label, p in (("Bladed wind file", path), ("Bladed summary file", summary)):
        check_output_file(p, label=label)
    u32 = float(np.float32(g.mean_speed))
    ti = _intensities(g.stats(max_chunk_bytes), u32, box.attrs)
    scale = [0.001 * u32 * t / 100.0 for t in ti]
    sign = (1.0, -1.0, 1.0)  # left-hand rule: v stored along -y
    seed = g.json_attrs.get("seed")
    seed = int(seed) if isinstance(seed, (int, np.integer)) and -2**31 <= int(seed) < 2**31 else 0
    centre = g.z_bottom + (nz - 1) * g.spacing[2] / 2
    header = struct.pack(_HEADER, -99, 4, 3, 0.0, 0.0, centre, *ti, g.spacing[2], g.spacing[1], g.spacing[0],
                         nx // 2, g.mean_speed, 0.0, 0.0, 0.0, 0, seed, nz, ny, *([0.0] * 6))
    text = _summary_text(g, ti, centre, attrs_text)
    with atomic_paths([path, summary]) as (tmp, tmp_sum):
        with open(tmp_sum, "w", encoding="ascii") as fh:
            fh.write(text)
        with open(tmp, "wb") as fh:
            fh.write(header)
            for slabs in g.time_slabs(max_chunk_bytes):
                fh.write(ff.interleave([ff.nint16(s * v / k) for v, s, k in zip(slabs, sign, scale)]))
    return path, summary


def _intensities(stats, u32, attrs):
    """Float32 TI [%] per component: TurbSim's rule, or those of ``attrs['bladed_ti']`` where they still fit."""
    kept = attrs.get("bladed_ti")
    out = []
    for c, (_, _, std, top) in enumerate(stats):
        ti = float(np.float32(100.0 * max(std, 0.05 * top, 0.01) / u32))
        if isinstance(kept, (list, tuple, np.ndarray)) and len(kept) == 3:
            k = float(np.float32(kept[c]))
            if math.isfinite(k) and k > 0 and abs(k / ti - 1) < 1e-3 and top / (0.001 * u32 * k / 100) < 32767.5:
                ti = k
        out.append(ti)
    return out


def _summary_text(g, ti, centre, attrs_text) -> str:
    nx, ny, nz = g.shape
    lines = [f"cwlidar_sim {__version__}: summary of a Bladed-style full-field file (TurbSim's variant), as "
             "OpenFAST InflowWind reads it with WindType = 4", "",
             f"{nz:10d}  Vertical grid-point matrix dimension",
             f"{ny:10d}  Horizontal grid-point matrix dimension",
             f"   {g.hub_height!r}  Hub height [m]", "",
             "Normalizing Parameters for Binary Data (approximate statistics):", "",
             f"   UBar  = {float(np.float32(g.mean_speed))!r} m/s",
             *(f"   TI({c}) = {t!r} %" for c, t in zip("uvw", ti)), "",
             f"   Height Offset = {g.hub_height - centre!r} m",
             f"   Grid Base     = {g.z_bottom!r} m", "",
             "Creating a PERIODIC output file.",
             "Creating a BLADED LEFT-HAND RULE output file.",
             _ATTRS_LINE + attrs_text]
    return "\n".join(lines) + "\n"


def _first_number(text, what):
    m = re.search(r"[-+]?(\d+\.?\d*|\.\d+)([eEdD][-+]?\d+)?", text)
    if not m:
        raise ValueError(f"{what}: no number in {text.strip()[:60]!r}")
    return float(m.group(0).replace("d", "e").replace("D", "e"))


def _read_summary(path: Path) -> dict:
    """InflowWind's search of a TurbSim summary (``Bladed_ReadTurbSimSummary``), plus our attributes line."""
    where = f"Bladed summary file {str(path)!r}"
    if path.stat().st_size > _MAX_SUMMARY_BYTES:
        raise ValueError(f"{where} holds {path.stat().st_size} bytes: not a TurbSim summary")
    lines = path.read_text(encoding="latin-1").splitlines()
    out = {"clockwise": False, "offset": 0.0, "periodic": False, "lhr": False, "grid_base": None, "attrs": None}
    need = ["clockwise", "hub", "ubar", "offset", "tail"]
    i = 0
    while i < len(lines):
        line, up = lines[i], lines[i].upper()
        at = f"{where}, line {i + 1}"
        if line.startswith(_ATTRS_LINE):
            out["attrs"] = _io_meta.attrs_from_json(line[len(_ATTRS_LINE):], at)
        elif "hub" in need:
            if "clockwise" in need and "CLOCKWISE" in up:
                token = (up.split() or ["?"])[0].lstrip(".")
                if token[:1] not in ("T", "F", "Y", "N"):
                    raise ValueError(f"{at}: cannot read the rotation (CLOCKWISE) from {line.strip()[:60]!r}")
                out["clockwise"] = token[:1] in ("T", "Y")
                need.remove("clockwise")
            if "HUB HEIGHT" in up or "ZHUB" in up:
                out["hub"] = _first_number(line, at)
                need.remove("hub")
        elif "ubar" in need:
            if "UBAR" in up:
                out["ubar"] = _first_number(line.partition("=")[2], at)
                if i + 3 >= len(lines):
                    raise ValueError(f"{at}: the three TI lines after UBar are missing")
                for j in (1, 2, 3):
                    ti_text = lines[i + j].partition("=")[2].partition("%")[0]
                    _first_number(ti_text, f"{where}, line {i + j + 1}")
                i += 3
                need.remove("ubar")
        elif "offset" in need:
            if "HEIGHT OFFSET" in up:
                out["offset"] = _first_number(line.partition("=")[2], at)
                need.remove("offset")
        else:
            if "GRID BASE" in up:
                out["grid_base"] = _first_number(line.partition("=")[2], at)
            out["periodic"] |= "PERIODIC" in up
            out["lhr"] |= "BLADED LEFT-HAND RULE" in up
        i += 1
    if "hub" in need or "ubar" in need:
        raise ValueError(f"{where} lacks the {'hub height' if 'hub' in need else 'UBar'} line InflowWind needs")
    return out


def read_bladed(path, *, left_hand_rule: bool | None = None, clockwise: bool | None = None):
    """Read a Bladed-style ``.wnd`` file (TurbSim's variant, with its ``.sum``) as a box Dataset.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.wnd`` file.  Its summary ``ROOT.sum`` (the extension
        replaced) is read when it is there.
    left_hand_rule : bool, optional
        Whether v is stored along -y (TurbSim's files: True; hipersim's:
        False).  Default: from the summary ("BLADED LEFT-HAND RULE"); needed
        without one; given with one, it must agree.
    clockwise : bool, optional
        Whether y is stored reversed (old TurbSim's "CLOCKWISE" summaries).
        Default: from the summary, else False; given with one, it must agree.

    Returns
    -------
    xarray.Dataset
        ``u``, ``v``, ``w`` float32 [m/s] on ("x", "y", "z"), fluctuations
        about U, time step j as plane ``x = (Nx-1-j) dx``.  Attributes: those
        the writer stored, and ``dx``, ``dy``, ``dz``, ``dt`` [s],
        ``mean_speed`` [m/s], ``hub_height``, ``z_bottom`` [m], ``bladed_ti``
        [%], ``bladed_left_hand_rule``, ``bladed_clockwise``, ``periodic``
        (from the summary), ``seed`` (the header's, unless stored).

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ValueError
        Not a Bladed file of this variant, a size that does not match the
        header, a corrupt header or summary, no summary and no
        ``left_hand_rule``, arguments contradicting the summary: one line
        naming the file, checked before anything is allocated.
    """
    path = _check_path("path", path)
    if not path.is_file():
        raise FileNotFoundError(f"{_WHAT} not found: {str(path)!r}")
    size = path.stat().st_size
    with open(path, "rb") as fh:
        raw = fh.read(_HEADER_BYTES)
    if len(raw) >= 4 and struct.unpack("<hh", raw[:4]) != (-99, 4):
        fid, kind = struct.unpack("<hh", raw[:4])
        hint = (" (a Bladed file of another turbulence type: only TurbSim's type 4 is read)" if fid == -99 else
                " (a TurbSim .bts file? read it with read_turbsim)" if fid in (7, 8) else "")
        raise ValueError(f"{str(path)!r} is not a Bladed-style wind file of TurbSim's variant: it starts "
                         f"{fid}, {kind}; allowed: -99, 4{hint}")
    (_, _, ncomp, _, _, centre, ti_u, ti_v, ti_w, dz, dy, dx, half, mean, _, _, _, _, seed, nz, ny,
     *_) = ff.unpack(_HEADER, raw, _WHAT, path)
    if ncomp != 3 or min(nz, ny) < 1 or half < 0:
        raise ValueError(f"{_WHAT} {str(path)!r}: its header gives {ncomp} components, nz={nz}, ny={ny}, "
                         f"nt/2={half}: a corrupt or foreign file")
    step = 6 * nz * ny
    nt, rest = divmod(size - _HEADER_BYTES, step)
    if rest or nt not in (2 * half, 2 * half + 1):
        need = _HEADER_BYTES + 2 * half * step
        raise ValueError(f"{_WHAT} {str(path)!r} holds {size} bytes, but its header (nt={2 * half} or "
                         f"{2 * half + 1}, ny={ny}, nz={nz}) needs {need} or {need + step}: "
                         + ("truncated" if size < need else "not such a file, or damaged"))
    if nt == 0:
        raise ValueError(f"{_WHAT} {str(path)!r} holds no time step")
    dz, dy, dx, mean = (ff.check_header_real(v, n, _WHAT, path)
                        for v, n in zip((dz, dy, dx, mean), ("dz", "dy", "dx", "U")))
    ti = [ff.check_header_real(t, f"TI({c})", _WHAT, path) for c, t in zip("uvw", (ti_u, ti_v, ti_w))]
    centre = ff.check_header_real(centre, "reference height", _WHAT, path, positive=False)
    summary = _summary_path(path)
    side = _read_summary(summary) if summary.is_file() else None
    if side is None and left_hand_rule is None:
        raise ValueError(f"no summary file {str(summary)!r} beside {_WHAT} {str(path)!r}: say whether v is stored "
                         "along -y, left_hand_rule=True (TurbSim's files) or False (hipersim's)")
    flags = {}
    for name, given, key in (("left_hand_rule", left_hand_rule, "lhr"), ("clockwise", clockwise, "clockwise")):
        stored = side[key] if side else None
        if given is not None:
            given = check_bool(name, given)
            if stored is not None and given != stored:
                raise ValueError(f"{name}={given} contradicts the summary {str(summary)!r}, which says {stored}")
        flags[name] = given if given is not None else bool(stored)
    if side and abs(side["ubar"] - mean) > 0.1:
        raise ValueError(f"{_WHAT} {str(path)!r} has U = {mean:g} m/s but its summary {str(summary)!r} says "
                         f"{side['ubar']:g} m/s: they were not written together")
    attrs = dict(side["attrs"] or {}) if side else {}
    spacing = ff.merge_spacing(attrs, (dx, dy, dz), _WHAT, path)
    half_height = (nz - 1) * spacing[2] / 2
    if side:
        hub = side["hub"]
        bottom = side["grid_base"] if side["grid_base"] is not None else hub - side["offset"] - half_height
    else:
        hub, bottom = centre, centre - half_height
    ints = ff.read_ints(path, _HEADER_BYTES, 3 * nz * ny * nt, nt, _WHAT)
    vel = []
    for c, t in enumerate(ti):
        k = 0.001 * mean * t / 100.0 * (-1.0 if c == 1 and flags["left_hand_rule"] else 1.0)
        v = (ints[:, :, c] * k).astype(np.float32).reshape(nt, nz, ny)
        vel.append(v[:, :, ::-1] if flags["clockwise"] else v)
    del ints
    if not (side and side["attrs"] is not None):  # a foreign file: its header's seed
        attrs["seed"] = seed
    attrs.update(dx=spacing[0], dy=spacing[1], dz=spacing[2], dt=spacing[0] / mean, mean_speed=mean,
                 hub_height=hub, z_bottom=bottom, bladed_ti=ti,
                 bladed_left_hand_rule=int(flags["left_hand_rule"]), bladed_clockwise=int(flags["clockwise"]))
    if side:
        attrs["periodic"] = int(side["periodic"])
    return ff.dataset(vel, spacing, attrs)
