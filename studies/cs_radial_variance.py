"""Why the simulated radial-variance ratio (TP U)^2 / sonic lies above CS's model: a decomposition on one box.

Run from the repository root (minutes per height on one core):
    CWLIDAR_SIM_NUM_THREADS=1 python studies/cs_radial_variance.py [height ...] [--seed S] [--duration T]
        [--json PATH]

One box per height (the conical default: tier 'los', z/20 grid, laterally doubled, 10 m/s), and on it:

* numerator: the lidar's mean residual variance ``<(TP U)^2>`` with the package's divisor n - 3, and
  with n (CS Eq. 8's plain mean square);
* the same lidar in the *1-D* field made of the box's line through the scan's centre (u, v, w varying
  along x only, CS's frozen-line assumption): what is left once the cross-circle structure is gone;
* denominator: the sonic's projected period variance (the package's definition), the box's own
  projected variance (every point of the box), and the model's (the Mann tensor integrated over all k);
* the model's numerator and ratio (Mann, the lidar's z_R), also with k cut at the grid's Nyquist;
* the estimator noise of tier 'spectral' on the same field (60 s): the noise variance it adds.

Writes JSON (default results/cs_radial_variance.json).
"""

import argparse
import json
import math
import pathlib
import time

import numpy as np


def projected(var_u, var_v, var_w, phi):
    return 0.5 * math.sin(phi) ** 2 * (var_u + var_v) + math.cos(phi) ** 2 * var_w


def one_height(z, seed, duration, U=10.0):
    from cwlidar_sim.analysis import cs_model
    from cwlidar_sim.analysis.vad import fit_record, sonic_radial_variance
    from cwlidar_sim.campaign.scenes.conical import default_spacing
    from cwlidar_sim.sensors import Sonic, sample_sonic
    from cwlidar_sim.sensors.conical import ConicalLidar, measure_conical
    from cwlidar_sim.signal.processing import Flag
    from cwlidar_sim.turbulence.cover import cover_box
    from cwlidar_sim.turbulence.surface_layer import surface_layer_parameters

    t0 = time.perf_counter()
    d = default_spacing(z)
    params, _, _ = surface_layer_parameters(z, U)
    lid = ConicalLidar(heights=(z,), cell_length=d)
    phi = math.radians(lid.half_angle_deg)
    field = cover_box(lid.box_region(d), U, duration, params, 1000 + seed, spacing=d)
    rec = measure_conical(field, lid, duration, U)
    sel = rec.select(z)
    vel = sample_sonic(field, Sonic(position=(0.0, 0.0, z)), sel["time_e"], U)
    out = {"height": z, "seed": seed, "duration": duration, "spacing": d, "box_shape": list(field.u.shape),
           "rayleigh_length": lid.instrument_at(z).rayleigh_length}
    out["den_sonic"] = sonic_radial_variance(vel, sel["azimuth_e"], lid.half_angle_deg)
    out["den_box"] = projected(*(float(field[c].values.astype(np.float64).var()) for c in "uvw"), phi)
    # the 1-D field: the line through the scan's centre, broadcast over y and z
    iy = int(np.argmin(np.abs(field.y.values)))
    iz = int(np.argmin(np.abs(field.z.values - z)))
    line = field.copy(deep=True)
    for c in "uvw":
        line[c].values[:] = field[c].values[:, iy:iy + 1, iz:iz + 1]
    rec1 = measure_conical(line, lid, duration, U)
    sel1 = rec1.select(z)
    vel1 = sample_sonic(line, Sonic(position=(0.0, 0.0, z)), sel1["time_e"], U)
    out["den_sonic_1d"] = sonic_radial_variance(vel1, sel1["azimuth_e"], lid.half_angle_deg)
    for n in (1, 3):
        s = {}
        for tag, r in (("", rec), ("_1d", rec1)):
            f = fit_record(r, z, n, reference_deg=0.0)
            ok = np.isfinite(f.residual_var_p)
            s["num" + tag] = float(f.residual_var_p[ok].mean())
            s["num_divisor_n" + tag] = float(np.mean(f.residual_var_p[ok] * (f.n_used_p[ok] - 3) / f.n_used_p[ok]))
            s["points_used" + tag] = float(np.mean(f.n_used_p / f.n_points))
        s["point_sonic_scan"] = sonic_radial_variance(vel, sel["azimuth_e"], lid.half_angle_deg, scan=True,
                                                      revolution_e=sel["revolution_e"], n_rev=n)
        m = cs_model.model_integrals(z, U, n, spectrum="mann", params=params, rayleigh_length=out["rayleigh_length"],
                                     n_k=3000)
        s["num_model"] = projected(m["hp_u"], m["hp_v"], m["hp_w"], phi)
        s["den_model"] = projected(m["var_u"], m["var_v"], m["var_w"], phi)
        # the model of what the box can hold: k2, k3 cut at the grid's Nyquist pi / d
        mc = cs_model.model_integrals(z, U, n, spectrum="mann", params=params,
                                      rayleigh_length=out["rayleigh_length"], n_k=3000, k_max=math.pi / d,
                                      k_cut_lateral=math.pi / d)
        s["num_model_cut"] = projected(mc["hp_u"], mc["hp_v"], mc["hp_w"], phi)
        s["den_model_cut"] = projected(mc["var_u"], mc["var_v"], mc["var_w"], phi)
        s["ratio_sim"] = s["num"] / out["den_sonic"]
        s["ratio_model"] = s["num_model"] / s["den_model"]
        s["ratio_sim_1d"] = s["num_1d"] / out["den_sonic_1d"]
        out[f"scans_{n}"] = s
    # estimator noise of tier 2 on the same air (60 s)
    sp = lid.replace(tier="spectral")
    r2 = measure_conical(field, sp, 60.0, U, np.random.default_rng(seed))
    ok = np.isfinite(r2.speed_e) & ((r2.flags_e & (Flag.NO_SIGNAL | Flag.NEAR_ZERO)) == 0)
    err = r2.speed_e[ok] - np.abs(r2.vlos_e[ok])
    out["noise_var_spectral"] = float(np.var(err))
    out["wall_s"] = time.perf_counter() - t0
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("heights", nargs="*", type=float, default=[40.0, 60.0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--json", default="results/cs_radial_variance.json")
    a = ap.parse_args(argv)
    res = []
    for z in a.heights:
        res.append(one_height(z, a.seed, a.duration))
        print(json.dumps(res[-1]), flush=True)
        out = pathlib.Path(a.json)
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.with_suffix(".tmp")
        tmp.write_text(json.dumps(res, indent=1))
        tmp.replace(out)  # atomic: each finished height is kept


if __name__ == "__main__":
    main()
