"""The memory check sees what the process may use: psutil's available memory capped by a cgroup (Dask's limit)."""

import psutil
import pytest

import distributed.system
from cwlidar_sim import _validation


def test_a_cgroup_limit_below_the_host_s_free_memory_caps_the_check(monkeypatch):
    """In a 2 GiB container (Slurm job) on a host with more free, a 3 GiB box is refused (was: the host's MemAvailable)."""
    free = psutil.virtual_memory().available
    limit = 2 * 2**30
    if free <= 2 * limit:
        pytest.skip("the host itself has less than 4 GiB free")
    monkeypatch.setattr(distributed.system, "MEMORY_LIMIT", limit)
    avail = _validation.available_memory()
    rss = psutil.Process().memory_info().rss
    assert 0 <= avail <= limit and abs(avail - max(0, limit - rss)) < 2**26
    with pytest.raises(ValueError, match=r"a box needs about 3\.00 GiB, more than 80% of the .* GiB available"):
        _validation.check_memory("a box", 3 * 2**30)


def test_without_a_cgroup_limit_the_check_is_the_host_s_available_memory(monkeypatch):
    monkeypatch.setattr(distributed.system, "MEMORY_LIMIT", psutil.virtual_memory().total)
    assert _validation.available_memory() == pytest.approx(psutil.virtual_memory().available, rel=0.05)
    _validation.check_memory("a small array", 2**20)  # passes
