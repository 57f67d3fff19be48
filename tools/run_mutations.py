"""Curated mutation check: break the physics on purpose and require the relevant tests to fail.

Run by hand (not collected by pytest: no ``test_`` prefix, and pytest only collects
``test_*.py``), from the repository root::

    CWLIDAR_SIM_NUM_THREADS=1 python tools/run_mutations.py [--only ID ...] [--baseline]
                                                                      [--json PATH] [--list]

Each mutation is (id, stage, file, exact old text, new text, pytest selection, what it
breaks).  For every mutation the repository's working tree (without .git) is copied to a
temporary directory, the old text (which must occur exactly once) is replaced in the copy,
and only the selected tests run there (``python -m pytest -x -q``, imports resolve to the
copy because pytest runs from its root).  A mutation is *caught* when pytest exits with
code 1 (a test failed); any other code (collection error, usage error) is reported as an
error, since it shows nothing about the tests.  The real files are never touched.
``--baseline`` first runs every selection on an unmutated copy, which must pass.

Prints a table (mutation, tests run, caught, seconds) and writes JSON
(default ``results/mutations.json``, git-ignored).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


@dataclasses.dataclass(frozen=True)
class Mutation:
    id: str
    stage: str
    file: str
    old: str
    new: str
    tests: tuple
    why: str


M = Mutation
MUTATIONS = [
    # --- turbulence ---------------------------------------------------------------------------
    M("tensor-lifetime-half", "turbulence tensor", "cwlidar_sim/turbulence/tensor.py",
      "return params.gamma * kl ** (-2.0 / 3.0) / np.sqrt(hyp2f1(",
      "return 0.5 * params.gamma * kl ** (-2.0 / 3.0) / np.sqrt(hyp2f1(",
      ("tests/turbulence/test_tensor.py", "tests/turbulence/test_spectra.py"),
      "eddy lifetime (shear distortion) halved"),
    M("tensor-energy-exponent", "turbulence tensor", "cwlidar_sim/turbulence/tensor.py",
      "kl**4 / (1.0 + kl**2) ** (17.0 / 6.0)", "kl**4 / (1.0 + kl**2) ** (17.0 / 5.0)",
      ("tests/turbulence/test_tensor.py", "tests/turbulence/test_spectra.py"),
      "von Karman energy spectrum: wrong inertial-range exponent"),
    M("box-amplitude-factor2", "turbulence box", "cwlidar_sim/turbulence/box.py",
      "scale = _prefactor(params) * math.sqrt(dk[0] * dk[1] * dk[2])",
      "scale = _prefactor(params) * math.sqrt(2.0 * dk[0] * dk[1] * dk[2])",
      ("tests/turbulence/test_turbulence_box.py",),
      "box Fourier amplitudes carry twice the variance"),
    M("box-noise-keyed-by-position", "turbulence box", "cwlidar_sim/turbulence/_kernels/box.py",
      "_row_normals(key, key_b, box_row_counter(s1, s2), za, rej)",
      "_row_normals(key, key_b, box_row_counter(n1, n2), za, rej)",
      ("tests/turbulence/test_grid_consistency.py::test_boxes_of_one_physical_size_share_their_coefficients",),
      "box noise keyed by the loop position, not the wavenumber (another grid, another realisation)"),
    M("plane-noise-keyed-by-position", "turbulence plane", "cwlidar_sim/turbulence/_kernels/rng.py",
      "_row_normals(key, key_b, plane_row_counter(s1), out_xy32[r].reshape(n), rej)",
      "_row_normals(key, key_b, plane_row_counter(n1), out_xy32[r].reshape(n), rej)",
      ("tests/turbulence/test_grid_consistency.py::test_planes_of_one_physical_size_share_their_coefficients",),
      "plane noise keyed by the row position, not the wavenumber"),
    M("plane-table-global-spline", "turbulence plane", "cwlidar_sim/turbulence/fields.py",
      "return np.ascontiguousarray(lattice_pieces(_to_spline_values(v_jc6), h))",
      "return np.ascontiguousarray(__import__('scipy.interpolate').interpolate.CubicSpline("
      "h * np.arange(len(v_jc6)), _to_spline_values(v_jc6), axis=0).c[:, 1:-1])",
      ("tests/turbulence/test_grid_consistency.py::test_planes_of_one_physical_size_share_their_coefficients",),
      "plane spectra from a global spline, whose pieces move with the grid's ends"),
    M("line-spectra-global-spline", "turbulence line", "cwlidar_sim/turbulence/fields.py",
      "coef = lattice_pieces(np.column_stack([np.log(Ft[:, :3]), rho]), h)",
      "coef = __import__('scipy.interpolate').interpolate.CubicSpline(h * np.arange(len(rho)), "
      "np.column_stack([np.log(Ft[:, :3]), rho]), axis=0).c[:, 1:-1]",
      ("tests/turbulence/test_grid_consistency.py::test_lines_of_one_length_share_their_coefficients",),
      "line spectra from a global spline, whose pieces move with the grid's ends"),
    M("surface-layer-phi-m-exponent", "turbulence surface layer", "cwlidar_sim/turbulence/surface_layer.py",
      "return (1.0 - _BD_UNSTABLE * zeta) ** -0.25", "return (1.0 - _BD_UNSTABLE * zeta) ** -0.5",
      ("tests/turbulence/test_surface_layer.py",),
      "unstable Businger-Dyer shear function with the heat-flux exponent (-1/2)"),
    M("surface-layer-length-times-phi", "turbulence surface layer", "cwlidar_sim/turbulence/surface_layer.py",
      "length_scale=0.59 * z / pm, gamma=3.9)", "length_scale=0.59 * z * pm, gamma=3.9)",
      ("tests/turbulence/test_surface_layer.py",),
      "Mann length scale grows in stable air instead of following the mixing length"),
    # --- beam ---------------------------------------------------------------------------------
    M("optics-rayleigh-no-pi", "beam optics", "cwlidar_sim/beam/optics.py",
      "return self.wavelength * self.focus**2 / (math.pi * self.radius**2)",
      "return self.wavelength * self.focus**2 / (self.radius**2)",
      ("tests/beam/test_optics.py",),
      "Rayleigh length (A2012 Eq. 1) without its pi"),
    M("lorentzian-cells-2zR", "beam optics", "cwlidar_sim/beam/optics.py",
      "cdf = np.arctan(edges / zR) / math.pi", "cdf = np.arctan(edges / (2.0 * zR)) / math.pi",
      ("tests/sensors/test_staring_lidar.py::test_tier1_is_the_weighted_line_of_sight_average_of_the_total_wind",),
      "Lorentzian range cells with twice the Rayleigh length (tier 1 against the plain-Python reference)"),
    M("sampling-taylor-sign", "beam sampling", "cwlidar_sim/beam/_kernels.py",
      "px = origin[0] + r * ex - shift", "px = origin[0] + r * ex + shift",
      ("tests/beam/test_sampling.py",),
      "Taylor advection in the wrong direction"),
    M("aperture-field-not-squared", "beam aperture", "cwlidar_sim/beam/aperture.py",
      "acc += (wv[lo:lo + step] * vv) @ (i2 * i2)", "acc += (wv[lo:lo + step] * vv) @ i2",
      ("tests/beam/test_aperture.py::test_pupil_function_against_the_autocorrelation_integral",),
      "truncated-aperture weighting from |E|^2 instead of |E_T E_BPLO|^2"),
    M("aperture-intensity-radius", "beam aperture", "cwlidar_sim/beam/aperture.py",
      "p = (wx * x * np.exp(-x * x)) * np.exp(1j * phase)", "p = (wx * x * np.exp(-2.0 * x * x)) * np.exp(1j * phase)",
      ("tests/beam/test_aperture.py::test_pupil_function_against_the_autocorrelation_integral",),
      "pupil amplitude with the e^-2 radius taken as the field's (intensity radius confused)"),
    M("aperture-normaliser-tail", "beam aperture", "cwlidar_sim/beam/aperture.py",
      "    total += tail(c_hi, m_max, math.inf)\n", "\n",
      ("tests/beam/test_aperture.py::test_truncated_weight_integrates_to_one_and_transforms_to_one_at_k0",),
      "truncated-aperture weighting normalised without the telescope-side tail"),
    # --- signal chain -------------------------------------------------------------------------
    M("speckle-looks-correlation", "signal tier 2", "cwlidar_sim/signal/spectral.py",
      "c = 2.0 * (r / one_r - r", "c = 1.0 * (r / one_r - r",
      ("tests/signal/test_spectral.py",),
      "effective number of speckle looks with half the block correlation"),
    M("tier3-ar1-rho", "signal tier 3", "cwlidar_sim/signal/heterodyne.py",
      "math.exp(-self.L / (fs * tau))", "math.exp(-2.0 * self.L / (fs * tau))",
      ("tests/signal/test_heterodyne.py", "tests/signal/test_tiers.py"),
      "tier-3 speckle decorrelates twice as fast"),
    M("tier3-colour-no-carry", "signal tier 3", "cwlidar_sim/signal/_kernels/heterodyne.py",
      "            seg[k] += w1[k] * c1 + w2[k] * c2", "            seg[k] += 0.0 * (w1[k] * c1 + w2[k] * c2)",
      ("tests/signal/test_noise_colour.py",),
      "coloured noise: each segment restarts from zero (the blocked scan's carry dropped)"),
    M("tier3-colour-segment-end", "signal tier 3", "cwlidar_sim/signal/_kernels/heterodyne.py",
      "        c1 = w1[ln - 1] * c1 + e1", "        c1 = w1[ln - 1] * c1",
      ("tests/signal/test_noise_colour.py",),
      "coloured noise: the carried state forgets the segment's own innovations"),
    M("tier3-colour-cold-start", "signal tier 3", "cwlidar_sim/signal/_kernels/heterodyne.py",
      "    state_2[0] = cf_8[5] * z0", "    state_2[0] = 0.0 * z0",
      ("tests/signal/test_noise_colour.py",),
      "coloured noise: the slow component starts each estimate from zero, not its stationary law"),
    M("tier3-colour-filter-sign", "signal tier 3", "cwlidar_sim/signal/heterodyne.py",
      "a0, b = float(x[0]), np.concatenate([x[1:], np.zeros(2 - c)])",
      "a0, b = float(x[0]), np.concatenate([-x[1:], np.zeros(2 - c)])",
      ("tests/signal/test_noise_colour.py",),
      "coloured noise: the AR(1) parts enter with the wrong sign"),
    M("tier3-colour-unordered", "signal tier 3", "cwlidar_sim/signal/heterodyne.py",
      "        self.ordered = ordered", "        self.ordered = False",
      ("tests/signal/test_noise_colour.py",),
      "coloured noise: an estimate's tasks synthesise in any order (state raced between threads)"),
    M("tier2-gridded-deconvolution", "signal tier 2", "cwlidar_sim/signal/spectral.py",
      "np.exp(np.arange(t_used) ** 2 * tau) / m", "np.exp(-np.arange(t_used) ** 2 * tau) / m",
      ("tests/signal/test_gridded.py",),
      "gridded cosine sums: the Gaussian multiplied in again instead of divided out"),
    M("tier2-gridded-spread-side", "signal tier 2", "cwlidar_sim/signal/_kernels/continuum.py",
      "            down = math.exp(2.0 * d * h * inv4t)", "            down = math.exp(-2.0 * d * h * inv4t)",
      ("tests/signal/test_gridded.py",),
      "gridded cosine sums: the Gaussian's lower side built from the upper side's factor"),
    M("threshold-no-background-term", "signal processing", "cwlidar_sim/signal/processing.py",
      "sigma_y = math.sqrt(1.0 / instrument.blocks_per_estimate + 1.0 / m_bg)",
      "sigma_y = math.sqrt(1.0 / instrument.blocks_per_estimate)",
      ("tests/signal/test_estimators.py",),
      "threshold ignores the background estimate's own noise"),
    M("median-not-half", "signal estimators", "cwlidar_sim/signal/_kernels/processing.py",
      "half = 0.5 * total", "half = 0.45 * total",
      ("tests/signal/test_estimators.py",),
      "median estimator takes the 45 % point"),
    M("parabolic-vertex", "signal estimators", "cwlidar_sim/signal/_kernels/processing.py",
      "d = 0.5 * (yl - yr) / den", "d = 0.6 * (yl - yr) / den",
      ("tests/signal/test_estimators.py::test_bias_off_centre",),
      "parabolic / Gaussian peak refinement with the wrong vertex"),
    # --- sensors ------------------------------------------------------------------------------
    M("sonic-weights-mirrored", "sonic resampling", "cwlidar_sim/sensors/sonic.py",
      "_A2012_W = tuple((float(6 - i) / 5.0, 1.0, 1.0, float(i) / 5.0) for i in range(1, 6))",
      "_A2012_W = tuple((float(i) / 5.0, 1.0, 1.0, float(6 - i) / 5.0) for i in range(1, 6))",
      ("tests/sensors/test_sonic.py::test_resample_variance_and_lag_one_covariance_of_white_noise",),
      "A2012 Eq. 5 weights mirrored (same variance, other covariance)"),
    M("block-average-counts-gaps", "sensors block average", "cwlidar_sim/sensors/sonic.py",
      "total / np.maximum(n_valid, 1)", "total / m",
      ("tests/sensors/test_sonic.py",),
      "50 -> 10 Hz block mean divides by the block size, not the valid samples"),
    M("transverse-rms-keeps-along-beam", "staring lidar", "cwlidar_sim/sensors/lidar.py",
      "perp = vel_tsc[:, 0, :] - vlos_ts[:, :1] * n3[None, :]", "perp = vel_tsc[:, 0, :] * np.array([0.0, 1.0, 1.0])",
      ("tests/sensors/test_staring_lidar.py::test_spectral_tier_with_a_misaligned_beam_in_a_plane",),
      "speed across the beam taken as (v, w) whatever the beam's direction"),
    # --- analysis -----------------------------------------------------------------------------
    M("method2-abs-chi", "analysis transfer functions", "cwlidar_sim/analysis/spectra.py",
      "cross_k = chi_k.real**2 / Fs_k**2", "cross_k = np.abs(chi_k) ** 2 / Fs_k**2",
      ("tests/analysis/test_analysis_spectra.py",),
      "method 2 with |chi|^2 instead of Re(chi)^2 (blind to timing)"),
    M("sigma-T2-sqrt2", "analysis transfer functions", "cwlidar_sim/analysis/spectra.py",
      "sig2_k = np.abs(chi_k.real) * np.sqrt(2.0 *", "sig2_k = np.abs(chi_k.real) * np.sqrt(4.0 *",
      ("tests/analysis/test_analysis_spectra.py::test_reported_sigmas_match_the_scatter_over_seeds",),
      "sigma_T2 sqrt(2) too large"),
    M("sigma-T1-half-var", "analysis transfer functions", "cwlidar_sim/analysis/spectra.py",
      "sig1_k = ratio_k * np.sqrt(2.0 *", "sig1_k = ratio_k * np.sqrt(1.0 *",
      ("tests/analysis/test_analysis_spectra.py::test_reported_sigmas_match_the_scatter_over_seeds",),
      "sigma_T1 sqrt(2) too small"),
    M("taylor-wavenumber", "analysis transfer functions", "cwlidar_sim/analysis/spectra.py",
      "    to_k = U / (2.0 * math.pi)\n    k_f = seg.f_f / to_k\n",
      "    to_k = U / math.pi\n    k_f = seg.f_f / to_k\n",
      ("tests/analysis/test_analysis_spectra.py",),
      "Taylor's k = 2 pi f / U with the 2 dropped"),
    M("theory-chi-double", "analysis theory", "cwlidar_sim/analysis/theory.py",
      "weights=pnn_m * np.exp(-zR * kn_m)", "weights=pnn_m * np.exp(-2.0 * zR * kn_m)",
      ("tests/analysis/test_analysis_theory.py",),
      "A2012 Eq. 14 with the power transfer in place of the amplitude transfer"),
    M("one-point-two-sided-at-boundary", "spectrum convention", "cwlidar_sim/turbulence/spectra.py",
      "tuple((2.0 * F[:, i]).reshape(shape)", "tuple((1.0 * F[:, i]).reshape(shape)",
      ("tests/analysis/test_spectrum_convention.py",),
      "one_point_spectra returns Mann's two-sided spectra, half the measured one-sided ones"),
    M("misaligned-two-sided-at-boundary", "spectrum convention", "cwlidar_sim/analysis/theory.py",
      "return 2.0 * F_vs_k.reshape(shape)", "return 1.0 * F_vs_k.reshape(shape)",
      ("tests/analysis/test_spectrum_convention.py",),
      "misaligned_spectra's F_vs two-sided, half the measured sonic spectrum"),
    M("fit-sampling-cov-half", "analysis fitting", "cwlidar_sim/analysis/fitting.py",
      "return C / n_k[:, None, None]", "return C / (2.0 * n_k[:, None, None])",
      ("tests/analysis/test_analysis_fitting.py::test_reported_std_matches_the_scatter_over_300_synthetic_records",),
      "chi-square covariance of the bin means halved (fit std / sqrt 2)"),
    # --- campaign runner ----------------------------------------------------------------------
    M("sonic-one-sample-late", "campaign runner", "cwlidar_sim/campaign/periods/staring.py",
      "    t32 = SONIC_DELAY + np.arange(n32) / 32.0\n", "    t32 = SONIC_DELAY + (np.arange(n32) + 1) / 32.0\n",
      ("tests/campaign/periods/test_campaign_physics.py::test_lidar_and_sonic_are_in_phase",),
      "sonic sampled one 32 Hz sample late"),
    M("transverse-no-misalignment", "campaign runner", "cwlidar_sim/campaign/periods/staring.py",
      "return math.sqrt(c.vv + c.ww + (period.mean_speed * math.sin(math.radians(period.misalignment_deg))) ** 2)",
      "return math.sqrt(c.vv + c.ww)",
      ("tests/campaign/periods/test_campaign_physics.py::test_speckle_transverse_speed_includes_the_mean_wind_across_the_beam",),
      "speckle transverse speed without the mean wind across a misaligned beam"),
    M("theory-ignores-fit", "campaign runner", "cwlidar_sim/campaign/periods/staring.py",
      'p = r["fit"].params if r["fit"] is not None and r["fit"].success else params', "p = params",
      ("tests/test_notebooks.py",),
      "misaligned theory with the scene's tensor instead of the fitted one"),
    # --- estimator theory (issue 13) ------------------------------------------------------------
    M("probe-length-grid-mislabelled", "estimator theory", "cwlidar_sim/analysis/estimator_theory.py",
      "instrument.focus**2 / (math.pi * z)))", "instrument.focus**2 / (math.pi * z * 1.2)))",
      ("tests/analysis/test_estimator_theory.py::test_probe_length_recovers_zR_and_a0_of_an_unseen_realisation",),
      "the probe-length fit's theory grid computed at zR / 1.2 of its label"),
    M("aerosol-correlation-halved", "estimator theory", "cwlidar_sim/signal/aerosol.py",
      "(1.0 + (k * ell) ** 2)", "(1.0 + (2 * k * ell) ** 2)",
      ("tests/signal/test_aerosol.py",),
      "backscatter modulation with half its correlation length"),
    M("line-broadening-dropped", "estimator theory", "cwlidar_sim/campaign/periods/staring.py",
      "    if scene.lidar.line_broadening == 0.0:\n", "    if True:\n",
      ("tests/campaign/test_estimator_theory_options.py",),
      "lidar.line_broadening never reaches the sub-cell spread"),
    # --- campaigns: resume, sweeps, conical results ---------------------------------------------
    M("store-ignores-scene-key", "campaign store", "cwlidar_sim/campaign/execution/store.py",
      '        return ds if ds.attrs.get("scene_key") == self.keys[index] else None\n', "        return ds\n",
      ("tests/campaign/execution/test_store.py::test_a_changed_scene_recomputes_its_periods",),
      "a stored period reused for a changed scene"),
    M("task-seed-by-position", "campaign sweeps", "cwlidar_sim/campaign/execution/sweep.py",
      '            seed = _task_seed(spec.seed, {"replica": r} if spec.paired else identity)\n',
      '            seed = _task_seed(spec.seed, {"position": len(tasks)})\n',
      ("tests/campaign/execution/test_batch.py::test_identity_not_position",),
      "a task's seed from its position in the sweep, not its identity"),
    M("cs-selection-ignored", "conical results", "cwlidar_sim/campaign/periods/conical.py",
      "                at = at.where(keep.astype(bool)) if \"scan_s\" in at.dims else at\n",
      "                at = at\n",
      ("tests/campaign/scenes/test_conical_scene.py::test_per_height_results_are_the_selected_periods_mean",),
      "per-height means taken over every period, not CS's selection"),
    M("scene-key-ignores-tensor", "campaign store", "cwlidar_sim/campaign/execution/store.py",
      "    tensor = None if params is None else [params.alpha_eps, params.length_scale, params.gamma]\n",
      "    tensor = None\n",
      ("tests/campaign/execution/test_batch_resume.py::test_new_contents_of_a_fit_to_record_recompute_its_tasks",),
      "a task fitted to a record whose contents changed behind the same path is reused"),
    M("task-index-ignores-key", "campaign batch", "cwlidar_sim/campaign/execution/batch.py",
      'return (e is not None and e.get("status") == "done" and key is not None and e.get("key") == key',
      'return (e is not None and e.get("status") == "done" and key is not None',
      ("tests/campaign/execution/test_batch_resume.py::test_a_change_recomputes_what_it_affects_and_only_that",),
      "a finished task reused after a [set] value, the tensor or the campaign seed changed"),
    M("task-units-not-kept", "campaign batch", "cwlidar_sim/campaign/execution/batch.py",
      "runs[t.task_id] = runner.prepare_scene(t.scene, units_dir[t.task_id], check=False)",
      "runs[t.task_id] = runner.prepare_scene(t.scene, None, check=False)",
      ("tests/campaign/execution/test_batch_resume.py::test_an_interrupted_task_keeps_its_finished_periods",),
      "an interrupted campaign task loses its finished periods"),
    M("conical-scan-turned-wrong-way", "conical period", "cwlidar_sim/campaign/periods/conical_simulation.py",
      'kw["azimuth0_deg"] = float(kw.get("azimuth0_deg", 0.0)) - wind_direction_deg',
      'kw["azimuth0_deg"] = float(kw.get("azimuth0_deg", 0.0)) + wind_direction_deg',
      ("tests/campaign/periods/test_conical_units.py::test_the_beam_turns_with_the_wind",),
      "the scan turned by +wind direction instead of -wind direction"),
    M("vad-direction-in-field-frame", "conical period", "cwlidar_sim/campaign/periods/conical_simulation.py",
      '"lidar_direction": _wrap180(st["mean_direction"] + wind_direction_deg),',
      '"lidar_direction": _wrap180(st["mean_direction"]),',
      ("tests/campaign/periods/test_conical_units.py::test_a_uniform_wind_from_every_side_gives_one_speed_and_its_direction",),
      "the VAD direction reported in the field's frame, not the lidar's"),
    M("conical-sensors-between-nodes", "conical period", "cwlidar_sim/campaign/periods/conical_simulation.py",
      "pos = nearest_node(field, (0.0, 0.0, z))",
      "pos = (0.0, 0.0, z)",
      ("tests/campaign/periods/test_conical_period.py::test_short_period_end_to_end",),
      "the cup and the sonic left between grid nodes (they read the nodes' average)"),
    M("twin-record-between-nodes", "conical twin", "cwlidar_sim/campaign/twin/conical.py",
      'p = nearest_node({"y": y_n, "z": z_n}, p)',
      "p = p",
      ("tests/campaign/twin/test_twin_conical.py::test_mast_positions_turn_with_the_wind_into_the_field_frame",),
      "the twin's records conditioned between grid nodes, where the period's sensors do not read"),
    M("misaligned-theory-without-shear-edges", "theory", "cwlidar_sim/analysis/theory.py",
      'q3_rj, w3_rj = _padded_rows([_onepoint_nodes(float(kk), L, params.gamma, math.inf, math.inf, tab, "fine")[1]',
      'q3_rj, w3_rj = _padded_rows([_onepoint_nodes(float(kk), L, 0.0, math.inf, math.inf, tab, "fine")[1]',
      ("tests/analysis/test_analysis_theory.py::test_aligned_and_cross_beams_at_gamma_0_and_8",),
      "the k3 nodes without the edges about the shear peak (Gamma = 0's nodes at every Gamma)"),
    M("quadrature-accumulator-sign", "tensor", "cwlidar_sim/turbulence/_kernels/tensor.py",
      "    acc[3] += w * a3\n",
      "    acc[3] -= w * a3\n",
      ("tests/turbulence/test_tensor.py::test_quadrature_accumulator_is_the_matrix_form",
       "tests/turbulence/test_spectra.py"),
      "the quadratures' register form of Phi13 with the wrong sign (the one-point F13 flips)"),
    M("cycle-sensors-at-one-height", "conical period", "cwlidar_sim/campaign/periods/conical_simulation.py",
      "pos = nearest_node(field, (0.0, 0.0, z))\n", "pos = nearest_node(field, (0.0, 0.0, heights[0]))\n",
      ("tests/campaign/periods/test_conical_units.py::test_cycling_lidar_gives_each_height_its_share_and_its_own_cup_and_sonic",),
      "a cycling lidar's cup and sonic all at the first height"),
    M("conical-unit-seeds-shared", "conical scene", "cwlidar_sim/campaign/scenes/conical.py",
      "            child = np.random.SeedSequence(self.seed, spawn_key=(index,))\n",
      "            child = np.random.SeedSequence(self.seed, spawn_key=(index // len(self.scan.heights),))\n",
      ("tests/campaign/periods/test_conical_units.py::test_conical_units_get_distinct_seeds_across_periods_and_heights",),
      "the heights of a period share one seed"),
    M("numba-threads-ignored", "configuration", "cwlidar_sim/_config.py",
      "    numba.set_num_threads(n)\n", "    numba.set_num_threads(1)\n",
      ("tests/test_threads.py",),
      "thread count never reaches numba"),
    # --- failure modes and the automatic choice (docs/stability.md, campaign/periods/staring_auto.py) -----------
    M("availability-counts-suspect", "failure modes", "cwlidar_sim/signal/processing.py",
      "ok = np.isfinite(self.speed_e) & ((self.flags_e & np.uint8(SUSPECT_FLAGS)) == 0)",
      "ok = np.isfinite(self.speed_e)",
      ("tests/signal/test_failure_modes.py",),
      "availability counts NEAR_ZERO / NEAR_NYQUIST estimates as usable"),
    M("near-zero-flag-lost", "failure modes", "cwlidar_sim/signal/_kernels/processing.py",
      "    if x < k_lo + guard_bins:", "    if x < k_lo - guard_bins:",
      ("tests/signal/test_failure_modes.py",),
      "estimates in the edge guard of the blind zone no longer flagged NEAR_ZERO"),
    M("near-zero-tail-unflagged", "failure modes", "cwlidar_sim/signal/_kernels/processing.py",
      "    if kp == k_lo:\n        flags |= F_NEAR_ZERO", "    if kp == -7:\n        flags |= F_NEAR_ZERO",
      ("tests/signal/test_failure_modes.py",),
      "a line inside the blind zone seen by its leakage tail reported unflagged (0.1 m/s reads 1.1 m/s)"),
    M("tier2-noise-looks", "failure modes", "cwlidar_sim/signal/chain.py",
      "_draw_rows(sig[lo - e0: hi - e0], noise, inst.blocks_per_estimate, gain",
      "_draw_rows(sig[lo - e0: hi - e0], noise, int(0.9 * inst.blocks_per_estimate), gain",
      ("tests/signal/test_failure_modes.py",),
      "tier-2 noise averaged over 10 % fewer blocks: false-alarm rate off the threshold's promise"),
    M("auto-dx-finest", "automatic choice", "cwlidar_sim/campaign/periods/staring_auto.py",
      "dx = max(ok) if ok else min(DX_LADDER)", "dx = min(ok) if ok else min(DX_LADDER)",
      ("tests/campaign/periods/test_auto.py",), "the finest field spacing chosen instead of the coarsest sufficient"),
    M("auto-ignores-processing", "automatic choice", "cwlidar_sim/campaign/periods/staring_auto.py",
      "keys = [k for k in lid.instrument if k in PROCESSING_KEYS]", "keys = []",
      ("tests/campaign/periods/test_auto.py",), "an estimator or threshold setting no longer asks for spectra"),
    M("conical-span-unconverged", "convergence", "cwlidar_sim/campaign/scenes/lidar_spec.py",
      "    preset: str = \"cs\"\n    span: float = 30.0\n",
      "    preset: str = \"cs\"\n    span: float = 5.0\n",
      ("tests/campaign/periods/test_convergence_defaults.py",),
      "the conical scenes' span back to 5 z_R (the std ratio 0.05-0.07 low at 40 m)"),
    M("conical-extent-origin-by-spacing", "convergence", "cwlidar_sim/turbulence/cover.py",
      "(region.x_lo - 0.5 * (ext3[0] - length + 4.0 * dx), region.y_mid - 0.5 * ext3[1],",
      "(region.x_lo - 0.5 * (ext3[0] - length + 4.0 * dx), region.y_mid - 0.5 * (ny - 1) * dy,",
      ("tests/sensors/test_conical.py::test_cover_box_of_one_extent_is_one_realisation_on_two_grids",),
      "boxes of one extent placed by their spacing: two grids no longer see the same air"),
    # --- conical results pinned by physics (issue 18) --------------------------------------------
    M("sonic-rv-w-unprojected", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "np.full(az.shape, math.cos(phi))", "np.full(az.shape, 1.0)",
      ("tests/analysis/test_vad_pins.py::test_sonic_radial_variance_projects_each_component",),
      "sonic-side radial variance takes w whole instead of cos(Phi) w"),
    M("vad-tp-divisor-n", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "dof = np.maximum(n_used - 3, 1)", "dof = np.maximum(n_used, 1)",
      ("tests/analysis/test_vad_pins.py::test_residual_variance_is_unbiased_for_white_noise_with_divisor_n_minus_3",),
      "radial variance (TP U)^2 divided by n instead of n - 3"),
    M("vad-selection-at-55", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "min_used_fraction: float = 0.65", "min_used_fraction: float = 0.55",
      ("tests/analysis/test_vad_pins.py::test_cs_selection_at_its_65_percent_boundary",),
      "CS's selection at 55 % of the points (a 60 % period kept)"),
    M("vad-selection-at-75", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "min_used_fraction: float = 0.65", "min_used_fraction: float = 0.75",
      ("tests/analysis/test_vad_pins.py::test_cs_selection_at_its_65_percent_boundary",),
      "CS's selection at 75 % of the points (a 70 % period dropped)"),
    M("vad-selection-fitted-scans-only", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "used = float(np.mean(fit.n_used_p / fit.n_points))", "used = float(np.mean(fit.n_used_p[ok] / fit.n_points))",
      ("tests/analysis/test_vad_pins.py::test_selection_counts_failed_scans_as_unused",),
      "points-used fraction over the fitted scans only (lost scans not counted)"),
    M("ambiguity-not-on-the-circle", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "dd = np.abs((d[ok] - t[ok] + 180.0) % 360.0 - 180.0)", "dd = np.abs(d[ok] - t[ok])",
      ("tests/analysis/test_vad_pins.py::test_ambiguity_rate_compares_directions_on_the_circle",),
      "ambiguity rate from plain differences (179 and -179 deg called opposite)"),
    M("vad-speed-over-cos", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "U = A / math.sin(phi) * nanf", "U = A / math.cos(phi) * nanf",
      ("tests/analysis/test_vad.py::test_uniform_flow_recovered_exactly_at_any_direction",),
      "horizontal speed A / cos Phi instead of A / sin Phi"),
    M("vad-w-over-sin", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "w_p=c / math.cos(phi) * nanf", "w_p=c / math.sin(phi) * nanf",
      ("tests/analysis/test_vad.py::test_uniform_flow_recovered_exactly_at_any_direction",),
      "vertical speed B / sin Phi instead of B / cos Phi"),
    M("vad-direction-mirrored", "conical VAD", "cwlidar_sim/analysis/vad.py",
      "dirn = np.degrees(np.arctan2(b, a))", "dirn = np.degrees(np.arctan2(-b, a))",
      ("tests/analysis/test_vad.py::test_uniform_flow_recovered_exactly_at_any_direction",),
      "wind direction mirrored (clockwise azimuths)"),
    M("probe-length-a0-sigma-not-halved", "estimator theory", "cwlidar_sim/analysis/estimator_theory.py",
      "return a0, 0.5 * a0 * zR_sigma / zR", "return a0, a0 * zR_sigma / zR",
      ("tests/analysis/test_vad_pins.py::test_probe_length_fit_propagates_its_uncertainty_as_a0_to_the_minus_half",),
      "probe-length fit's sigma_a0 as if a0 ~ 1 / zR (not zR^-1/2)"),
    M("cs-model-zr-at-height", "CS model", "cwlidar_sim/analysis/cs_model.py",
      "    r = z / math.cos(phi)\n", "    r = z\n",
      ("tests/analysis/test_cs_model_pins.py::test_default_probe_length_is_cs_coefficient_at_the_focus",),
      "the model's default z_R at the height, not at the focus z / cos Phi"),
    M("cs-model-probe-amplitude", "CS model", "cwlidar_sim/analysis/cs_model.py",
      "return np.exp(-2.0 * zr * np.abs(", "return np.exp(-zr * np.abs(",
      ("tests/analysis/test_cs_model_pins.py",),
      "probe filter exp(-zR k): the amplitude transfer in place of the power transfer"),
    M("cs-model-v-filter-sine", "CS model", "cwlidar_sim/analysis/cs_model.py",
      'Lv = scan_transfer(k, l_az, "rectified_cosine")', 'Lv = scan_transfer(k, l_az, "rectified_sine")',
      ("tests/analysis/test_cs_model_pins.py::test_model_integrals_and_ratios_against_independent_quadrature",),
      "cross-wind v filtered by the along-wind rectified sine"),
    M("cs-model-w-filter-cosine", "CS model", "cwlidar_sim/analysis/cs_model.py",
      'Lw = scan_transfer(k, l_az, "boxcar")', 'Lw = scan_transfer(k, l_az, "rectified_cosine")',
      ("tests/analysis/test_cs_model_pins.py::test_model_integrals_and_ratios_against_independent_quadrature",),
      "vertical w filtered by the rectified cosine instead of the box-car"),
    M("cs-boxcar-full-length", "CS model", "cwlidar_sim/analysis/cs_model.py",
      "return np.sinc(k * a / math.pi) ** 2", "return np.sinc(k * L / math.pi) ** 2",
      ("tests/analysis/test_cs_model_pins.py::test_each_scan_filter_against_quadrature_of_its_weighting",),
      "box-car scan filter twice as long as its weighting"),
    M("cs-model-w-projection-halved", "CS model", "cwlidar_sim/analysis/cs_model.py",
      'num = 0.5 * s2 * (m["hp_u"] + m["hp_v"]) + c2 * m["hp_w"]',
      'num = 0.5 * s2 * (m["hp_u"] + m["hp_v"]) + 0.5 * c2 * m["hp_w"]',
      ("tests/analysis/test_cs_model_pins.py::test_model_integrals_and_ratios_against_independent_quadrature",),
      "model radial variance with cos^2 Phi / 2 of w's high-pass part"),
    M("cs-scan-length-whole-revolutions", "CS model", "cwlidar_sim/analysis/cs_model.py",
      "return 2.0 * z * math.tan(phi) + U * T * (n - 0.5)", "return 2.0 * z * math.tan(phi) + U * T * n",
      ("tests/analysis/test_cs_model_pins.py::test_model_integrals_and_ratios_against_independent_quadrature",),
      "l_az = D + U T n instead of D + U T (n - 1/2) (CS Eq. 4)"),
    M("conical-focus-at-height", "conical lidar", "cwlidar_sim/sensors/conical.py",
      "return self.instrument.replace(focus=self.focus(height))", "return self.instrument.replace(focus=float(height))",
      ("tests/sensors/test_conical_pins.py::test_focus_and_probe_length_per_height_seen_through_a_range_varying_wind",),
      "the beam focused at the height z instead of z / cos Phi"),
    M("conical-speckle-fixed-focus", "conical lidar", "cwlidar_sim/sensors/conical.py",
      "return self.instrument_at(height).speckle_time(self.transverse_speed_at(height))",
      "return self.instrument.speckle_time(self.transverse_speed_at(height))",
      ("tests/sensors/test_conical_pins.py::test_speckle_time_and_looks_of_the_scan_in_closed_form",),
      "scan speckle time from the waist at the instrument's default focus, not the height's"),
    M("conical-spot-speed-cos", "conical lidar", "cwlidar_sim/sensors/conical.py",
      "return 2.0 * math.pi * self.focus(height) * math.sin(self._phi) / self.revolution_time",
      "return 2.0 * math.pi * self.focus(height) * math.cos(self._phi) / self.revolution_time",
      ("tests/sensors/test_conical_pins.py::test_speckle_time_and_looks_of_the_scan_in_closed_form",),
      "spot speed on a circle of radius r cos Phi (speckle looks wrong)"),
    M("cup-distance-constant-default", "cup", "cwlidar_sim/sensors/cup.py",
      "DISTANCE_CONSTANT = 2.3", "DISTANCE_CONSTANT = 1.5",
      ("tests/sensors/test_conical_pins.py::test_the_campaign_cup_has_its_documented_distance_constant",),
      "the campaign's cup with a 1.5 m distance constant instead of the documented 2.3 m"),
    M("cup-time-constant-halved", "cup", "cwlidar_sim/sensors/_cup_kernels.py",
      "    tau = l0 / mean_speed\n", "    tau = 0.5 * l0 / mean_speed\n",
      ("tests/sensors/test_conical_pins.py::test_cup_filters_the_spectrum_it_sees_by_its_first_order_response",),
      "cup time constant l0 / (2 U): it filters half as much of the spectrum"),
    M("surface-layer-kappa", "turbulence surface layer", "cwlidar_sim/turbulence/surface_layer.py",
      "ustar = 0.4 * U / math.log(z / z0)", "ustar = 0.41 * U / math.log(z / z0)",
      ("tests/turbulence/test_surface_layer.py::test_neutral_fit_is_mann_1994",),
      "neutral u* with von Karman's constant 0.41 where the fit uses 0.4"),
    M("surface-layer-alpha-eps", "turbulence surface layer", "cwlidar_sim/turbulence/surface_layer.py",
      "p = MannParameters(alpha_eps=3.2 * ustar**2 * z ** (-2.0 / 3.0), length_scale=0.59 * z, gamma=3.9)",
      "p = MannParameters(alpha_eps=3.0 * ustar**2 * z ** (-2.0 / 3.0), length_scale=0.59 * z, gamma=3.9)",
      ("tests/turbulence/test_surface_layer.py::test_neutral_fit_is_mann_1994",),
      "Mann's 1994 neutral fit with alpha eps^(2/3) = 3.0 u*^2 z^(-2/3) instead of 3.2"),
    # --- conditioned fields (the virtual twin's turbulence, turbulence/conditioning.py) ---------
    M("twin-no-noise-draw", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "d = d - rng.normal(0.0, math.sqrt(noise_var), n)", "d = d - 0.0 * rng.normal(0.0, math.sqrt(noise_var), n)",
      ("tests/turbulence/test_conditioning.py::test_twin_differs_from_the_record_by_the_measurement_noise",),
      "no fresh noise draw: the twin is forced towards the record through its own noise"),
    M("twin-taylor-reversed", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "coef[:m] = np.conj(a[:m]) * np.exp(-1j * k[:m] * x_ref)", "coef[:m] = a[:m] * np.exp(-1j * k[:m] * x_ref)",
      ("tests/turbulence/test_conditioning.py::test_taylor_convention_matches_the_package_sensors",),
      "records mapped to x = x_s + U t (the box moving along -x)"),
    M("twin-x-bandlimited-reading", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "H = (1.0 - t) + t * np.exp(1j * k * dx)", "H = np.exp(1j * k * t * dx)",
      ("tests/turbulence/test_conditioning.py::test_taylor_convention_matches_the_package_sensors",),
      "a sensor between nodes read as the band-limited interpolate, not sample_los's linear one"),
    M("twin-noise-not-in-solve", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "C[:, a, a] += ca.var", "C[:, a, a] += 0.0 * ca.var",
      ("tests/turbulence/test_conditioning.py::test_full_line_records_match_dense_conditioning",),
      "measurement noise left out of the per-k1 covariance"),
    M("twin-lateral-phase-unconjugated", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "wzz = (wz[:, None, :] * np.conj(wz[None, :, :]))", "wzz = (wz[:, None, :] * wz[None, :, :])",
      ("tests/turbulence/test_conditioning.py::test_zero_noise_twins_pass_exactly_through_the_records",),
      "cross-covariance between sensor heights with the wrong phase"),
    M("twin-cup-response-sign", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "H = 1.0 / (1.0 - 1j * k1 * r.distance_constant * U / Uc)",
      "H = 1.0 / (1.0 + 1j * k1 * r.distance_constant * U / Uc)",
      ("tests/turbulence/test_conditioning.py::test_cup_record_is_reproduced_through_its_own_response",),
      "cup lag mapped to x with the wrong sign (a lead instead of a lag)"),
    M("twin-cup-no-linearisation-noise", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_lines.py",
      "nv += var_v**2 / (2.0 * Uc * Uc)", "nv += 0.0 * var_v**2 / (2.0 * Uc * Uc)",
      ("tests/turbulence/test_conditioning.py::test_cup_record_is_reproduced_through_its_own_response",),
      "the cup's second-order term v^2 / 2U forced into u"),
    M("twin-phi-factor2", "conditioned fields", "cwlidar_sim/turbulence/_discrete.py",
      "pre2 = _prefactor(params) ** 2 * dk[0] * dk[1] * dk[2]", "pre2 = 2.0 * _prefactor(params) ** 2 * dk[0] * dk[1] * dk[2]",
      ("tests/turbulence/test_conditioning.py::test_discrete_box_spectra_match_the_generator_mode_by_mode",),
      "discrete box spectra twice the generator's"),
    M("twin-nyquist-direct", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_kernels.py",
      "own = 2 * j3 < N3", "own = True",
      ("tests/turbulence/test_conditioning.py::test_discrete_box_spectra_match_the_generator_mode_by_mode",),
      "modes with k3 < 0 given the tensor at their own wave vector, not their stored conjugate's"),
    M("twin-points-noise-dropped", "conditioned fields", "cwlidar_sim/turbulence/_conditioning_points.py",
      "alpha = _pinv_solve(K + np.diag(noise), resid)", "alpha = _pinv_solve(K, resid)",
      ("tests/turbulence/test_conditioning.py::test_scattered_points_match_dense_conditioning_mean_and_variance",),
      "scattered points: noise left out of the dense solve"),
    M("records-despike-blind", "measured records", "cwlidar_sim/analysis/records.py",
      "out = ok & (np.abs(dev) > spec.despike_threshold * 1.4826 * mad)",
      "out = ok & (np.abs(dev) > 10.0 * spec.despike_threshold * 1.4826 * mad)",
      ("tests/analysis/test_records.py::test_spikes_are_found_flagged_and_filled",), "despiking threshold ten times too high: spikes kept"),
    M("records-yaw-sign", "measured records", "cwlidar_sim/analysis/records.py",
      "v1 = -u * math.sin(yaw) + v * math.cos(yaw)", "v1 = u * math.sin(yaw) + v * math.cos(yaw)",
      ("tests/analysis/test_records.py::test_csv_sonic_in_its_own_axes_is_rotated_back_into_the_wind",),
      "double rotation: the lateral component rotated the wrong way"),
    M("records-long-gap-filled", "measured records", "cwlidar_sim/analysis/records.py",
      "        if m > max_run:", "        if m > 10 * max_run:",
      ("tests/analysis/test_records.py::test_gaps_short_filled_long_refused_naming_period_and_gap",), "gaps ten times max_gap filled silently"),
    M("records-planar-offset-ignored", "measured records", "cwlidar_sim/analysis/records.py",
      "vel = np.stack([u, v, w - b0])", "vel = np.stack([u, v, w])",
      ("tests/analysis/test_records.py::test_planar_fit_recovers_the_sonic_tilt_over_periods_of_several_directions",),
      "planar fit: the sonic's w offset b0 left in"),
    M("records-units-cm", "measured records", "cwlidar_sim/analysis/records.py",
      '"cm": 0.01,', '"cm": 0.1,', ("tests/analysis/test_records.py::test_netcdf_cf_names_and_units",), "cm s-1 read as dm s-1"),
    # --- the virtual twin of a staring scene (campaign/twin/run.py) ------------------------------------
    M("twin-scene-unconditioned", "virtual twin", "cwlidar_sim/campaign/twin/run.py",
      "        field = condition_field(field, twin_line_records(scene, tp, plan), seed=seed, U=tp.U, params=params,\n"
      "                                inplace=True)\n", "",
      ("tests/campaign/twin/test_twin.py::test_closed_loop_coherence_lidar_on_twin_vs_lidar_on_truth",),
      "the twin's field left unconditioned: the lidar flies through a statistical cousin"),
    M("twin-scene-record-at-telescope", "virtual twin", "cwlidar_sim/campaign/twin/run.py",
      "    focus = np.asarray(plan.lidar_position) + scene.lidar.build_instrument().focus * np.asarray(plan.direction)\n"
      "    out = []",
      "    focus = np.asarray(plan.lidar_position)\n    out = []",
      ("tests/campaign/twin/test_twin.py::test_closed_loop_coherence_lidar_on_twin_vs_lidar_on_truth",),
      "record positions taken from the telescope instead of the focus"),
    M("twin-scene-delay-sign", "virtual twin", "cwlidar_sim/campaign/twin/run.py",
      "        pos[0] -= tp.U * tp.delay", "        pos[0] += tp.U * tp.delay",
      ("tests/campaign/twin/test_twin.py::test_twin_reproduces_the_record_at_the_sonic_within_the_noise",),
      "the record's first-sample delay applied the wrong way (twin and record a sample apart)"),
    # --- evolving turbulence, REWS and preview ------------------------------------------------
    M("evolution-generated-age", "evolving turbulence", "cwlidar_sim/turbulence/evolution.py",
      "rho = np.exp(np.float32(-age / evolution.lifetime) * inv_f)",
      "rho = np.exp(np.float32(-1.3 * age / evolution.lifetime) * inv_f)",
      ("tests/turbulence/test_evolution.py",), "the generated planes decorrelate 30 % faster than the model"),
    M("evolution-innovation-weight", "evolving turbulence", "cwlidar_sim/turbulence/evolution.py",
      "comp = np.sqrt(np.maximum(np.float32(1.0) - rho * rho, np.float32(0.0)))", "comp = np.float32(1.0) - rho",
      ("tests/turbulence/test_evolution.py",), "the AR(1) innovation's weight: planes lose the box's spectra"),
    M("evolution-model-age", "evolving turbulence", "cwlidar_sim/turbulence/evolution.py",
      "return np.exp(-abs(dx) / (self.mean_speed * self.eddy_lifetime(k, params)))",
      "return np.exp(-abs(dx) / (1.3 * self.mean_speed * self.eddy_lifetime(k, params)))",
      ("tests/turbulence/test_evolution.py",), "the model's coherence ages eddies 30 % too slowly"),
    M("rews-beam-transfer-unconjugated", "REWS theory", "cwlidar_sim/analysis/rews_theory.py",
      "base.append(ph * np.conj(transfers[b](q)))", "base.append(ph * transfers[b](q))",
      ("tests/analysis/test_rews.py::test_box_discrete_theory_is_the_explicit_sum",),
      "the probe volume's transfer taken at -k.n: the weighting mirrored about the focus"),
    M("rews-scan-delay-sign", "REWS theory", "cwlidar_sim/analysis/rews_theory.py",
      "np.outer(base[b] * complex(_cis(kk * U * d_b[b])), coef_bc[b])",
      "np.outer(base[b] * complex(_cis(-kk * U * d_b[b])), coef_bc[b])",
      ("tests/analysis/test_rews.py::test_box_discrete_theory_is_the_explicit_sum",),
      "the scan's samples taken in the future instead of the past"),
    M("rews-evolution-dropped", "REWS theory", "cwlidar_sim/analysis/rews_theory.py",
      "r0 = 1.0 if rho is None else rho[abs(plane_x[p])]", "r0 = 1.0",
      ("tests/analysis/test_rews.py::test_evolving_point_limit_is_the_model_longitudinal_coherence",),
      "evolution left out of the rotor-lidar cross-spectrum"),
    M("rews-disc-diameter", "REWS", "cwlidar_sim/analysis/rews.py",
      "x = kap * self.radius", "x = 2.0 * kap * self.radius",
      ("tests/analysis/test_rews.py::test_rotor_disc_transfer_and_weights",),
      "the disc's transfer with the diameter for the radius"),
    M("rews-los-to-u", "REWS", "cwlidar_sim/analysis/rews_theory.py",
      "coef_bc = (lidar.weight_b / n_bc[:, 0])[:, None] * n_bc",
      "coef_bc = (lidar.weight_b * n_bc[:, 0])[:, None] * n_bc",
      ("tests/analysis/test_rews.py::test_box_discrete_theory_is_the_explicit_sum",),
      "line-of-sight speed multiplied by n_x instead of divided to estimate u"),
    M("rews-hann-ordinates-independent", "REWS", "cwlidar_sim/analysis/rews.py",
      "    n = effective_averages(count, ss.n_per, window) * ss.n_segments", "    n = count * ss.n_segments",
      ("tests/analysis/test_rews.py::test_hann_bins_count_their_correlated_ordinates",),
      "Fisher's interval counts a Hann bin's correlated ordinates as independent"),
    M("rews-estimate-keeps-the-mean", "REWS theory", "cwlidar_sim/analysis/rews_theory.py",
      "            kj -= mean_mode * d0\n", "",
      ("tests/analysis/test_rews.py::test_estimated_spectra_are_what_segment_averages_converge_to",),
      "the estimated spectra forget that each segment's mean is removed"),
    M("hawc2-openfast-y", "turbulence io", "cwlidar_sim/turbulence/io.py",
      "        return True, True", "        return True, False",
      ("tests/turbulence/test_io_openfast.py",), "OpenFAST's reversed y axis ignored"),
    # --- nacelle lidar ----------------------------------------------------------------------------
    M("nacelle-yaw-sign", "nacelle lidar", "cwlidar_sim/sensors/nacelle.py",
      "return rotation_matrices(0.0, 0.0, self.yaw_misalignment_deg)",
      "return rotation_matrices(0.0, 0.0, -self.yaw_misalignment_deg)",
      ("tests/sensors/test_nacelle.py",), "yaw misalignment turns the rotor the wrong way"),
    M("nacelle-motion-doppler-sign", "nacelle lidar", "cwlidar_sim/sensors/nacelle.py",
      "vlos_ls -= rel[:, None]", "vlos_ls += rel[:, None]",
      ("tests/sensors/test_nacelle.py::test_platform_motion_los_and_its_correction",),
      "the platform's own speed adds to the Doppler shift instead of subtracting"),
    M("nacelle-motion-correction-attitude", "nacelle lidar", "cwlidar_sim/sensors/nacelle.py",
      "known = att_lc if lidar.motion_correction else m_lc", "known = m_lc",
      ("tests/sensors/test_nacelle.py::test_platform_motion_los_and_its_correction",),
      "the motion correction forgets the attitude (roll, pitch, yaw)"),
    M("nacelle-blockage-half-chord", "nacelle lidar", "cwlidar_sim/sensors/nacelle.py",
      "< 0.5 * lidar.blade_chord)", "< lidar.blade_chord)",
      ("tests/sensors/test_nacelle.py::test_blade_blockage_flags_the_estimates_it_covers",),
      "blades twice as wide as their chord"),
    M("nacelle-sweep-offsets", "nacelle lidar", "cwlidar_sim/sensors/nacelle.py",
      "dang = 360.0 / self.estimates_per_rev if self.circle else 0.0",
      "dang = 0.0",
      ("tests/sensors/test_nacelle.py::test_uniform_wind_tier1_is_exact_yawed_or_not",),
      "the beam does not sweep within a dwell"),
    M("nacelle-theory-forgets-evolution", "nacelle scene", "cwlidar_sim/campaign/periods/nacelle.py",
      "ev = None if p.lifetime is None else EddyLifetimeEvolution(p.lifetime, p.mean_speed)", "ev = None",
      ("tests/test_notebooks.py::test_notebook_runs_in_quick_mode[nacelle.ipynb]",),
      "the analytic coherence of an evolving period is the frozen one"),
    M("nacelle-rews-psd-of-another-focus", "nacelle scene", "cwlidar_sim/campaign/periods/nacelle.py",
      "rpsd[i, at], ndof[at] = est.rotor_f, est.n_dof_f", "rpsd[:, at], ndof[at] = est.rotor_f, est.n_dof_f",
      ("tests/campaign/scenes/test_nacelle_scene.py",),
      "every focus reports the REWS spectrum of the last focus's preview-aligned segments"),
    M("nacelle-theory-rotor-radius", "nacelle scene", "cwlidar_sim/campaign/periods/nacelle.py",
      "RotorDisc(s.rotor_radius, s.rotor_exponent), beams, U, weighting=lid.weighting",
      "RotorDisc(0.7 * s.rotor_radius, s.rotor_exponent), beams, U, weighting=lid.weighting",
      ("tests/campaign/scenes/test_nacelle_scene.py::test_simulated_coherence_is_the_analytic_one_within_its_sampling_error",),
      "the analytic coherence for a smaller rotor than the simulated REWS's"),
    M("nacelle-tier1-motion-uncorrected", "nacelle scene", "cwlidar_sim/campaign/periods/nacelle.py",
      "        los = rec.vlos_e + corr", "        los = rec.vlos_e",
      ("tests/campaign/scenes/test_nacelle_scene.py::test_platform_motion_is_corrected_alike_in_every_estimate",),
      "the tier-1 estimate of a moving platform left uncorrected"),
]


def _copy_tree(dst):
    def ignore(d, names):
        skip = {".git", ".venv", "results", ".pytest_cache", "mutations.json"}
        return [n for n in names if n in skip or n.endswith(".nc")]

    # copy2 keeps the modification times, so numba's on-disk caches of the unmutated files stay valid
    shutil.copytree(ROOT, dst, ignore=ignore, copy_function=shutil.copy2, symlinks=True)


def _pytest(cwd, tests, timeout):
    env = dict(os.environ)
    env.setdefault("CWLIDAR_SIM_NUM_THREADS", "1")
    env.pop("PYTHONPATH", None)
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *tests]
    t0 = time.perf_counter()
    try:
        r = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
        out = r.stdout + r.stderr
        errs = [ln for ln in out.splitlines() if ln.startswith("E ")][:6]
        code, tail = r.returncode, "\n".join(errs) + "\n" + out[-1500:]
    except subprocess.TimeoutExpired:
        code, tail = -9, "timeout"
    return code, tail, time.perf_counter() - t0


def _check_imports_copy(cwd):
    r = subprocess.run([sys.executable, "-c", "import cwlidar_sim; print(cwlidar_sim.__file__)"], cwd=cwd,
                       capture_output=True, text=True)
    path = pathlib.Path(r.stdout.strip()).resolve()
    if not str(path).startswith(str(pathlib.Path(cwd).resolve())):
        raise SystemExit(f"the copy imports cwlidar_sim from {path}, not from {cwd}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="*", help="mutation ids to run (default: all)")
    ap.add_argument("--baseline", action="store_true", help="first run every selection unmutated (must pass)")
    ap.add_argument("--json", default=str(ROOT / "results" / "mutations.json"), help="where to write the results")
    ap.add_argument("--list", action="store_true", help="list the mutations and check their texts, run nothing")
    ap.add_argument("--timeout", type=float, default=900.0, help="per-mutation pytest timeout [s]")
    args = ap.parse_args(argv)
    muts = [m for m in MUTATIONS if not args.only or m.id in args.only]
    for m in muts:
        text = (ROOT / m.file).read_text(encoding="utf-8")
        n = text.count(m.old)
        if n != 1:
            raise SystemExit(f"{m.id}: the old text occurs {n} times in {m.file}; it must occur exactly once")
    if args.list:
        for m in muts:
            print(f"{m.id:32s} {m.stage:30s} {m.file}: {m.why}")
        return 0
    results = []
    with tempfile.TemporaryDirectory(prefix="cwlidar_mut_") as tmp:
        work = pathlib.Path(tmp) / "repo"
        _copy_tree(work)
        _check_imports_copy(work)
        if args.baseline:
            sel = sorted({t for m in muts for t in m.tests})
            code, tail, sec = _pytest(work, sel, args.timeout * 3)
            print(f"baseline: exit {code} in {sec:.0f} s")
            if code != 0:
                print(tail)
                raise SystemExit("baseline failed: the unmutated selections must pass")
        for m in muts:
            path = work / m.file
            original = path.read_bytes()
            stat = path.stat()
            path.write_text(original.decode("utf-8").replace(m.old, m.new), encoding="utf-8")
            try:
                code, tail, sec = _pytest(work, list(m.tests), args.timeout)
            finally:
                path.write_bytes(original)
                os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns))
            status = "yes" if code == 1 else ("NO" if code == 0 else f"error ({code})")
            failed = [ln.split()[1] for ln in tail.splitlines() if ln.startswith("FAILED ")]
            results.append({**dataclasses.asdict(m), "exit_code": code, "caught": code == 1, "status": status,
                            "failed_test": failed[0] if failed else None,
                            "seconds": round(sec, 1), "output_tail": tail if code != 1 else tail[:1500]})
            print(f"{m.id:32s} {status:10s} {sec:7.1f} s  {' '.join(m.tests)}"
                  + (f"\n{'':32s} failed: {failed[0]}" if failed else ""), flush=True)
    print()
    print("| mutation | stage | tests run | caught (first failing test) | s |\n|---|---|---|---|---|")
    for r in results:
        tests = ", ".join(t.replace("tests/", "") for t in r["tests"])
        first = f" ({r['failed_test'].split('::')[-1]})" if r["failed_test"] else ""
        print(f"| {r['id']}: {r['why']} | {r['stage']} | {tests} | {r['status']}{first} | {r['seconds']:.0f} |")
    pathlib.Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(args.json).write_text(json.dumps(results, indent=1), encoding="utf-8")
    n_caught = sum(r["caught"] for r in results)
    print(f"\n{n_caught} of {len(results)} mutations caught; results in {args.json}")
    return 0 if n_caught == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
