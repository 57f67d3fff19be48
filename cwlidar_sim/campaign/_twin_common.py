"""What the staring and the conical twins share: the files' layout version, the seed tag, the records' statistics."""

from __future__ import annotations

import numpy as np

__all__ = ["TWIN_VERSION", "record_statistics"]

#: Layout version of the twin files (part of their identity).
TWIN_VERSION = 1
#: Second word of the twins' seed sequence ("tw").
_TWIN_TAG = 0x7477


def record_statistics(ds, tp):
    """The records' own 10-minute statistics (mean speed, std of u or the cup's speed, filled samples)."""
    for i, rec in enumerate(tp.records):
        key = "speed" if rec.spec.kind == "cup" else "u"
        ds[f"record{i}_mean_speed"] = ((), rec.mean_speed, {"units": "m s-1", "long_name": f"{rec.spec.name}: mean {key}"})
        ds[f"record{i}_std"] = ((), float(np.std(rec.values[key])),
                                {"units": "m s-1", "long_name": f"{rec.spec.name}: std of {key}"})
        ds[f"record{i}_filled"] = ((), rec.n_filled, {"units": "1", "long_name": f"{rec.spec.name}: filled samples"})
