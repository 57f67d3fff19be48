"""The scene kinds of this package, one module each, found by name through :data:`~cwlidar_sim.campaign.registry.BUILTIN_KINDS`.

:mod:`~cwlidar_sim.campaign.kinds.builtin` holds the first three (staring,
conical, nacelle); an instrument added later is one module here with its
kind object and one line in :data:`~cwlidar_sim.campaign.registry.BUILTIN_KINDS`.
Nothing is imported here: the registry loads each kind's module by its
``"module:attribute"`` reference, and nothing else imports a kind.
"""
