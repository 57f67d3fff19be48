"""cwlidar_sim: a continuous-wave coherent Doppler wind lidar in synthetic turbulence.

Stages, one subpackage each:

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
    Virtual sensors: sonic anemometer, staring lidar.
``analysis``
    Spectra, the two transfer-function methods, A2012 theory, tensor fitting.
``campaign``
    Scenes in TOML, the runner (local or Dask), NetCDF results, figures.

Conventions used throughout the package
---------------------------------------
Units are SI: metres, seconds, m/s, and wavenumbers in rad/m.  Spectra are
*two-sided* in wavenumber unless a docstring says otherwise:
``sigma_i**2 = integral of F_ii(k1) dk1 over -inf..inf``.

Array names carry their dimensions as a suffix of single letters (PyWake's
habit), e.g. ``psd_tf`` is time x frequency.  The letters are:

==  ==========================================================
x   grid index along x (the mean-wind direction)
y   grid index along y (lateral)
z   grid index along z (vertical)
k   wavenumber k1 along x [rad/m]
q   a second wavenumber axis (k2 or k3) [rad/m]
c   velocity component (u, v, w)
t   time sample
f   frequency bin
s   range cell along a beam
b   signal block (512 samples)
e   speed estimate (one output sample)
p   averaging period
==  ==========================================================
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
