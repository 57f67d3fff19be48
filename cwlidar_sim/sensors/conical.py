"""Virtual conically scanning cw lidar (the series ZephIR of CS; PHYSICS sections 5-6).

Geometry
--------
The telescope at ``position`` looks up a cone of half-angle Phi from the
vertical (30 deg) that it sweeps at a constant rate, one revolution per
``revolution_time`` (1 s), counter-clockwise seen from above (azimuth from
+x, the mean wind, toward +y).  For a measurement height z the focus is
``r = z / cos Phi`` and the scanned circle has diameter ``D = 2 z tan Phi``
(115 m at 100 m).  Beam direction at azimuth theta:
``n = (sin Phi cos theta, sin Phi sin theta, cos Phi)``, so a radial speed is
positive away from the telescope and the total wind ``(U + u, v, w)`` gives
``v_r = sin Phi [(U + u) cos theta + v sin theta] + cos Phi w``.

Estimates and the sweep within a dwell
--------------------------------------
Each revolution holds ``estimates_per_rev`` (50) estimates; estimate ``e``
averages the spectra of one dwell of ``revolution_time / estimates_per_rev``
(20 ms, CS: 4000 spectra) while the beam sweeps ``360 / estimates_per_rev``
degrees (7.2 deg).  The sweep is simulated: the dwell is cut into
``sub_dwells`` equal looks, look ``j`` at the look's mid-time and mid-azimuth
(``(j + 1/2) / sub_dwells`` through the dwell).

* tier ``los`` (1): ``vlos_e`` = the mean over the looks of the beam-weighted
  line-of-sight speed (A2012 Eq. 2 per look); ``speed_e = |vlos_e|``.
* tier ``spectral`` (2): the expected spectrum of the dwell is the average of
  the looks' expected spectra (every look's cells enter with weight
  ``w_s / sub_dwells``), so the sweep broadens the Doppler line (near the
  cross-wind azimuths v_r changes by ``U sin Phi 2 pi / 50``, 0.63 m/s or
  4 bins of the CS instrument at 10 m/s, within one dwell); then the
  speckle and noise draw (:func:`cwlidar_sim.signal.sample_spectra`), a
  measured background and :func:`cwlidar_sim.signal.estimate`.
* tier ``signal`` (3): the heterodyne signal
  (:func:`cwlidar_sim.signal.simulate_signal_spectra`) of each look in turn,
  ``blocks_per_estimate / sub_dwells`` blocks per look with that look's cell
  speeds (speckle and Doppler phase continuous from look to look), the looks'
  periodograms averaged into the dwell's; then the same processing as tier 2.
  It synthesises ``2 x 10^6`` samples of ``n_cells + 1`` tones per estimate,
  so records are limited to :data:`SIGNAL_MAX_ESTIMATES`; ``sub_dwells`` must
  divide ``blocks_per_estimate``.

Speckle while scanning (derived)
--------------------------------
The focal spot moves at ``v_spot = 2 pi r sin Phi / revolution_time``
(363 m/s at z = 100 m), far faster than the wind carries aerosols across the
waist ``w0 = lambda r / (pi a0)`` (2.9 mm at r = 115 m for the CS optics), so
the speckle correlation time is the spot's transit time
``tau_c = w0 / v_spot`` (8 us at 100 m; the wind's few m/s across the beam
are neglected beside v_spot) and an M-block average holds
``M_eff = speckle_looks(M, T_b, tau_c)`` independent looks
(:func:`cwlidar_sim.signal.speckle_looks`): about 2200 of CS's 4000 blocks
of 5 us -- not the handful of a staring beam -- at every height (w0 and
v_spot both grow like r, so tau_c does not depend on the height).
``tau_c`` also broadens each look's line (AR(1) amplitude, about
``1 / (2 pi tau_c)`` = 20 kHz, a tenth of a bin).

Probe volume
------------
Cells of about ``cell_length`` over ``[-span z_R, span z_R]`` around the
focus (clipped at the telescope), with the exact integrals of the weighting
(:func:`cwlidar_sim.beam.weight_truncated`, ``renormalise=False``); the
weight outside the span, ``truncated_fraction``, is given the mean wind's
radial speed ``n . (U, 0, 0)`` (a tail cell), so a uniform wind is returned
exactly and the turbulent tails are not over-weighted.

Homodyne folding and the zero crossing
--------------------------------------
The instrument loses the sign of v_r.  Twice per revolution, near the
cross-wind azimuths, |v_r| falls into the low-frequency blind zone of the
instrument (relative-intensity noise, ``blind_zone_speed``): tier 2's
processing returns NaN flagged ``NO_SIGNAL`` or an estimate flagged
``NEAR_ZERO`` (:class:`cwlidar_sim.signal.Flag`).  Tier 1 applies the same
rule to ``|vlos_e|``: below ``blind_zone_speed`` the estimate is NaN and
flagged ``NO_SIGNAL | NEAR_ZERO``, within ``edge_guard_speed`` above it the
value is kept and flagged ``NEAR_ZERO``; near Nyquist ``NEAR_NYQUIST``.
:func:`cwlidar_sim.analysis.vad.fit_scans` leaves flagged points out.

Clouds (optional)
-----------------
A cloud layer above the cone (``cloud_base`` z_b above the telescope,
``cloud_depth`` dz, backscatter ``cloud_strength`` = beta_cloud /
beta_aerosol, both per metre) is reached by the far tail of the focused
beam's weighting (``phi ~ z_R / (pi s^2)``).  Along a beam at Phi from the
vertical the layer occupies the ranges ``[z_b, z_b + dz] / cos Phi``, where
the weighting (the lidar's ``weighting``, exact or Lorentzian, the same
density as the cells) integrates to ``I_c``; the cloud then carries
``w_c = cloud_strength * I_c`` of the aerosol probe volume's (unit) weight:
one more "cell" moving at the cloud's radial speed
``n . (V_c cos psi, V_c sin psi, 0)`` (``V_c = cloud_speed``, by default the
mean wind U; ``psi = cloud_direction_deg``; no vertical motion, no
turbulence), the same look by look as the beam sweeps.  Tiers 2 and 3 renormalise
the weights to 1 and add the cloud's power to the CNR
(``cnr_db + 10 log10(1 + w_c)``, ``cnr_db`` stays the aerosol's), as
:func:`cwlidar_sim.signal.doppler.simulate_uniform` does for the staring
beam, so the spectrum holds a second Doppler line of relative power
``f_c = w_c / (1 + w_c)`` that the estimator mixes in and the processing may
flag ``SECOND_PEAK``.  Tier 1 returns the weighted mean
``(v_a + w_c v_c) / (1 + w_c)`` of the signed aerosol and cloud speeds
(the centroid of tier 2 wherever both lines have the same sign and are
above the threshold); ``vlos_e`` stays the aerosol's (the clear-air ideal)
in every tier.  Not modelled, all small beside the effect: the aerosol
weight inside and beyond the cloud (the beam is not extinguished; its weight
there is ``~ z_R / (pi R_b)`` of the total, 0.5 % at 100 m under a cloud at
1 km, and ``1 / cloud_strength`` of the cloud's own), the cloud's own speckle
time (the beam at the cloud is wider and the spot faster: its line is
narrower than the aerosol's, whose ``tau_c`` it is given) and any spread of
speeds within the cloud.  Inside the simulated span the cells would count the
cloud twice, so the cloud must lie beyond it (validated).

Heights
-------
One height: the lidar dwells there.  Several heights: it cycles, measuring
``revs_per_height`` revolutions at each height in turn and losing
``refocus_time`` between heights (the scanner keeps turning); each height
then gets its share of the record.

Randomness
----------
``seed`` spawns a background stream and one stream per fixed block of
:data:`DRAW_BLOCK` estimates of each height, so the result does not depend
on the thread count.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import check_choice, check_int, check_keys, check_real, check_seed, check_tuple
from ..signal.instrument import CS_SERIES, Instrument

__all__ = [
    "ConicalLidar",
    "ConicalRecord",
    "ScanSchedule",
    "measure_conical",
    "conical_field",
    "surface_layer_parameters",
    "HALF_ANGLE_RANGE",
    "FOCUS_RANGE",
    "TIERS",
    "DRAW_BLOCK",
    "SIGNAL_MAX_ESTIMATES",
    "CLOUD_BASE_MAX",
    "CLOUD_STRENGTH_MAX",
]

#: Allowed cone half-angle from the vertical [deg]: the VAD needs both sin Phi
#: (horizontal speed) and cos Phi (vertical speed) well away from zero.
HALF_ANGLE_RANGE = (10.0, 60.0)
#: Allowed focus distance r = z / cos Phi [m] (ZephIR: measurement heights 10-200 m,
#: and the telescope cannot focus much closer than 10 m).
FOCUS_RANGE = (10.0, 1000.0)
#: Tiers offered for the scanning beam.
TIERS = ("los", "spectral", "signal")
#: Longest record of tier 'signal' [estimates] (10 s at 50 Hz).
SIGNAL_MAX_ESTIMATES = 500
#: Estimates per block of random draws (fixed: the draws do not depend on any chunking).
DRAW_BLOCK = 2048
#: Highest cloud base [m] (the troposphere).
CLOUD_BASE_MAX = 20000.0
#: Largest cloud backscatter relative to the aerosol's [-].
CLOUD_STRENGTH_MAX = 1e9


def _check_bool(name, value):
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a bool, got {type(value).__name__} {value!r}")
    return bool(value)


@dataclasses.dataclass(frozen=True)
class ConicalLidar:
    """A conically scanning cw lidar (CS's series ZephIR by default).

    Parameters
    ----------
    heights : tuple of float
        Measurement heights z above the telescope [m]; one height: dwell,
        several: cycle (module notes).  Each needs a focus ``z / cos Phi`` in
        :data:`FOCUS_RANGE`.
    instrument : Instrument
        Acquisition and processing; its ``focus`` is replaced by each height's
        ``z / cos Phi``.  Default :data:`cwlidar_sim.signal.CS_SERIES`.
    half_angle_deg : float
        Cone half-angle Phi from the vertical [deg]; in :data:`HALF_ANGLE_RANGE`.
    revolution_time : float
        Time of one revolution [s]; in [0.1, 100].
    estimates_per_rev : int
        Estimates per revolution; in [4, 10000].  The instrument's
        ``blocks_per_estimate`` must fit in one dwell.
    revs_per_height : int
        Revolutions at each height before refocusing (cycle mode); in [1, 10000].
    refocus_time : float
        Time lost between heights in cycle mode [s]; in [0, 100].
    azimuth0_deg : float
        Beam azimuth at t = 0 [deg], from +x toward +y.
    position : tuple of 3 floats
        Telescope position (x, y, z) [m].
    tier : {'los', 'spectral', 'signal'}
    weighting : {'exact', 'lorentzian'}
    span : float
        Half-width of the simulated span in Rayleigh lengths; in (0, 1000].
    cell_length : float
        Target range-cell length [m]; in (0, 100].
    sub_dwells : int
        Looks simulated per dwell (the sweep); in [1, 256].
    cnr_db : float
        Wideband carrier-to-noise ratio [dB]; in [-200, 200] (tier 2).
    speckle : {'independent', 'coherent'}
        Tier 2's speckle gain per bin or per estimate.
    exact_background : bool
        Use the exact noise floor instead of a measured background (tier 2).
    cloud_base : float, optional
        Height of a cloud layer's base above the telescope [m] (module notes);
        default None, no cloud.  At most :data:`CLOUD_BASE_MAX`, and above
        every height's simulated span (its range ``cloud_base / cos Phi``
        beyond the span's far end).
    cloud_strength : float
        The cloud's backscatter coefficient relative to the aerosol's
        (beta_cloud / beta_aerosol, both per metre) [-]; in
        [0, :data:`CLOUD_STRENGTH_MAX`]; > 0 needs ``cloud_base``.  Water
        clouds: 1e3-1e5 (the 1.5 um aerosol backscatter of a clean boundary
        layer is ~1e-7 /m/sr, a cloud's 1e-4-1e-2 /m/sr).
    cloud_depth : float
        Vertical depth of the backscattering layer [m] (the beam's
        penetration into an optically thick cloud: ~ 1 / (2 extinction),
        10-50 m for water clouds); in (0, 10000].
    cloud_speed : float, optional
        Horizontal speed of the cloud [m/s], in [0, 200]; default None: the
        mean wind ``U`` given to :func:`measure_conical` (no shear).
    cloud_direction_deg : float
        Direction the cloud moves toward [deg], from +x (the mean wind) toward +y.
    """

    heights: tuple = (100.0,)
    instrument: Instrument = CS_SERIES
    half_angle_deg: float = 30.0
    revolution_time: float = 1.0
    estimates_per_rev: int = 50
    revs_per_height: int = 1
    refocus_time: float = 0.0
    azimuth0_deg: float = 0.0
    position: tuple = (0.0, 0.0, 0.0)
    tier: str = "los"
    weighting: str = "exact"
    span: float = 5.0
    cell_length: float = 2.0
    sub_dwells: int = 8
    cnr_db: float = -10.0
    speckle: str = "independent"
    exact_background: bool = False
    cloud_base: float | None = None
    cloud_strength: float = 0.0
    cloud_depth: float = 30.0
    cloud_speed: float | None = None
    cloud_direction_deg: float = 0.0

    def __post_init__(self):
        def put(k, v):
            object.__setattr__(self, k, v)

        if not isinstance(self.instrument, Instrument):
            raise TypeError(f"instrument must be an Instrument, got {type(self.instrument).__name__}")
        phi = check_real("half_angle_deg", self.half_angle_deg, lo=HALF_ANGLE_RANGE[0], hi=HALF_ANGLE_RANGE[1])
        put("half_angle_deg", phi)
        h = self.heights
        if isinstance(h, (int, float, np.integer, np.floating)) and not isinstance(h, bool):
            h = (h,)
        if isinstance(h, (str, bytes)) or not hasattr(h, "__len__") or len(h) < 1:
            raise TypeError(f"heights must be a non-empty sequence of heights [m], got {self.heights!r}")
        c = math.cos(math.radians(phi))
        lo_z, hi_z = FOCUS_RANGE[0] * c, FOCUS_RANGE[1] * c
        hs = []
        for i, z in enumerate(h):
            z = check_real(f"heights[{i}]", z)
            if not lo_z <= z <= hi_z:
                raise ValueError(
                    f"heights[{i}]={z!r} m needs focus r = z / cos({phi:g} deg) = {z / c:.4g} m, outside the "
                    f"focus range {FOCUS_RANGE} m; allowed heights: [{lo_z:.4g}, {hi_z:.4g}] m")
            hs.append(z)
        if len(set(hs)) != len(hs):
            raise ValueError(f"heights must be distinct, got {tuple(hs)}")
        put("heights", tuple(hs))
        put("revolution_time", check_real("revolution_time", self.revolution_time, lo=0.1, hi=100.0))
        put("estimates_per_rev", check_int("estimates_per_rev", self.estimates_per_rev, lo=4, hi=10000))
        put("revs_per_height", check_int("revs_per_height", self.revs_per_height, lo=1, hi=10000))
        put("refocus_time", check_real("refocus_time", self.refocus_time, lo=0.0, hi=100.0))
        put("azimuth0_deg", check_real("azimuth0_deg", self.azimuth0_deg))
        put("position", check_tuple("position", self.position, 3, check_real))
        check_choice("tier", self.tier, TIERS)
        check_choice("weighting", self.weighting, ("exact", "lorentzian"))
        put("span", check_real("span", self.span, lo=0.0, hi=1000.0, lo_open=True))
        put("cell_length", check_real("cell_length", self.cell_length, lo=0.0, hi=100.0, lo_open=True))
        put("sub_dwells", check_int("sub_dwells", self.sub_dwells, lo=1, hi=256))
        put("cnr_db", check_real("cnr_db", self.cnr_db, lo=-200.0, hi=200.0))
        check_choice("speckle", self.speckle, ("independent", "coherent"))
        put("exact_background", _check_bool("exact_background", self.exact_background))
        inst = self.instrument
        if self.tier == "signal" and inst.blocks_per_estimate % self.sub_dwells:
            raise ValueError(f"tier 'signal' needs sub_dwells={self.sub_dwells} to divide "
                             f"instrument.blocks_per_estimate={inst.blocks_per_estimate}; allowed: its divisors")
        fit = self.dwell_time / inst.block_duration
        if inst.blocks_per_estimate > fit * (1 + 1e-9):
            raise ValueError(
                f"instrument.blocks_per_estimate={inst.blocks_per_estimate} does not fit in one dwell of "
                f"{self.dwell_time:g} s (revolution_time / estimates_per_rev); allowed: <= {math.floor(fit + 1e-9)}")
        self._check_cloud(put)

    def _check_cloud(self, put):
        put("cloud_strength", check_real("cloud_strength", self.cloud_strength, lo=0.0, hi=CLOUD_STRENGTH_MAX))
        put("cloud_depth", check_real("cloud_depth", self.cloud_depth, lo=0.0, hi=1e4, lo_open=True))
        if self.cloud_speed is not None:
            put("cloud_speed", check_real("cloud_speed", self.cloud_speed, lo=0.0, hi=200.0))
        put("cloud_direction_deg", check_real("cloud_direction_deg", self.cloud_direction_deg))
        if self.cloud_base is None:
            if self.cloud_strength > 0.0:
                raise ValueError(f"cloud_strength={self.cloud_strength!r} > 0 needs cloud_base [m] (the height of "
                                 f"the cloud layer); allowed: cloud_strength=0 without a cloud_base")
            return
        base = check_real("cloud_base", self.cloud_base, lo=0.0, hi=CLOUD_BASE_MAX, lo_open=True)
        c = math.cos(self._phi)
        # the cloud must lie beyond every height's simulated span (module notes)
        lo = max((self.focus(z) + self.cells(z).edges[-1]) * c for z in self.heights)
        if base <= lo:
            raise ValueError(f"cloud_base={base!r} m is inside the simulated span of the beam (its far end reaches "
                             f"{lo:.4g} m); allowed: ({lo:.4g}, {CLOUD_BASE_MAX:g}] m")
        put("cloud_base", base)

    # -- interchange -----------------------------------------------------
    def as_dict(self) -> dict:
        """Plain dict of the fields, the instrument as its field dict (round-trips through :meth:`from_dict`)."""
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["instrument"] = self.instrument.as_dict()
        d["heights"] = tuple(self.heights)
        d["position"] = tuple(self.position)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "ConicalLidar":
        """Build from a mapping; unknown keys are rejected by name.

        ``instrument`` may be an :class:`Instrument`, a full field dict or a
        dict of overrides on a preset (``{'preset': 'cs', ...}``).
        """
        from .lidar import instrument_from_spec

        check_keys(cls, d)
        d = dict(d)
        if "instrument" in d:
            d["instrument"] = instrument_from_spec(d["instrument"])
        return cls(**d)

    def replace(self, **changes) -> "ConicalLidar":
        """Copy with some fields changed (validated); unknown names are rejected."""
        check_keys(type(self), changes)
        return dataclasses.replace(self, **changes)

    # -- derived ---------------------------------------------------------
    @property
    def dwell_time(self) -> float:
        """Duration of one estimate, revolution_time / estimates_per_rev [s] (20 ms)."""
        return self.revolution_time / self.estimates_per_rev

    @property
    def dwell_angle_deg(self) -> float:
        """Azimuth swept during one estimate, 360 / estimates_per_rev [deg] (7.2 deg)."""
        return 360.0 / self.estimates_per_rev

    @property
    def _phi(self) -> float:
        return math.radians(self.half_angle_deg)

    def focus(self, height: float) -> float:
        """Focus distance r = z / cos Phi [m]."""
        return float(height) / math.cos(self._phi)

    def circle_diameter(self, height: float) -> float:
        """Diameter of the scanned circle D = 2 z tan Phi [m]."""
        return 2.0 * float(height) * math.tan(self._phi)

    def instrument_at(self, height: float) -> Instrument:
        """The instrument focused at height z."""
        return self.instrument.replace(focus=self.focus(height))

    def spot_speed(self, height: float) -> float:
        """Speed of the focal spot along the circle, 2 pi r sin Phi / revolution_time [m/s]."""
        return 2.0 * math.pi * self.focus(height) * math.sin(self._phi) / self.revolution_time

    def speckle_time(self, height: float) -> float:
        """Speckle correlation time while scanning, w0 / v_spot [s] (module notes)."""
        return self.instrument_at(height).waist_radius / self.spot_speed(height)

    def speckle_looks(self, height: float) -> float:
        """Independent speckle looks M_eff of one estimate while scanning [-]."""
        from ..signal.spectral import speckle_looks

        inst = self.instrument_at(height)
        return speckle_looks(inst.blocks_per_estimate, inst.block_duration, self.speckle_time(height))

    def cells(self, height: float):
        """Range cells and exact (not renormalised) weights at height z (:class:`cwlidar_sim.beam.RangeCells`)."""
        from ..beam.optics import weight_truncated

        inst = self.instrument_at(height)
        zr = inst.rayleigh_length
        half = self.span * zr
        n = max(1, int(math.ceil((half + min(half, inst.focus)) / self.cell_length - 1e-9)))
        check_int("number of range cells", n, lo=1, hi=100_000)
        return weight_truncated(inst.optics(), self.weighting, span=self.span, n_cells=n, renormalise=False)

    def cloud_weight(self, height: float) -> float:
        """Weight of the cloud relative to the aerosol probe volume at height z, ``w_c`` [-] (module notes).

        ``cloud_strength`` times the integral of the weighting over the
        cloud's range interval ``[cloud_base, cloud_base + cloud_depth] / cos Phi``;
        0 without a cloud.
        """
        if self.cloud_base is None:
            return 0.0
        from ..beam.optics import _cauchy_exact

        inst = self.instrument_at(height)
        c = math.cos(self._phi)
        a = self.cloud_base / c - inst.focus
        b = (self.cloud_base + self.cloud_depth) / c - inst.focus
        if self.weighting == "exact":
            s0, g, eps = _cauchy_exact(inst.focus, inst.wavelength, inst.telescope_radius)
        else:
            s0, g, eps = 0.0, inst.rayleigh_length, 0.0
        # arctan((b - s0)/g) - arctan((a - s0)/g) without cancellation (a, b > s0)
        integral = math.atan(g * (b - a) / (g * g + (a - s0) * (b - s0))) / (math.pi * (1.0 - eps))
        return self.cloud_strength * integral

    def cloud_fraction(self, height: float) -> float:
        """Fraction of the received power from the cloud at height z, ``w_c / (1 + w_c)`` [-]."""
        w = self.cloud_weight(height)
        return w / (1.0 + w)

    def beam_extent(self, height: float) -> dict:
        """Horizontal radius and height range [m] that the simulated cells reach at height z."""
        cells = self.cells(height)
        r = self.focus(height)
        r_lo = max(r + cells.edges[0], 0.0)
        r_hi = r + cells.edges[-1]
        s, c = math.sin(self._phi), math.cos(self._phi)
        return {"radius": r_hi * s, "z_lo": self.position[2] + r_lo * c,
                "z_hi": self.position[2] + r_hi * c}

    def direction(self, azimuth_deg) -> np.ndarray:
        """Unit beam directions at the given azimuths [deg], shape (..., 3)."""
        az = np.radians(np.asarray(azimuth_deg, dtype=np.float64))
        s, c = math.sin(self._phi), math.cos(self._phi)
        return np.stack([s * np.cos(az), s * np.sin(az), np.full(az.shape, c)], axis=-1)

    def schedule(self, duration: float, start: float = 0.0) -> "ScanSchedule":
        """Estimate times, azimuths and heights over ``[start, start + duration)`` (module notes).

        Parameters
        ----------
        duration : float
            Record length [s]; > 0 and holding at least one revolution.
        start : float
            Start time [s]; the azimuth is ``azimuth0 + 360 t / revolution_time`` at any t.
        """
        duration = check_real("duration", duration, lo=0.0, lo_open=True)
        start = check_real("start", start)
        if duration < self.revolution_time * (1 - 1e-12):
            raise ValueError(f"duration={duration} s holds no revolution; allowed: >= revolution_time = "
                             f"{self.revolution_time} s")
        epr, dt = self.estimates_per_rev, self.dwell_time
        nh = len(self.heights)
        if nh == 1:
            n = int(math.floor(duration / dt + 1e-9))
            n -= n % epr
            j = np.arange(n)
            time_e = start + (j + 0.5) * dt
            hidx = np.zeros(n, dtype=np.int64)
            scan_e = j // epr
        else:
            block_n = self.revs_per_height * epr
            block_t = self.revs_per_height * self.revolution_time + self.refocus_time
            nb = int(math.floor((duration + self.refocus_time) / block_t + 1e-9))
            if nb < 1:
                raise ValueError(f"duration={duration} s holds no complete height block of {block_t:g} s")
            b = np.repeat(np.arange(nb), block_n)
            j = np.tile(np.arange(block_n), nb)
            time_e = start + b * block_t + (j + 0.5) * dt
            hidx = b % nh
            scan_e = b * self.revs_per_height + j // epr
        az = self.azimuth0_deg + 360.0 * time_e / self.revolution_time
        return ScanSchedule(time_e=time_e, azimuth_e=az, height_index_e=hidx, revolution_e=scan_e,
                            heights=self.heights)


@dataclasses.dataclass(frozen=True)
class ScanSchedule:
    """Estimates of a conical scan.

    Attributes
    ----------
    time_e : ndarray, shape (n_e,)
        Dwell mid-times [s].
    azimuth_e : ndarray, shape (n_e,)
        Beam azimuth at the dwell's mid-time [deg] (unwrapped, increasing).
    height_index_e : ndarray of int, shape (n_e,)
        Index into ``heights`` of each estimate.
    revolution_e : ndarray of int, shape (n_e,)
        Revolution number of each estimate (consecutive within a height block).
    heights : tuple of float
        Heights [m].
    """

    time_e: np.ndarray
    azimuth_e: np.ndarray
    height_index_e: np.ndarray
    revolution_e: np.ndarray
    heights: tuple


@dataclasses.dataclass(frozen=True)
class ConicalRecord:
    """Output of :func:`measure_conical`.

    Attributes
    ----------
    time_e, azimuth_e, height_index_e, revolution_e : ndarray
        The :class:`ScanSchedule` of the record.
    height_e : ndarray, shape (n_e,)
        Height of each estimate [m].
    vlos_e : ndarray, shape (n_e,)
        Tier-1 dwell-averaged weighted line-of-sight speed [m/s], signed: the ideal.
    speed_e : ndarray, shape (n_e,)
        The instrument's estimate |v_r| [m/s]; NaN where it failed.
    flags_e : ndarray, uint8, shape (n_e,)
        :class:`cwlidar_sim.signal.Flag` bits.
    availability : float
        Fraction of finite ``speed_e``.
    info : dict
        Per height: focus, circle diameter, Rayleigh length, cells, truncated
        fraction, spot speed, speckle time and looks (with a cloud also
        ``cloud_range`` [m], ``cloud_weight`` w_c and ``cloud_fraction``
        w_c / (1 + w_c)); tier, sub_dwells, flag counts.
    """

    time_e: np.ndarray
    azimuth_e: np.ndarray
    height_index_e: np.ndarray
    revolution_e: np.ndarray
    height_e: np.ndarray
    vlos_e: np.ndarray
    speed_e: np.ndarray
    flags_e: np.ndarray
    availability: float
    info: dict

    def select(self, height: float) -> dict:
        """Arrays of the estimates at one height: time, azimuth, speed, flags, vlos, revolution."""
        m = self.height_e == float(height)
        if not m.any():
            raise ValueError(f"height={height!r} is not in the record; allowed: {sorted(set(self.height_e))}")
        return {"time_e": self.time_e[m], "azimuth_e": self.azimuth_e[m], "speed_e": self.speed_e[m],
                "flags_e": self.flags_e[m], "vlos_e": self.vlos_e[m], "revolution_e": self.revolution_e[m]}


def _homodyne_flags(inst, vlos_e):
    """Tier 1's folding and low-frequency cut (module notes): speed_e, flags_e."""
    from ..signal.processing import Flag

    speed = np.abs(vlos_e)
    flags = np.zeros(vlos_e.shape, dtype=np.uint8)
    low = speed < inst.blind_zone_speed
    near = speed < inst.blind_zone_speed + inst.edge_guard_speed
    nyq = speed > inst.nyquist_speed - inst.edge_guard_speed
    flags[near] |= np.uint8(Flag.NEAR_ZERO)
    flags[low] |= np.uint8(Flag.NO_SIGNAL)
    flags[nyq] |= np.uint8(Flag.NEAR_NYQUIST)
    speed = np.where(low, np.nan, speed)
    return speed, flags


def measure_conical(field, lidar: ConicalLidar, duration: float, U: float, seed=None, *, start: float = 0.0,
                    wrap: bool = False) -> ConicalRecord:
    """Simulate a conically scanning lidar's record of radial-speed estimates in a turbulence field.

    Parameters
    ----------
    field : xarray.Dataset
        Box field (see :func:`cwlidar_sim.beam.sample_los`) holding every cell
        of the cone (:func:`conical_field` builds one); u, v, w fluctuations [m/s].
    lidar : ConicalLidar
    duration : float
        Record length [s] (:meth:`ConicalLidar.schedule`).
    U : float
        Mean wind along +x [m/s] (Taylor advection and the mean of u).
    seed : int or numpy.random.Generator, optional
        Randomness of tiers 'spectral' and 'signal'; ignored by tier 'los'.
    start : float
        Start time [s].
    wrap : bool
        Treat y and z as periodic.

    Returns
    -------
    ConicalRecord
    """
    from .._config import apply_numba_threads
    from ..beam.sampling import _check_extent, _check_flag, _prepare_field
    from ..signal.processing import FAIL_FLAGS, Flag

    if not isinstance(lidar, ConicalLidar):
        raise TypeError(f"lidar must be a ConicalLidar, got {type(lidar).__name__}")
    U = check_real("U", U, lo=-1000.0, hi=1000.0)
    wrap = _check_flag("wrap", wrap)
    sch = lidar.schedule(duration, start)
    origin = np.asarray(lidar.position, dtype=np.float64)
    fld = _prepare_field(field, origin)
    ne = sch.time_e.size
    nsub = lidar.sub_dwells
    vlos_e = np.empty(ne)
    speed_e = np.empty(ne)
    flags_e = np.zeros(ne, dtype=np.uint8)
    height_e = np.asarray(lidar.heights)[sch.height_index_e]
    info = {"tier": lidar.tier, "sub_dwells": nsub, "n_estimates": ne, "heights": {}}
    if lidar.tier == "signal" and ne > SIGNAL_MAX_ESTIMATES:
        raise ValueError(f"tier 'signal' synthesises the {lidar.instrument.sample_rate:g} Hz signal of every cell: "
                         f"{ne} estimates is too many; allowed: <= {SIGNAL_MAX_ESTIMATES} (use tier 'spectral')")
    if lidar.tier != "los":
        if seed is None:
            raise ValueError(f"seed is required for tier {lidar.tier!r}; allowed: an int or a numpy Generator")
        if isinstance(seed, np.random.Generator):
            root = np.random.SeedSequence(int(seed.integers(0, 2**63 - 1)))
        else:
            root = np.random.SeedSequence(check_seed("seed", seed))
        height_seqs = root.spawn(len(lidar.heights))
    apply_numba_threads()
    # look offsets within a dwell, in units of the dwell: (j + 1/2) / nsub - 1/2
    off_j = (np.arange(nsub) + 0.5) / nsub - 0.5
    for ih, z in enumerate(lidar.heights):
        idx = np.flatnonzero(sch.height_index_e == ih)
        if idx.size == 0:
            continue
        inst = lidar.instrument_at(z)
        cells = lidar.cells(z)
        range_s = np.ascontiguousarray(np.maximum(inst.focus + cells.s_s, 0.0))
        w_s = np.ascontiguousarray(cells.weight_s, dtype=np.float64)
        tail = float(cells.truncated_fraction)
        ns = w_s.size
        # extent check over the whole circle (every azimuth at the extreme ranges)
        ring = lidar.direction(np.linspace(0.0, 360.0, 73))
        _check_extent(fld, origin, ring, range_s, wrap, 1e-6)
        hinfo = {"focus": inst.focus, "circle_diameter": lidar.circle_diameter(z),
                 "rayleigh_length": inst.rayleigh_length, "n_cells": ns, "cell_length": float(cells.edges[1] -
                 cells.edges[0]), "truncated_fraction": tail, "spot_speed": lidar.spot_speed(z),
                 "speckle_time": lidar.speckle_time(z), "m_eff": lidar.speckle_looks(z),
                 "n_estimates": int(idx.size)}
        cloud = lidar.cloud_base is not None
        cnr_db = lidar.cnr_db
        if cloud:
            w_cl = lidar.cloud_weight(z)
            hinfo.update(cloud_range=lidar.cloud_base / math.cos(lidar._phi), cloud_weight=w_cl,
                         cloud_fraction=w_cl / (1.0 + w_cl))
            v_cl = U if lidar.cloud_speed is None else lidar.cloud_speed
            psi = math.radians(lidar.cloud_direction_deg)
            vel_cl = np.array([v_cl * math.cos(psi), v_cl * math.sin(psi), 0.0])
            # the cloud is one more cell: weights renormalised to 1, its power added to the CNR (module notes)
            cnr_db = cnr_db + 10.0 * math.log10(1.0 + w_cl)
            look_w = np.append(np.append(w_s, tail), w_cl) / (1.0 + w_cl)
        else:
            look_w = np.append(w_s, tail)
        if lidar.tier != "los":
            from ..signal.processing import background_spectrum

            s_bg, s_sim = height_seqs[ih].spawn(2)
            bg = None if lidar.exact_background else background_spectrum(inst, np.random.default_rng(s_bg))
            weights_c = np.concatenate([np.tile(look_w, nsub) / nsub])
        for b0 in range(0, idx.size, DRAW_BLOCK):
            sel = idx[b0: b0 + DRAW_BLOCK]
            nb = sel.size
            t_l = (sch.time_e[sel][:, None] + off_j[None, :] * lidar.dwell_time).ravel()
            az_l = (sch.azimuth_e[sel][:, None] + off_j[None, :] * lidar.dwell_angle_deg).ravel()
            n_lc = np.ascontiguousarray(lidar.direction(az_l))
            vlos_ls, vlos_l = _sample_looks(fld, wrap, origin, n_lc, range_s, w_s, tail, t_l, U)
            vlos_e[sel] = vlos_l.reshape(nb, nsub).mean(axis=1)
            nc = ns + 1
            if cloud:
                vcl_l = n_lc @ vel_cl  # the cloud's radial speed of every look
                vlos_ls = np.ascontiguousarray(np.concatenate([vlos_ls, vcl_l[:, None]], axis=1))
                nc += 1
            if lidar.tier == "los":
                v_mix = vlos_e[sel]
                if cloud:
                    v_mix = (v_mix + w_cl * vcl_l.reshape(nb, nsub).mean(axis=1)) / (1.0 + w_cl)
                speed_e[sel], flags_e[sel] = _homodyne_flags(inst, v_mix)
            elif lidar.tier == "signal":
                speed_e[sel], flags_e[sel] = _signal_block(inst, lidar, z, vlos_ls, look_w, bg,
                                                           s_sim, b0 // DRAW_BLOCK, nb, cnr_db)
            else:
                sp, fl = _spectral_block(inst, lidar, z, vlos_ls.reshape(nb, nsub * nc), weights_c, bg,
                                         s_sim, b0 // DRAW_BLOCK, cnr_db)
                speed_e[sel], flags_e[sel] = sp, fl
        if lidar.tier != "los":
            hinfo["background"] = "exact" if lidar.exact_background else f"measured ({inst.background_blocks} blocks)"
        info["heights"][float(z)] = hinfo
    info["flag_counts"] = {f.name: int(np.count_nonzero(flags_e & f.value)) for f in Flag}
    info["n_failed"] = int(np.count_nonzero(flags_e & int(FAIL_FLAGS)))
    avail = float(np.mean(np.isfinite(speed_e))) if ne else float("nan")
    return ConicalRecord(time_e=sch.time_e, azimuth_e=sch.azimuth_e, height_index_e=sch.height_index_e,
                         revolution_e=sch.revolution_e, height_e=height_e, vlos_e=vlos_e, speed_e=speed_e,
                         flags_e=flags_e, availability=avail, info=info)


def _sample_looks(fld, wrap, origin, n_lc, range_s, w_s, tail, t_l, U):
    from . import _conical_kernels as K

    nl = t_l.size
    vlos_ls = np.empty((nl, range_s.size + 1))
    vlos_l = np.empty(nl)
    K.scan_cells_kernel(fld.u, fld.v, fld.w, fld.grid, wrap, wrap, origin, n_lc, range_s, w_s, tail,
                        np.ascontiguousarray(t_l), float(U), vlos_ls, vlos_l)
    return vlos_ls, vlos_l


def _spectral_block(inst, lidar, z, vlos_ec, weights_c, bg, seq, block, cnr_db=None):
    """Tier 2 for one block of estimates: the looks' spectra averaged, speckle, noise, processing."""
    from ..signal.processing import estimate
    from ..signal.spectral import sample_spectra
    from .lidar import expected_spectrum_exact

    tau = lidar.speckle_time(z)
    cnr_db = lidar.cnr_db if cnr_db is None else cnr_db
    sig, noise = expected_spectrum_exact(inst, vlos_ec, weights_c, cnr_db, correlation_time=tau)
    child = np.random.SeedSequence(seq.entropy, spawn_key=tuple(seq.spawn_key) + (block,))
    spec = sample_spectra(sig, noise, inst.blocks_per_estimate, lidar.speckle_looks(z),
                          np.random.default_rng(child), speckle=lidar.speckle)
    est = estimate(spec, inst, bg)
    return est.speed_e, est.flags_e


def _signal_block(inst, lidar, z, vlos_ls, weight_s, bg, seq, block, nb, cnr_db=None):
    """Tier 3 for one block of estimates: each look's blocks in turn, the looks' periodograms averaged."""
    from ..signal.heterodyne import simulate_signal_spectra
    from ..signal.processing import estimate

    nsub = lidar.sub_dwells
    cnr_db = lidar.cnr_db if cnr_db is None else cnr_db
    look = inst.replace(blocks_per_estimate=inst.blocks_per_estimate // nsub,
                        estimate_rate=inst.estimate_rate * nsub)
    child = np.random.SeedSequence(seq.entropy, spawn_key=tuple(seq.spawn_key) + (block,))
    spec_l = simulate_signal_spectra(look, vlos_ls, weight_s, cnr_db, np.random.default_rng(child),
                                     correlation_time=lidar.speckle_time(z))
    spec = spec_l.reshape(nb, nsub, -1).mean(axis=1)
    est = estimate(spec, inst, bg)
    return est.speed_e, est.flags_e


# ---------------------------------------------------------------------------
# turbulence for the cone
# ---------------------------------------------------------------------------
def surface_layer_parameters(height: float, speed: float, *, z0: float = 0.01, source: str = "mann1994",
                             sigma_u_over_ustar: float = 2.4, gamma: float = 3.9):
    """Mann parameters at height z in a neutral surface layer over flat terrain.

    ``u* = kappa U(z) / ln(z / z0)`` (log law, kappa = 0.4; default
    ``z0 = 0.01`` m, grass, Hoevsoere's flat farmland), then

    * ``source='mann1994'`` (default): Mann's (1994, J. Fluid Mech. 273) fit
      of his tensor to Kaimal's neutral spectra, ``alpha eps^(2/3) = 3.2 u*^2
      z^(-2/3)``, ``L = 0.59 z``, ``Gamma = 3.9``: the same surface layer as
      CS's Kaimal model, at every height;
    * ``source='iec'``: IEC 61400-1 Annex C (:meth:`MannParameters.iec`,
      ``L = 0.56 z`` up to 60 m and 33.6 m above) for ``sigma_u =
      sigma_u_over_ustar u*`` (neutral surface layer: 2.4, Panofsky & Dutton 1984).

    Parameters
    ----------
    height : float
        Height z [m]; > z0.
    speed : float
        Mean wind speed at z [m/s]; > 0.
    z0 : float
        Roughness length [m]; in (0, 2].
    source : {'mann1994', 'iec'}
    sigma_u_over_ustar : float
        sigma_u / u* for 'iec' [-]; in (0, 10].
    gamma : float
        Mann's anisotropy for 'iec' [-].

    Returns
    -------
    params : MannParameters
    sigma_u : float
        sigma_u of the tensor ('mann1994', from its one-point spectrum) or the IEC target [m/s].
    u_star : float
        Friction velocity [m/s].
    """
    from ..turbulence.parameters import MannParameters

    z0 = check_real("z0", z0, lo=0.0, hi=2.0, lo_open=True)
    z = check_real("height", height, lo=z0, lo_open=True)
    U = check_real("speed", speed, lo=0.0, lo_open=True)
    check_choice("source", source, ("mann1994", "iec"))
    ratio = check_real("sigma_u_over_ustar", sigma_u_over_ustar, lo=0.0, hi=10.0, lo_open=True)
    ustar = 0.4 * U / math.log(z / z0)
    if source == "iec":
        su = ratio * ustar
        return MannParameters.iec(z, su, gamma=gamma), su, ustar
    from ..turbulence.spectra import covariances

    p = MannParameters(alpha_eps=3.2 * ustar**2 * z ** (-2.0 / 3.0), length_scale=0.59 * z, gamma=3.9)
    return p, math.sqrt(covariances(p).uu), ustar


def conical_field(lidar: ConicalLidar, U: float, duration: float, params, seed: int, *, spacing: float,
                  lateral_doubling: bool = True, min_extent: float | None = None, dtype=np.float32):
    """A Mann box holding a conical lidar's cells for a record, placed in the lidar's frame.

    Parameters
    ----------
    lidar : ConicalLidar
        Its heights, cone and span set the region (all heights together).
    U : float
        Mean wind [m/s]; the box's x period must hold ``U duration`` plus the
        circle, so that no part of the field is seen twice.
    duration : float
        Record length [s]; > 0.
    params : MannParameters
    seed : int
    spacing : float
        Grid spacing in x, y and z [m]; in (0, 100].
    lateral_doubling : bool
        Generate the box twice as wide in y and keep one half (hipersim's
        default), so that the far side of the circle is not correlated with
        its periodic image W - D away (see the notes).
    min_extent : float, optional
        Minimum lateral and vertical size of the kept box [m]; default
        ``2 L`` (L the tensor's length scale), so that the lowest resolved
        modes are not much shorter than the energy-containing eddies.
    dtype : float32 or float64

    Returns
    -------
    xarray.Dataset
        u, v, w [m/s] on x, y, z; y centred on the lidar, z from below the
        lowest cell; attrs hold the generation settings (``period_x``,
        ``lateral_doubling``, ``generated_shape``).

    Notes
    -----
    Lateral periodicity: a periodic box of width W correlates y with
    y + W, so points at the two ends of a circle diameter D (y = +-D/2) are
    only ``W - D`` apart through the periodic image; for W close to D the far
    sides of the circle are nearly the same air.  Generating ``2 W`` and
    keeping ``W`` makes the kept box's two lateral ends ``W`` apart through
    the image as well (the generated box's correlation at lag ``2W - D``
    instead of ``W - D``); the price is twice the generation cost.  Kept
    boxes are not periodic in y, so sampling uses ``wrap=False``.
    """
    import xarray as xr

    from ..turbulence.box import generate_box
    from ..turbulence.parameters import MannParameters

    if not isinstance(lidar, ConicalLidar):
        raise TypeError(f"lidar must be a ConicalLidar, got {type(lidar).__name__}")
    if not isinstance(params, MannParameters):
        raise TypeError(f"params must be MannParameters, got {type(params).__name__}")
    U = check_real("U", U, lo=0.0, hi=1000.0)
    duration = check_real("duration", duration, lo=0.0, lo_open=True)
    d = check_real("spacing", spacing, lo=0.0, hi=100.0, lo_open=True)
    lateral_doubling = _check_bool("lateral_doubling", lateral_doubling)
    ext = 2.0 * params.length_scale if min_extent is None else check_real("min_extent", min_extent, lo=0.0)
    radius = max(lidar.beam_extent(z)["radius"] for z in lidar.heights)
    z_lo = min(lidar.beam_extent(z)["z_lo"] for z in lidar.heights)
    z_hi = max(lidar.beam_extent(z)["z_hi"] for z in lidar.heights)
    for z in lidar.heights:  # in-situ sensors at the measurement heights
        z_lo, z_hi = min(z_lo, lidar.position[2] + z), max(z_hi, lidar.position[2] + z)
    width = max(2.0 * radius + 2.0 * d, ext)
    height = max(z_hi - z_lo + 2.0 * d, ext)
    ny = int(math.ceil(width / d)) + 1
    nz = int(math.ceil(height / d)) + 1
    nx = _fast_size(int(math.ceil((U * duration + 2.0 * radius + 4.0 * d) / d)))
    ny_gen = 2 * ny if lateral_doubling else ny
    box = generate_box(params, (nx, ny_gen, nz), (d, d, d), seed, dtype=dtype)
    y0 = lidar.position[1] - 0.5 * (ny - 1) * d
    zc = 0.5 * (z_lo + z_hi)
    zb = zc - 0.5 * (nz - 1) * d
    data = {c: (("x", "y", "z"), np.ascontiguousarray(box[c].values[:, :ny, :])) for c in ("u", "v", "w")}
    attrs = dict(box.attrs)
    attrs.update(period_x=nx * d, lateral_doubling=int(lateral_doubling), generated_shape=(nx, ny_gen, nz))
    del box
    coords = {"x": lidar.position[0] - radius - d + np.arange(nx) * d, "y": y0 + np.arange(ny) * d,
              "z": zb + np.arange(nz) * d}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _fast_size(n: int) -> int:
    """Smallest integer >= n whose prime factors are 2, 3 and 5 (fast FFT lengths)."""
    m = max(2, n)
    while True:
        k = m
        for p in (2, 3, 5):
            while k % p == 0:
                k //= p
        if k == 1:
            return m
        m += 1
