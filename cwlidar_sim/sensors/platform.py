"""A floating turbine's prescribed platform motion and the attitude rotations of the nacelle lidar.

See :mod:`cwlidar_sim.sensors.nacelle` (Line of sight and the platform) for how they enter the
line of sight.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._repr import summary_repr

__all__ = ["PlatformMotion", "rotation_matrices", "read_platform_csv", "PLATFORM_MAX_GAP"]

#: Default longest step of a platform series [s]: the motion between samples is interpolated linearly, and a
#: floater's wave-driven motion (periods of 3-20 s) is not linear over more than about a second.
PLATFORM_MAX_GAP = 1.0

_MOTION_NAMES = ("surge", "sway", "heave", "roll_deg", "pitch_deg", "yaw_deg")


def rotation_matrices(roll_deg, pitch_deg, yaw_deg) -> np.ndarray:
    """``Rz(yaw) Ry(pitch) Rx(roll)`` (right-handed, about x, y, z of the field frame), shape (..., 3, 3)."""
    r, p, y = (np.radians(np.asarray(a, dtype=np.float64)) for a in (roll_deg, pitch_deg, yaw_deg))
    r, p, y = np.broadcast_arrays(r, p, y)
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    out = np.empty(r.shape + (3, 3))
    out[..., 0, 0] = cy * cp
    out[..., 0, 1] = cy * sp * sr - sy * cr
    out[..., 0, 2] = cy * sp * cr + sy * sr
    out[..., 1, 0] = sy * cp
    out[..., 1, 1] = sy * sp * sr + cy * cr
    out[..., 1, 2] = sy * sp * cr - cy * sr
    out[..., 2, 0] = -sp
    out[..., 2, 1] = cp * sr
    out[..., 2, 2] = cp * cr
    return out


@dataclasses.dataclass(frozen=True, eq=False)
class PlatformMotion:
    """A prescribed motion of the lidar's platform (module notes), sampled at ``time``.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s], n >= 2, strictly increasing; the record must lie inside.
    surge, sway, heave : array_like, shape (n,), optional
        The lidar's displacement along x, y, z of the field frame [m] (lever arms included); default 0.
    roll_deg, pitch_deg, yaw_deg : array_like, shape (n,), optional
        The nacelle's attitude about x, y, z [deg], each within [-45, 45]; default 0.
    """

    __repr__ = summary_repr

    time: np.ndarray
    surge: np.ndarray | None = None
    sway: np.ndarray | None = None
    heave: np.ndarray | None = None
    roll_deg: np.ndarray | None = None
    pitch_deg: np.ndarray | None = None
    yaw_deg: np.ndarray | None = None

    def __post_init__(self):
        t = np.array(self.time, dtype=np.float64, ndmin=1)
        if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ValueError(f"motion.time must be >= 2 finite, strictly increasing times [s], got shape {t.shape}")
        t.setflags(write=False)
        object.__setattr__(self, "time", t)
        for name in _MOTION_NAMES:
            v = getattr(self, name)
            a = np.zeros(t.size) if v is None else np.array(v, dtype=np.float64, ndmin=1)
            if a.shape != t.shape or not np.all(np.isfinite(a)):
                raise ValueError(f"motion.{name} must be {t.size} finite values (one per motion.time), got "
                                 f"shape {a.shape}")
            if name.endswith("_deg") and np.any(np.abs(a) > 45.0):
                raise ValueError(f"motion.{name} must lie within [-45, 45] deg, got up to {np.abs(a).max():g}")
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def as_dict(self) -> dict:
        """Plain dict of lists (round-trips through :meth:`from_dict`)."""
        return {f.name: getattr(self, f.name).tolist() for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, d: dict) -> "PlatformMotion":
        """Build from a mapping; unknown keys are rejected by name."""
        from .._validation import check_keys

        check_keys(cls, d, required=["time"])
        return cls(**d)

    def check_covers(self, t0: float, t1: float) -> None:
        """The record ``[t0, t1]`` [s] must lie inside the samples."""
        if t0 < self.time[0] - 1e-9 or t1 > self.time[-1] + 1e-9:
            raise ValueError(f"motion covers [{self.time[0]:g}, {self.time[-1]:g}] s, the record needs "
                             f"[{t0:g}, {t1:g}] s; allowed: motion samples spanning the record")

    def at(self, t):
        """``(d_tc, ddot_tc, rot_tcc)`` at times ``t`` [s]: displacement [m], velocity [m/s], attitude matrix."""
        t = np.asarray(t, dtype=np.float64)
        d = np.stack([np.interp(t, self.time, getattr(self, k)) for k in _MOTION_NAMES[:3]], axis=-1)
        v = np.stack([np.interp(t, self.time, np.gradient(getattr(self, k), self.time)) for k in _MOTION_NAMES[:3]],
                     axis=-1)
        ang = [np.interp(t, self.time, getattr(self, k)) for k in _MOTION_NAMES[3:]]
        return d, v, rotation_matrices(*ang)


def read_platform_csv(path, *, max_gap: float = PLATFORM_MAX_GAP, where: str = "platform.csv") -> PlatformMotion:
    """A :class:`PlatformMotion` from a CSV: a header row, a time column, any of the degrees of freedom.

    Parameters
    ----------
    path : str
        The file: a header row naming the time column (``time`` [s], or
        with its unit: ``time_ms``, ``time [ms]``, ``time (us)``; s, ms, us,
        ns, min, h) and any of surge, sway, heave [m], roll_deg, pitch_deg,
        yaw_deg [deg]; one sample per row.
    max_gap : float
        Longest step between consecutive samples [s], in (0, 3600]: the motion
        is interpolated linearly between samples, so a longer hole is refused
        with its place named, not bridged.
    where : str
        Label for messages.

    Raises ValueError (one line, naming the file and the column) for a
    missing or unknown column, a value that is not a number, times that are
    missing, repeated or unsorted, a step longer than ``max_gap`` (with a
    hint when the unit is likely wrong: a column in ms read as s steps by
    100 s at 10 Hz), or motion out of range.
    """
    import csv

    from .._times import check_increasing, check_rate, column_unit, find_time_column, ns_text, parse_time_cells
    from .._validation import check_real

    max_gap = check_real(f"{where} max_gap", max_gap, lo=0.0, hi=3600.0, lo_open=True)
    with open(path, newline="", encoding="utf-8-sig") as f:
        rows = [r for r in csv.reader(f) if r]
    if len(rows) < 3:
        raise ValueError(f"{where} {path!r}: {max(len(rows) - 1, 0)} sample row(s); allowed: a header row and >= 2 "
                         f"samples")
    header = [h.strip() for h in rows[0]]
    tcol = find_time_column(header, f"{where} {path!r}")
    unknown = sorted(set(header) - {tcol, *_MOTION_NAMES})
    if tcol is None or unknown:
        raise ValueError(f"{where} {path!r}: columns {header}; allowed: 'time' (or 'time_ms', 'time [ms]' ...) and "
                         f"any of {list(_MOTION_NAMES)}")
    body = rows[1:]
    cols = {}
    for j, name in enumerate(header):
        cells = [row[j].strip() if j < len(row) else "" for row in body]
        if name == tcol:
            w = f"{where} {path!r}: time column {tcol!r}"
            tc = parse_time_cells(cells, column_unit(tcol, None, w), w)
            t = check_increasing(tc, w)
            d = np.diff(t)
            # the median step says the unit (a column in ms read as s steps by 100 s); single long steps are holes
            check_rate(float(np.median(d)), w, rate_range=(1.0 / max_gap, 1e3), unit=tc.unit, what="platform series")
            i = int(np.argmax(d))
            if d[i] > max_gap * 1e9:
                raise ValueError(f"{w}: a hole of {d[i] / 1e9:.6g} s between samples {i} and {i + 1} (t = "
                                 f"{ns_text(t[i])} to {ns_text(t[i + 1])} s); allowed: steps up to max_gap = "
                                 f"{max_gap:g} s (the motion is not interpolated across a hole)")
            # seconds as written parse as before (float of the text); other units from the exact ns
            cols["time"] = np.array([float(c) for c in cells]) if tc.unit == "s" and not tc.iso else t / 1e9
            continue
        try:
            cols[name] = np.array([float(c) for c in cells])
        except ValueError:
            bad = next(i for i, c in enumerate(cells) if not _is_number(c))
            raise ValueError(f"{where} {path!r}: column {name!r} sample {bad} is {cells[bad][:20]!r}; allowed: a "
                             f"number") from None
    return PlatformMotion(**cols)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
