"""Model no more than a scene needs: the automatic choice of tier, field spacing and range cells.

A scene may leave three fidelity settings to the runner with ``"auto"``:
``lidar.tier``, ``field.dx`` (the field's spacing along the wind, which is
also the default range-cell length) and ``lidar.cell_length``.  The runner
(:func:`cwlidar_sim.campaign.run_scene`) resolves them with :func:`resolve`
before anything is computed, prints what it chose and why, and keeps the
reasons in the results (``attrs["auto_choice"]``).  The field *kind* (line,
plane, box) is chosen per period by :func:`cwlidar_sim.campaign.periods.staring_field.choose_field`.

The rule
--------
The cheapest setting whose error on the fidelity chart
(``benchmarks/speed_vs_accuracy.py``, docs/speed_vs_accuracy.png) is within
:data:`TOLERANCE` of the best for what the scene asks.  The chart's error is
the RMS log10 error of method 2's transfer function T2 against the
highest-fidelity result over 0.01-0.5 rad/m; TOLERANCE is the scatter of that
same error between two seeds of the reference (differences below it are not
resolved by the chart).

* **Tier.**  What the scene asks decides:

  - it asks for Doppler processing -- processing variants, an estimator,
    threshold, window or averaging setting in ``lidar.instrument``, a
    background pause or an exact background -- so it needs spectra: tier
    ``spectral`` (tier 2).  Tier 3 ``signal`` is never chosen: on the chart
    tier 2 with continuum speckle is within the tolerance of tier 3 (the
    tiers' spectra agree in their first two moments) at about 1/30 of the
    cost, and tier 3 is limited to 60-s periods;
  - it asks for none of these: a noise-free line-of-sight study, tier
    ``los`` (tier 1, the probe volume's weighted average, A2012 Eq. 2).
    Its chart error against tier 2 (about 0.33) is far outside the
    tolerance, which is why any Doppler setting selects tier 2.

* **Field spacing along the wind** ``dx``: the coarsest of
  :data:`DX_LADDER` whose chart error, scaled by the Rayleigh length
  (``dx / z_R``), is within the tolerance -- :data:`DX_MAX_PER_ZR` (the
  chart: 0.5 m and 1 m, 0.089 and 0.18 z_R for A2012's z_R = 5.61 m, are
  both within it; coarser was not charted), and never coarser than the analysis needs: the
  field's Nyquist wavenumber ``pi / dx`` at least ``k_used``, the smaller
  of ``analysis.k_max`` and the largest 10-Hz Nyquist wavenumber
  ``pi 10 / U`` of the periods, so that the sonic (which samples the same
  field) is resolved wherever the transfer functions are read.  Tier ``los``
  uses the same rule.

* **Range cells** ``cell_length``: the longest cell, :data:`CELL_MAX_PER_ZR`
  ``x z_R`` (the chart: cells of 0.71 z_R are within the tolerance, at
  about half the cost of cells of the field spacing; the continuum speckle model
  makes the Doppler statistics converge in the cell length), but not
  shorter than ``dx`` and only with continuum speckle (the point-cell
  models 'independent' / 'coherent' change their statistics with the cell
  count); otherwise the field spacing.
"""

from __future__ import annotations

import dataclasses
import json
import math

__all__ = ["TOLERANCE", "DX_LADDER", "DX_MAX_PER_ZR", "CELL_MAX_PER_ZR", "CHART", "needs_spectra", "resolve",
           "PROCESSING_KEYS"]

#: The chart's measurements behind the rule (``benchmarks/speed_vs_accuracy.py --groups hour
#: --duration 600 --segment 60``, A2012 period C, 600 s; docs/speed_vs_accuracy_600s.json):
#: setting -> (CPU s per simulated hour, one thread; RMS log10 error of T2 against the reference).
#: The 60-s ``--quick`` chart gives the same order within its larger scatter (0.108).
CHART = {
    "plane dx.25 dy.25 c.25 (reference)": (45.6, 0.0),
    "plane dx.5 dy.5": (21.9, 0.061),
    "plane dx1 dy1": (14.5, 0.045),
    "box dx1 dy4 dz4": (14.8, 0.107),
    "cells 1 m": (16.2, 0.061),
    "cells 2 m": (14.7, 0.058),
    "cells 4 m": (12.3, 0.061),
    "speckle independent": (20.3, 0.079),
    "los tier": (8.1, 0.306),
    "seed 2 (scatter of the reference)": (43.8, 0.09),
}
#: Tolerance on the chart's error: the seed-to-seed scatter of the reference.
TOLERANCE = CHART["seed 2 (scatter of the reference)"][1]
#: Field spacings the choice picks from [m].
DX_LADDER = (0.25, 0.5, 1.0, 2.0)
#: Coarsest field spacing within the tolerance, in Rayleigh lengths (the chart: 1 m at z_R = 5.61 m,
#: the coarsest charted).
DX_MAX_PER_ZR = 1.0 / 5.61
#: Longest range cell within the tolerance, in Rayleigh lengths (the chart: 4 m at z_R = 5.61 m,
#: the longest charted).
CELL_MAX_PER_ZR = 4.0 / 5.61
#: Instrument overrides that configure the Doppler processing (a scene setting one asks for spectra).
PROCESSING_KEYS = ("estimator", "threshold_kind", "threshold_value", "threshold_raise_percent",
                   "threshold_raise_reading", "window", "blocks_per_estimate", "n_fft", "estimate_rate",
                   "second_peak_fraction", "edge_guard_speed", "blind_zone_speed", "background_blocks",
                   "rin_level", "reflection_level")


def needs_spectra(scene):
    """Whether the scene asks for Doppler processing, and why (text)."""
    lid = scene.lidar
    asked = []
    if lid.variants:
        asked.append(f"{len(lid.variants)} processing variant(s)")
    keys = [k for k in lid.instrument if k in PROCESSING_KEYS]
    if keys:
        asked.append("lidar.instrument." + ", ".join(keys))
    if lid.background_pause:
        asked.append("lidar.background_pause")
    if lid.exact_background:
        asked.append("lidar.exact_background")
    return bool(asked), ", ".join(asked)


def _k_needed(scene):
    """Largest wavenumber the analysis reads [rad/m]: analysis.k_max or the sonic's 10-Hz Nyquist."""
    k_sonic = max(math.pi * 10.0 / p.mean_speed for p in scene.periods)
    return min(scene.analysis.k_max, k_sonic)


def resolve(scene):
    """The scene with every ``"auto"`` fidelity setting chosen, and the reasons.

    Parameters
    ----------
    scene : Scene

    Returns
    -------
    (Scene, dict)
        The resolved scene (no ``"auto"`` left in ``lidar.tier``,
        ``field.dx``, ``lidar.cell_length``) and ``{setting: "value: why"}``
        for each setting that was ``"auto"`` (empty when none was).
    """
    lid, fld = scene.lidar, scene.field
    why = {}
    tier = lid.tier
    if tier == "auto":
        spectra, asked = needs_spectra(scene)
        if spectra:
            tier = "spectral"
            why["lidar.tier"] = (f"spectral: the scene asks for Doppler processing ({asked}); tier 2 with continuum "
                                 f"speckle is within the chart's tolerance ({TOLERANCE:.3f}) of tier 3 at ~1/30 of "
                                 f"its cost")
        else:
            tier = "los"
            why["lidar.tier"] = ("los: no estimator, threshold, variant or background setting asked for, so a "
                                 "noise-free line-of-sight study (tier 1); set lidar.instrument.estimator for tier 2")
    zr = lid.build_instrument().rayleigh_length
    dx = fld.dx
    if dx == "auto":
        k_need = _k_needed(scene)
        ok = [d for d in DX_LADDER if d <= DX_MAX_PER_ZR * zr * (1 + 1e-9) and math.pi / d >= k_need]
        dx = max(ok) if ok else min(DX_LADDER)
        why["field.dx"] = (f"{dx:g} m: the coarsest of {list(DX_LADDER)} m within the chart's tolerance "
                           f"(dx <= {DX_MAX_PER_ZR:.3f} z_R = {DX_MAX_PER_ZR * zr:.3g} m) that resolves the "
                           f"analysis' {k_need:.3g} rad/m (pi/dx >= {k_need:.3g} rad/m)")
    cell = lid.cell_length
    if cell == "auto":
        if lid.speckle == "continuum" and tier != "los":
            cell = max(dx, math.floor(CELL_MAX_PER_ZR * zr / dx) * dx)
            why["lidar.cell_length"] = (f"{cell:g} m: the longest cell within the chart's tolerance "
                                        f"({CELL_MAX_PER_ZR:.3f} z_R = {CELL_MAX_PER_ZR * zr:.3g} m), a multiple of "
                                        f"dx; continuum speckle converges in the cell length")
        else:
            cell = None
            why["lidar.cell_length"] = (f"the field spacing {dx:g} m: "
                                        + ("tier 1 reads the field point by point" if tier == "los" else
                                           f"speckle {lid.speckle!r} (point cells) changes with the cell count"))
    if not why:
        return scene, why
    new = scene.replace(lidar=dataclasses.replace(lid, tier=tier, cell_length=cell),
                        field=dataclasses.replace(fld, dx=dx))
    return new, why


def describe(why) -> str:
    """The reasons as one JSON text (for the results' attributes)."""
    return json.dumps(why)
