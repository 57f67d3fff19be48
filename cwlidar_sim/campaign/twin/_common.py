"""What the staring and the conical twins share: the files' layout version, the seed tag, the clock, the records'
statistics."""

from __future__ import annotations

import numpy as np

from ..._times import ns_text

__all__ = ["TWIN_VERSION", "record_statistics", "clock_attrs"]

#: Layout version of the twin files (part of their identity).  2: the twin's clock starts half a sample
#: before the reference record (record_10hz on the lidar's tenths), times exact; files of 1 are recomputed.
TWIN_VERSION = 2
#: Second word of the twins' seed sequence ("tw").
_TWIN_TAG = 0x7477


def clock_attrs(tp) -> dict:
    """The period's clock: its start on the records' clock (exact decimal seconds and ns), the records' delay [s]."""
    return {"time_origin": ns_text(tp.origin_ns), "time_origin_ns": int(tp.origin_ns), "record_delay": tp.delay}


def record_statistics(ds, tp):
    """The records' own statistics over the period (mean speed, std of u or the cup's speed, filled samples)."""
    for i, rec in enumerate(tp.records):
        key = "speed" if rec.spec.kind == "cup" else "u"
        ds[f"record{i}_mean_speed"] = ((), rec.mean_speed, {"units": "m s-1", "long_name": f"{rec.spec.name}: mean {key}"})
        ds[f"record{i}_std"] = ((), float(np.std(rec.values[key])),
                                {"units": "m s-1", "long_name": f"{rec.spec.name}: std of {key}"})
        ds[f"record{i}_filled"] = ((), rec.n_filled, {"units": "1", "long_name": f"{rec.spec.name}: filled samples"})
