"""Figures of a scene's results, one module per kind: each function takes the results Dataset.

:mod:`~cwlidar_sim.campaign.figures.staring` (after A2012 Figs. 3-8),
:mod:`~cwlidar_sim.campaign.figures.conical` (after CS Figs. 6, 8-9, 11-12) and
:mod:`~cwlidar_sim.campaign.figures.nacelle` (coherence, preview, estimators, evolution).
"""

__all__: list = []
