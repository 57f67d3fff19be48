"""The package's two seeding idioms, written once.

* :func:`seed_sequence`: a record's root :class:`numpy.random.SeedSequence`
  from an int seed or a numpy Generator (a Generator gives one 63-bit draw).
* :func:`focus_seeds`: the one rule by which a lidar's record seed becomes
  the streams of its focus groups (:mod:`cwlidar_sim.signal.chain`).
* :func:`seed_int`: the int seed a SeedSequence stands for where a function
  takes an int (a box's seed, a unit's seed): the first 64-bit word of its
  state shifted right by one bit, so it lies in ``[0, 2**63)`` like every seed
  (:func:`cwlidar_sim._validation.check_seed`).
"""

from __future__ import annotations

import numpy as np

from ._validation import check_seed

__all__ = ["seed_sequence", "seed_int", "focus_seeds"]


def seed_sequence(seed) -> np.random.SeedSequence:
    """The record's root SeedSequence from an int seed or a numpy Generator."""
    if isinstance(seed, np.random.Generator):
        return np.random.SeedSequence(int(seed.integers(0, 2**63 - 1)))
    return np.random.SeedSequence(check_seed("seed", seed))


def focus_seeds(seed, n_foci: int | None) -> list:
    """The focus groups' SeedSequences of a record: the one seeding rule of every lidar.

    A sensor with a focus *list* (the conical lidar's heights, the nacelle
    lidar's focus distances: ``n_foci`` entries, one included) gives its
    groups the record root's children in list order; a sensor with one fixed
    focus (the staring lidar: ``n_foci`` None) gives its one group the root.

    Parameters
    ----------
    seed : int or numpy.random.Generator
        The record's seed (:func:`seed_sequence`).
    n_foci : int or None
        Length of the sensor's focus list; None: a fixed focus.
    """
    root = seed_sequence(seed)
    return [root] if n_foci is None else root.spawn(n_foci)


def seed_int(seq: np.random.SeedSequence) -> int:
    """A non-negative int seed below 2**63 from a SeedSequence (the first word of its state, shifted)."""
    return int(seq.generate_state(1, np.uint64)[0] >> np.uint64(1))
