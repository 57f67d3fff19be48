"""A scene's absolute start: ``start_time``, ISO 8601 with a time zone, kept as UTC text.

Every kind's scene file may name it (:class:`~cwlidar_sim.campaign.scenes.spec.SceneSpec`);
it gives the results an absolute time axis (:mod:`cwlidar_sim.campaign.execution.cf`)
and changes no number.
"""

from __future__ import annotations

import datetime

__all__ = ["check_start_time", "start_datetime"]


def check_start_time(value, name: str = "start_time"):
    """An absolute start time: ISO 8601 with a time zone, returned as UTC text ``YYYY-MM-DDTHH:MM:SSZ``.

    Parameters
    ----------
    value : str, datetime.datetime or None
        ``"2024-05-01T12:00:00+02:00"``, ``"2024-05-01T10:00:00Z"``, or a TOML
        offset date-time (``start_time = 2024-05-01T10:00:00Z``, unquoted);
        None: no absolute time.
    name : str
        The key as the user wrote it, for the message.

    Returns
    -------
    str or None
        The instant in UTC (microseconds kept when given), e.g. ``"2024-05-01T10:00:00Z"``.

    Raises
    ------
    ValueError, TypeError
        Not a date-time, or one without a time zone (a local time names no instant).
    """
    if value is None:
        return None
    if isinstance(value, str):
        try:
            value = datetime.datetime.fromisoformat(value.strip())
        except ValueError:
            raise ValueError(f"{name} = {value!r} is not an ISO 8601 date-time; allowed: e.g. "
                             f"'2024-05-01T10:00:00Z' or '2024-05-01T12:00:00+02:00' (with a time zone)") from None
    if not isinstance(value, datetime.datetime):
        raise TypeError(f"{name} must be an ISO 8601 date-time with a time zone such as '2024-05-01T10:00:00Z', "
                        f"got {type(value).__name__} {value!r}")
    if value.tzinfo is None or value.utcoffset() is None:
        raise ValueError(f"{name} = {value.isoformat()!r} has no time zone; allowed: an instant such as "
                         f"'{value.isoformat()}Z' (UTC) or with its offset, '+02:00'")
    utc = value.astimezone(datetime.timezone.utc).replace(tzinfo=None)
    return utc.isoformat(timespec="microseconds" if utc.microsecond else "seconds") + "Z"


def start_datetime(scene):
    """A scene's ``start_time`` as a naive UTC ``datetime.datetime``, or None (validated, naming the key)."""
    text = check_start_time(getattr(scene, "start_time", None))
    return None if text is None else datetime.datetime.fromisoformat(text[:-1])
