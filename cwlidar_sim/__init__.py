"""cwlidar_sim: a continuous-wave coherent Doppler wind lidar in synthetic turbulence.

Five virtual sensors measure one turbulence field: a sonic anemometer, a cup
anemometer, a staring lidar, a conically scanning (VAD) lidar and a
turbine's nacelle lidar.  A *scene* (a TOML file, or a bundled one) says which
sensors, where, in which turbulence and for which periods; running it gives
an :class:`xarray.Dataset` of records, spectra and transfer functions.

The high-level API, at the top of the package (the quick start in the
documentation):

:func:`open_scene`
    A bundled scene by name (``"a2012"``, ``"cs"``, ``"nacelle"``) or a
    scene file; change it with ``scene.with_values({"lidar.tier": "los"})``
    (dotted keys of the file, validated like the file).
:func:`run`
    Run a scene (here or on a Dask cluster); with ``out``, its results
    folder, resumable; returns the results.
:func:`open_results`
    Read a run's results back (its folder or its file), checked.

Stages, one subpackage each, for everything below that:

``turbulence``
    Mann (1998) uniform-shear spectral tensor, analytic one-point spectra, and
    periodic box, plane and line fields; HAWC2 and NetCDF interchange.
``beam``
    Optics of the focused beam (Rayleigh length, exact and Lorentzian
    weighting, transfer functions) and line-of-sight sampling of a field.
``signal``
    The Doppler signal chain in three tiers (weighted line-of-sight average,
    expected Doppler spectra with speckle, the 50 MHz heterodyne signal),
    background, thresholds, estimators and quality flags.
``sensors``
    The virtual sensors: sonic and cup anemometers, the staring, conical
    (VAD) and nacelle lidars.
``analysis``
    Spectra, the two transfer-function methods, A2012 theory, tensor
    fitting, VAD and rotor-equivalent wind speed fits.
``campaign``
    Scenes in TOML, the runner (local or Dask), NetCDF results, figures.

Conventions used throughout the package
---------------------------------------
Units are SI: metres, seconds, m/s, and wavenumbers in rad/m.  Every
one-dimensional spectrum the package returns, measured or theoretical, is
*one-sided* (the measured-data convention, as Kaimal's and
``scipy.signal.welch``'s): ``sigma_i**2 = integral of F_ii(k1) dk1 over
0..inf`` in wavenumber, ``integral of S(f) df over 0..inf`` in frequency
(``S(f) = U F(k1) / (2 pi)`` at ``k1 = 2 pi f / U``), the same for
cross-spectra and covariances.  Mann's one-point spectra
(:func:`~cwlidar_sim.turbulence.one_point_spectra`) are therefore twice his
two-sided ``integral of Phi dk2 dk3``, and a measured spectrum estimates its
theory without any factor.  Densities over a whole wave-vector space keep
their own definition: the spectral tensor ``Phi_ij(k)`` (variance = its
integral over all of R^3), a plane's ``Phi2(k1, k2)`` (over all of R^2) and
the energy spectrum ``E(|k|)`` (``integral over 0..inf = (sigma_u^2 +
sigma_v^2 + sigma_w^2) / 2``).  Doppler spectra of the signal chain are
powers per frequency bin (:mod:`cwlidar_sim.signal`).

Array names carry their dimensions as a suffix of single letters (PyWake's
habit), e.g. ``psd_tf`` is time x frequency, ``vlos_els`` a line-of-sight
speed per estimate, look and range cell.  The alphabet is closed: one letter,
one meaning, and no other letter in a suffix (``tests/test_dimension_letters.py``).
The letters are:

==  ==========================================================
x   grid index along x (the mean-wind direction)
y   grid index along y (lateral)
z   grid index along z (vertical)
k   wavenumber k1 along x [rad/m]
q   a second wavenumber axis (k2 or k3) [rad/m]
c   component of a vector: velocity (u, v, w) or direction (x, y, z)
t   time sample
f   frequency bin
s   range cell along a beam (the probe volume's cells, then the
    mean-wind tail or a cloud cell)
j   sub-point of a range cell (the points a cell's weight is
    spread over, :class:`~cwlidar_sim.beam.cells.ProbeCells`)
l   look: an equal sub-interval of an estimate's dwell (a
    scanning beam's sweep)
b   signal block (512 samples)
n   sample within a signal block
d   lag of an autocorrelation [samples]
e   speed estimate (one output sample)
p   averaging period
==  ==========================================================
"""

from ._version import __version__

__all__ = ["__version__", "open_scene", "run", "open_results"]

#: The high-level API's names; imported from ``campaign`` on first use, so ``import cwlidar_sim``
#: (and the command line's cold start) loads no numerical library.
_API = ("open_scene", "run", "open_results")


def __getattr__(name):
    if name in _API:
        from .campaign import _api

        return getattr(_api, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
