"""The ``box`` command: generate a Mann box, write it as NetCDF, HAWC2, TurbSim (.bts) or Bladed (.wnd).

Kept apart from :mod:`cwlidar_sim.cli` for length.  Heavy modules are imported in the handler only.
Everything that can be checked before the box is generated is: the parameters, the format and the
options that apply to it, the targets (a directory, ``/dev/null``, a missing folder) and the disk.
"""

from __future__ import annotations

import os
import sys

from ._cli_help import _command, _json

__all__: list = []  # private to the CLI

FORMATS = ("netcdf", "hawc2", "turbsim", "bladed")
#: Format chosen by --out's extension when --format is not given (HAWC2 is never guessed: say --format hawc2).
_BY_EXTENSION = {".nc": "netcdf", ".nc4": "netcdf", ".netcdf": "netcdf", ".bts": "turbsim", ".wnd": "bladed"}
_EXTENSION = {"netcdf": ".nc", "turbsim": ".bts", "bladed": ".wnd"}
_NAME = {"netcdf": "NetCDF", "hawc2": "HAWC2", "turbsim": "TurbSim", "bladed": "Bladed"}


def _add_box(sub):
    p = _command(
        sub, "box", "generate a Mann turbulence box (.nc, HAWC2, .bts, .wnd)",
        "Generate a periodic Mann (1998) turbulence box and write it to NetCDF, HAWC2 binary (with a JSON "
        "sidecar of shape, spacing and parameters and an HTC snippet), a TurbSim .bts file or a Bladed-style "
        ".wnd file with its .sum (TurbSim's variant, as OpenFAST InflowWind reads them). The format follows "
        "--out's extension (.nc, .bts, .wnd) unless --format says it; HAWC2 needs --format hawc2.",
        ["cwlidar-sim box --alpha-eps 1 --length-scale 33.6 --gamma 3.9 --shape 4096 32 32 \\",
         "    --spacing 2 2 2 --seed 1 --out box.nc --stats --plot box_spectra.png",
         "cwlidar-sim box --alpha-eps 1 --length-scale 33.6 --gamma 3.9 --shape 8192 32 32 \\",
         "    --spacing 1 2 2 --seed 7 --format hawc2 --out turb     # turb_u.bin ... turb.json, turb.htc",
         "cwlidar-sim box --alpha-eps 1 --length-scale 33.6 --gamma 3.9 --shape 8192 32 32 \\",
         "    --spacing 1 2 2 --seed 7 --format hawc2 --convention openfast --out of   # for InflowWind",
         "cwlidar-sim box --alpha-eps 1 --length-scale 33.6 --gamma 3.9 --shape 8192 32 32 \\",
         "    --spacing 1 2 2 --seed 7 --out turb.bts --mean-speed 10 --hub-height 90"],
    )
    p.add_argument("--alpha-eps", type=float, required=True, help="alpha*epsilon^(2/3) [m^(4/3) s^-2]")
    p.add_argument("--length-scale", type=float, required=True, help="length scale L [m]")
    p.add_argument("--gamma", type=float, required=True, help="anisotropy Gamma [-]")
    p.add_argument("--shape", type=int, nargs=3, required=True, metavar=("NX", "NY", "NZ"))
    p.add_argument("--spacing", type=float, nargs=3, required=True, metavar=("DX", "DY", "DZ"), help="[m]")
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--out", required=True,
                   help="output file (.nc, .bts, .wnd) or HAWC2 basename (writes BASE_u.bin ... BASE.json, BASE.htc)")
    p.add_argument("--format", choices=FORMATS, default=None,
                   help="default: from --out's extension (.nc NetCDF, .bts TurbSim, .wnd Bladed)")
    p.add_argument("--convention", choices=("hawc2", "openfast"), default=None,
                   help="HAWC2 only: the generators' layout (default) or the one OpenFAST InflowWind reads")
    p.add_argument("--reverse-x", action="store_true",
                   help="HAWC2 only: x planes in arrival order (for HAWC2 before 13.1)")
    p.add_argument("--mean-speed", type=float, default=None, metavar="U",
                   help="TurbSim, Bladed (needed): mean wind speed [m/s], added to u; dt = dx / U")
    p.add_argument("--hub-height", type=float, default=None, metavar="H",
                   help="TurbSim, Bladed: hub height [m], the grid centred on it (default: the grid's bottom at 0)")
    p.add_argument("--correction", choices=("cell", "none"), default="cell",
                   help="finite-box correction of the lowest wavenumbers (default: cell)")
    p.add_argument("--hf-compensation", action="store_true",
                   help="rescale each k1 so one-point spectra match the full analytic ones")
    p.add_argument("--sigma-u", type=float, default=None, help="rescale the box to this sample sigma_u [m/s]")
    p.add_argument("--dtype", choices=("float32", "float64"), default="float32")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    p.add_argument("--keep-mean", action="store_true", help="keep the k = 0 mode (a fluctuating box mean)")
    p.add_argument("--stats", action="store_true", help="print box statistics against theory as JSON")
    p.add_argument("--plot", default=None, metavar="PNG", help="plot one-point spectra against the tensor")
    p.set_defaults(func=_cmd_box)


def _box_format(args) -> str:
    """The format, from --format or --out's extension, and the options checked against it (one-line errors)."""
    stem, ext = os.path.splitext(args.out)
    ext = ext.lower()
    fmt = args.format or _BY_EXTENSION.get(ext)
    if fmt is None or (fmt in _EXTENSION and _BY_EXTENSION.get(ext) != fmt):
        if fmt in (None, "netcdf"):
            raise ValueError(f"--out {args.out!r}: a NetCDF box is written to a .nc file (e.g. {stem}.nc), a TurbSim "
                             f"box to .bts, a Bladed box to .wnd; for HAWC2's three .bin files add --format hawc2")
        raise ValueError(f"--out {args.out!r}: a {_NAME[fmt]} box is written to a {_EXTENSION[fmt]} file "
                         f"(e.g. {stem}{_EXTENSION[fmt]})")
    if fmt == "hawc2" and ext in _BY_EXTENSION:
        raise ValueError(f"--out {args.out!r} with --format hawc2: HAWC2 writes BASE_u.bin, BASE_v.bin, BASE_w.bin, "
                         f"BASE.json, BASE.htc; give a base name such as {stem!r}")
    for option, given in (("--convention", args.convention is not None), ("--reverse-x", args.reverse_x)):
        if given and fmt != "hawc2":
            raise ValueError(f"{option} applies to HAWC2 boxes only (--format hawc2); a {_NAME[fmt]} file has "
                             f"one layout")
    if args.convention == "openfast" and args.reverse_x:
        raise ValueError("--reverse-x with --convention openfast: the openfast layout already puts the x planes in "
                         "arrival order; give one of them")
    for option, value in (("--mean-speed", args.mean_speed), ("--hub-height", args.hub_height)):
        if value is not None and fmt in ("netcdf", "hawc2"):
            raise ValueError(f"{option} applies to --format turbsim and bladed only (files that hold the whole "
                             f"wind at a height); a {_NAME[fmt]} box holds the fluctuations")
    if fmt in ("turbsim", "bladed") and args.mean_speed is None:
        raise ValueError(f"a {_NAME[fmt]} file holds the whole wind (u = U + fluctuation, dx = U dt): "
                         f"give --mean-speed U [m/s]")
    return fmt


def _targets(args, fmt) -> list:
    from .turbulence import hawc2_paths, hawc2_sidecar_paths

    if fmt == "hawc2":
        return [(f"--out (component {c})", str(p)) for c, p in zip("uvw", hawc2_paths(args.out))] + \
            [(f"--out ({what})", str(p)) for what, p in zip(("sidecar", "HTC snippet"), hawc2_sidecar_paths(args.out))]
    if fmt == "bladed":
        return [("--out", args.out), ("--out (summary)", os.path.splitext(args.out)[0] + ".sum")]
    return [("--out", args.out)]


def _cmd_box(args) -> int:
    from . import _config
    from ._atomic import check_output_file
    from ._preflight import preflight
    from ._validation import check_real
    from .turbulence import MannParameters, generate_box, write_bladed, write_hawc2, write_netcdf, write_turbsim
    from .turbulence.stats import box_report, plot_box_spectra

    if args.threads is not None:
        _config.set_num_threads(args.threads)
    params = MannParameters(args.alpha_eps, args.length_scale, args.gamma)
    # the targets first (a directory, /dev/null: named as such), then the name and options against the format
    fmt = args.format or _BY_EXTENSION.get(os.path.splitext(args.out)[1].lower(), "netcdf")
    # before generating: the box's folder is writable, NetCDF imports, the disk holds 3 components
    itemsize = {"netcdf": 4 if args.dtype == "float32" else 8, "hawc2": 4}.get(fmt, 2)
    need = 3 * itemsize * args.shape[0] * args.shape[1] * args.shape[2]
    preflight(os.path.dirname(os.path.abspath(args.out)), need, engine=fmt == "netcdf")
    # ... and every target can receive a file (not a directory, /dev/null, a FIFO)
    targets = _targets(args, fmt)
    if args.plot:
        preflight(os.path.dirname(os.path.abspath(args.plot)), 0.0, engine=False)
        targets.append(("--plot", args.plot))
    for label, target in targets:
        check_output_file(target, label=label)
    fmt = _box_format(args)
    if fmt in ("turbsim", "bladed"):
        check_real("--mean-speed", args.mean_speed, lo=0.0, lo_open=True, hi=1e3)
        half = (args.shape[2] - 1) * args.spacing[2] / 2
        if args.hub_height is not None and check_real("--hub-height", args.hub_height, lo=half, hi=1e5) <= 0:
            raise ValueError(f"--hub-height={args.hub_height!r}; allowed: > 0 m")
    box = generate_box(
        params, tuple(args.shape), tuple(args.spacing), args.seed,
        correction=args.correction, hf_compensation=args.hf_compensation,
        keep_mean=args.keep_mean, sigma_u=args.sigma_u, dtype=args.dtype,
        progress=not args.no_progress and args.shape[0] * args.shape[1] * args.shape[2] >= 1 << 22,
    )
    if fmt == "netcdf":
        write_netcdf(box, args.out)
    elif fmt == "hawc2":
        write_hawc2(box, args.out, convention=args.convention or "hawc2", reverse_x=args.reverse_x)
    else:
        writer = write_turbsim if fmt == "turbsim" else write_bladed
        writer(box, args.out, mean_speed=args.mean_speed, hub_height=args.hub_height)
    written = [target for label, target in targets if label != "--plot"]
    print(f"wrote a {'x'.join(map(str, args.shape))} box ({fmt}): {', '.join(written)}", file=sys.stderr)
    if args.stats:
        print(_json(box_report(box)))
    if args.plot:
        plot_box_spectra(box, args.plot)
    return 0
