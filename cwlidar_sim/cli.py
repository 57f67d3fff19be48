"""Command-line interface: ``cwlidar-sim SUBCOMMAND ...``.

Kept thin on purpose: it parses arguments and calls the public API.  Heavy
modules (numba kernels, pyfftw, xarray) are imported inside the subcommand
handlers so that ``cwlidar-sim --help`` starts without compiling anything.

Exit status: 0 done; 1 a write failed part-way (the file being replaced is unchanged) or a campaign
task failed; 2 bad input or a check before compute (one line); 130 Ctrl-C; 143 SIGTERM (one line).
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from ._version import __version__
from ._cli_box import _add_box
from ._cli_help import _DASK_TRUST, _add_dask_options, _command, _Formatter, _json
from ._bundled import bundled_files as _bundled_files, bundled_or_path as _bundled_or_path
from ._interrupt import EXIT_SIGTERM, RESUMABLE, Terminated, sigterm_raises, terminated_message


def _add_doppler(sub):
    p = _command(
        sub, "doppler", "Doppler estimates of a uniform target, any tier",
        "Simulate N speed estimates of a target moving uniformly at V m/s along the beam "
        "through one tier (los: the ideal weighted line-of-sight average, returns V exactly; "
        "spectral: expected spectrum times speckle statistics; signal: the 50 MHz heterodyne "
        "signal, block FFTs and averaging), with an instrument preset (overridable), and "
        "print mean, std, availability and quality-flag counts.",
        ["cwlidar-sim doppler --speed 5 --cnr -20 --tier spectral --estimator median --n 500 --seed 1 --json",
         "cwlidar-sim doppler --speed 5 --cnr -25 --tier signal --estimator centroid --threshold-raise 10 --n 50",
         "cwlidar-sim doppler --speed 8 --cnr -10 --preset cs --set window=hann --cloud 1600 6e5 12"],
    )
    p.add_argument("--speed", type=float, required=True, help="radial speed V [m/s] (positive away from the lidar)")
    p.add_argument("--cnr", type=float, required=True,
                   help="carrier-to-noise ratio [dB]: signal power over noise power in 0..fs/2")
    p.add_argument("--tier", choices=("los", "spectral", "signal"), default="spectral")
    p.add_argument("--estimator", default=None, help="median, centroid, peak, peak_parabolic, peak_gaussian, ml "
                                                     "(default: the preset's)")
    p.add_argument("--threshold", type=float, default=None,
                   help="threshold factor (sigma: multiple of the floor's std; snr: per-bin SNR, linear; "
                        "peak_fraction: fraction of the peak)")
    p.add_argument("--threshold-kind", choices=("sigma", "snr", "peak_fraction"), default=None)
    p.add_argument("--threshold-raise", type=float, default=None, metavar="PERCENT",
                   help="raise the raw threshold by this percentage (A2012's 5/10/20 %% experiment)")
    p.add_argument("--preset", choices=("prototype", "cs"), default="prototype")
    p.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                   help="override an instrument field, e.g. --set blocks_per_estimate=500 (repeatable)")
    p.add_argument("--n", type=int, default=100, help="number of estimates")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--transverse-speed", type=float, default=1.0,
                   help="aerosol speed across the beam [m/s]; sets the speckle correlation time w0/v")
    p.add_argument("--cells", type=int, default=8, help="range cells of the probe volume")
    p.add_argument("--speckle", choices=("coherent", "independent"), default="coherent")
    p.add_argument("--exact-background", action="store_true", help="use the exact noise floor")
    p.add_argument("--cloud", type=float, nargs=3, default=None, metavar=("RANGE", "WEIGHT", "SPEED"),
                   help="a cloud return: distance along the beam [m], integrated backscatter relative to the "
                        "aerosol's per metre [m], radial speed [m/s]")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--json", action="store_true", help="print the full report as JSON")
    p.set_defaults(func=_cmd_doppler)


def _cmd_doppler(args) -> int:
    import dataclasses

    from . import _config
    from ._validation import did_you_mean
    from .signal import Instrument, preset, simulate_uniform, uniform_report

    if args.threads is not None:
        _config.set_num_threads(args.threads)
    inst = preset(args.preset)
    changes = {}
    types = {f.name: f.type for f in dataclasses.fields(Instrument)}
    for item in args.set:
        key, sep, val = item.partition("=")
        if not sep:
            raise ValueError(f"--set {item!r} must look like FIELD=VALUE")
        if key not in types:
            raise ValueError(f"--set {key}: unknown instrument field{did_you_mean([key], types)}; allowed: {sorted(types)}")
        t = types[key]
        try:
            changes[key] = int(val) if t in (int, "int") else float(val) if t in (float, "float") else val
        except ValueError:
            raise ValueError(f"--set {key}={val!r}: {key} takes {'an integer' if t in (int, 'int') else 'a number'}"
                             ) from None
    if args.threshold is not None:
        changes["threshold_value"] = args.threshold
    if args.threshold_kind is not None:
        changes["threshold_kind"] = args.threshold_kind
    if args.threshold_raise is not None:
        changes["threshold_raise_percent"] = args.threshold_raise
    if args.estimator is not None:
        changes["estimator"] = args.estimator
    inst = Instrument.from_dict(changes, base=inst)
    est, info = simulate_uniform(args.speed, args.cnr, instrument=inst, tier=args.tier, n=args.n, seed=args.seed,
                                 transverse_speed=args.transverse_speed, n_cells=args.cells, speckle=args.speckle,
                                 exact_background=args.exact_background,
                                 **({} if args.cloud is None else dict(zip(("cloud_range", "cloud_weight", "cloud_speed"),
                                                                           args.cloud))))
    rep = uniform_report(est, info, speed=args.speed, cnr_db=args.cnr, tier=args.tier, instrument=inst)
    if args.json:
        print(_json(rep))
    else:
        mean = "nan" if rep["mean"] is None else f"{rep['mean']:.4f}"
        std = "nan" if rep["std"] is None else f"{rep['std']:.4f}"
        sign = "signed, + away from the lidar" if args.tier == "los" else "|V|, homodyne"
        print(f"{args.tier} {rep['estimator']}: mean {mean} m/s ({sign}), std {std} m/s, "
              f"availability {rep['availability']:.3f} (usable: finite, not NEAR_ZERO/NEAR_NYQUIST; "
              f"finite {rep['valid_fraction']:.3f}), flags {rep['flags']}")
        for what in ("note", "warning"):
            if rep.get(what):
                print(f"{what}: {rep[what]}")
    return 0


def _add_campaign(sub):
    p = _command(sub, "run", "run a scene file (TOML) and write its results",
                 "Run every period of a scene file and write DIR/<name>.nc. SCENE is a file, or the name of a "
                 "bundled scene ('cwlidar-sim scenes' lists them). Re-running into the same folder computes only "
                 "the periods that are missing or whose settings changed (and removes the files the changed "
                 "scene no longer uses).\n\nA results folder belongs to one scene (DIR/cwlidar-run.json): "
                 "another scene's (or a campaign's) results there are refused unless --overwrite, which removes "
                 "every file of the old run (its results file only once the new one is written). One run at a "
                 "time: a second run into a folder in use is refused, naming the first one's pid." + "\n\n" + _DASK_TRUST,
                 ["cwlidar-sim scenes --write a2012 my_scene.toml     # a commented starting point",
                  "cwlidar-sim run my_scene.toml --out results/mine --figures",
                  "cwlidar-sim run my_scene.toml --out results/mine --dask tcp://scheduler:8786"])
    p.add_argument("scene", help="scene file (TOML), or a bundled scene's name")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    _add_dask_options(p, "dask", "the periods")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--figures", action="store_true", help="also write the figures (as 'report' does)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace another scene's results in DIR (removing every file of that run); for the "
                        "same scene: compute every period again")
    p.set_defaults(func=_cmd_run)

    p = _command(sub, "report", "write the figures of a results folder",
                 "Read DIR/*.nc written by 'run' or 'reproduce' and write the figures as PNG.",
                 ["cwlidar-sim report results/mine", "cwlidar-sim report results --out figures"])
    p.add_argument("dir", metavar="DIR")
    p.add_argument("--out", default=None, metavar="FIGDIR", help="figure folder (default DIR)")
    p.set_defaults(func=_cmd_report)

    p = _command(sub, "reproduce", "reproduce a bundled study and draw its figures",
                 "Run a bundled scene and write its results and figures. a2012: Angelou et al. "
                 "(2012), the spectral transfer function of a staring cw lidar, four 1-h periods. "
                 "cs: a conically scanning ZephIR against a cup, 40-100 m, 1 s and 3 s scans, "
                 "18-48 10-min periods per height (each std ratio to a standard error of 0.01). nacelle: a nacelle lidar's REWS preview coherence at "
                 "three focus distances, frozen and evolving turbulence, against the analytic coherence. spinner: a SpinnerLidar's "
                 "REWS, shear, veer and yaw per rosette (Mikkelsen et al. 2013). windscanner: three beams meeting at 125 m "
                 "against a sonic (Mikkelsen et al. 2012's layout)."
                 "\n\n" + _DASK_TRUST,
                 ["cwlidar-sim reproduce a2012 --out results            # under a minute on 2 cores",
                  "cwlidar-sim reproduce cs --quick --out results       # two periods per height",
                  "cwlidar-sim reproduce nacelle --quick --out results  # 5-min periods, under a minute",
                  "cwlidar-sim reproduce spinner --quick --out results  # 20-s periods"])
    p.add_argument("paper", choices=("a2012", "cs", "nacelle", "spinner", "windscanner"))
    p.add_argument("--quick", action="store_true",
                   help="each under a minute on 2 cores: a2012: 20-min periods; cs: two periods per height; "
                        "nacelle: 5-min periods; spinner: 20-s periods; windscanner: 30-s periods, 10-s segments")
    p.add_argument("--out", default="results", metavar="DIR", help="output folder (default: results)")
    _add_dask_options(p, "dask", "the periods")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--overwrite", action="store_true", help="replace another scene's results in DIR (see 'run')")
    p.set_defaults(func=_cmd_reproduce)


def _worker_timeout(args) -> float:
    """``--worker-timeout`` checked (a one-line error out of range), or the default."""
    from ._dask import DEFAULT_WORKER_TIMEOUT, check_worker_timeout

    value = getattr(args, "worker_timeout", None)
    return DEFAULT_WORKER_TIMEOUT if value is None else check_worker_timeout(value)


def _client(address, worker_timeout=None):
    """A Dask client for ``address`` with a worker (an unreachable or empty scheduler: a one-line error)."""
    if address is None:
        return None
    from ._dask import DEFAULT_WORKER_TIMEOUT, connect_scheduler

    return connect_scheduler(address, worker_timeout=worker_timeout or DEFAULT_WORKER_TIMEOUT)


def _run_and_report(scene, args, figures):
    import os

    from . import _config
    from .campaign import run_scene
    from .campaign.execution import folder
    from .campaign.registry import kind_of
    from .campaign.execution.store import preflight

    if args.threads is not None:
        _config.set_num_threads(args.threads)

    def log(line):
        print(line, file=sys.stderr)

    # every check before the first period: names, folder, engine, disk, scheduler (reachable, with a worker)
    timeout = _worker_timeout(args)
    folder.check_file_names(scene)
    kind = kind_of(scene)
    preflight(args.out, kind.estimate_bytes(scene), scheduler=args.dask)
    with folder.locked(args.out):  # held across the run and its figures
        client = _client(args.dask, timeout)
        try:
            ds = run_scene(scene, args.out, client=client, progress=not args.no_progress, log=log,
                           overwrite=args.overwrite, worker_timeout=timeout)
        except KeyboardInterrupt:
            print(f"cwlidar-sim {args.command}: interrupted; the finished periods are kept in "
                  f"{os.path.join(args.out, scene.name + '.periods')}; run the same command again to resume",
                  file=sys.stderr)
            return 130
        finally:
            if client is not None:
                client.close()
        figs = kind.figures(ds, args.out) if figures else None
        if figs:
            folder.record_figures(args.out, figs)
    summary = {
        "results": os.path.join(args.out, f"{scene.name}.nc"),
        "wall_time_s": round(ds.attrs["wall_time"], 2),
        "periods_reused": json.loads(ds.attrs["periods_reused"]),
    }
    summary.update(kind.summary(scene, ds))
    if figures:
        summary["figures"] = figs
    print(_json(summary))
    return 0


def _cmd_run(args) -> int:
    from .campaign import load_scene

    return _run_and_report(load_scene(_bundled_or_path(args.scene, "scene")), args, args.figures)


def _cmd_report(args) -> int:
    import glob
    import os

    from ._preflight import check_writable
    from .campaign.figures.staring import make_figures
    from .campaign.execution.results_file import lacking, open_results

    if not os.path.isdir(args.dir):
        raise ValueError(f"{args.dir!r} is not a folder; 'report' reads the results (*.nc) of a folder")
    files = sorted(glob.glob(os.path.join(args.dir, "*.nc")))
    if not files:
        raise ValueError(f"no results (*.nc) in {args.dir!r}; run 'cwlidar-sim run' or 'reproduce' first")
    check_writable(args.out or args.dir)  # before any file is read: the figures' folder takes files
    # every file checked (type, signature, attributes) before the first figure is drawn
    datasets = [open_results(f) for f in files]
    out = []
    for f, ds in zip(files, datasets):
        sub = args.out or args.dir
        if len(files) > 1:
            sub = os.path.join(sub, os.path.splitext(os.path.basename(f))[0])
        try:
            out.extend(make_figures(ds, sub))
        except (KeyError, AttributeError) as e:  # a variable or attribute missing from an older or edited file
            raise lacking(f, ds, e, "the figures") from None
    print(_json({"figures": out}))
    return 0


def _cmd_reproduce(args) -> int:
    from .campaign import bundled_scene

    return _run_and_report(bundled_scene(args.paper, quick=args.quick), args, True)


def _add_sweep(sub):
    p = _command(sub, "campaign", "run a sweep over a scene (TOML), on Dask",
                 "Expand a campaign file into tasks (sweep points x replicas) and run them on a "
                 "local Dask cluster sized to the machine, or on --scheduler. Each finished task is "
                 "written at once; re-running resumes (done tasks skipped, failed ones retried). CAMPAIGN is a "
                 "file, or the name of a bundled example ('cwlidar-sim scenes' lists them).\n\n" + _DASK_TRUST,
                 ["cwlidar-sim campaign campaign_quick --dry-run          # tasks, estimated time and memory",
                  "cwlidar-sim campaign campaign_quick --out results/cq",
                  "cwlidar-sim campaign my_sweep.toml --out DIR --scheduler tcp://host:8786"])
    p.add_argument("campaign", help="campaign file (TOML), or a bundled example's name")
    p.add_argument("--out", default=None, metavar="DIR", help="campaign folder (required unless --dry-run)")
    p.add_argument("--dry-run", action="store_true", help="list the tasks with estimated time and memory; run nothing")
    p.add_argument("--workers", type=int, default=None, help="local cluster workers (default: sized to the machine)")
    _add_dask_options(p, "scheduler", "the tasks")
    p.add_argument("--local", action="store_true", help="run the tasks in this process, one after the other")
    p.add_argument("--memory-limit", type=float, default=None, metavar="GB", help="memory per worker [GB]")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="--dry-run: print the tasks as JSON")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a scene's or another campaign's results in DIR; for the same campaign: "
                        "compute every task again")
    p.set_defaults(func=_cmd_campaign)

    p = _command(sub, "campaign-report", "merge a campaign's tasks, draw the sweep figures",
                 "Merge DIR/tasks/*.nc into DIR/campaign.nc (sweep dimensions as coordinates) and "
                 "write DIR/figures/sweep_*.png.",
                 ["cwlidar-sim campaign-report results/cq"])
    p.add_argument("dir", metavar="DIR")
    p.add_argument("--keep-series", action="store_true", help="keep the raw time series in campaign.nc")
    p.set_defaults(func=_cmd_campaign_report)


def _cmd_campaign(args) -> int:
    import os

    from ._dask import WorkersLostError
    from ._preflight import PreflightError, check_scheduler
    from .campaign.execution.batch import dry_run, plan_cluster, run_campaign
    from .campaign.execution.sweep import load_campaign

    spec = load_campaign(_bundled_or_path(args.campaign, "campaign"))
    if args.memory_limit is not None and not args.memory_limit > 0:
        raise ValueError(f"--memory-limit {args.memory_limit} GB must be > 0")
    if args.dry_run:
        rows = dry_run(spec)
        plan = plan_cluster(len(rows), max(r["est_memory_gb"] for r in rows) * 1e9, args.workers)
        total = sum(r["est_seconds"] for r in rows)
        if args.json:
            print(_json({"tasks": rows, "cluster": plan, "est_seconds_total": total}))
            return 0
        print(f"{'task_id':16}  {'est s':>7}  {'mem GB':>6}  label")
        for r in rows:
            print(f"{r['task_id']:16}  {r['est_seconds']:7.1f}  {r['est_memory_gb']:6.2f}  {r['label']}")
        print(f"{len(rows)} tasks, {total:.0f} s of work on one core; local cluster {plan['workers']} workers x "
              f"{plan['threads']} threads ({plan['why']}): about {total / plan['workers']:.0f} s")
        return 0
    if args.out is None:
        raise ValueError("--out DIR is required (or --dry-run)")
    timeout = _worker_timeout(args)
    if args.scheduler is not None:
        check_scheduler(args.scheduler)

    def log(line):
        print(line, file=sys.stderr)

    try:
        summary = run_campaign(spec, args.out, workers=args.workers, scheduler=args.scheduler, local=args.local,
                               memory_limit=None if args.memory_limit is None else args.memory_limit * 1e9,
                               progress=not args.no_progress, log=log, overwrite=args.overwrite,
                               worker_timeout=timeout)
    except KeyboardInterrupt:
        print(f"cwlidar-sim campaign: interrupted; finished tasks are kept in {os.path.join(args.out, 'tasks')}; "
              f"run the same command again to resume", file=sys.stderr)
        return 130
    except WorkersLostError:
        raise  # main: one line, finished tasks kept, exit status 1
    except OSError as e:
        if "connect" in str(e).lower() or isinstance(e, TimeoutError):
            raise PreflightError(f"dask scheduler {args.scheduler} did not answer ({e}); fix: check the address") from None
        raise
    print(_json(summary))
    return 1 if summary["failed"] else 0


def _cmd_campaign_report(args) -> int:
    import os

    from .campaign.execution.batch import merge_campaign, sweep_figures
    from .campaign.execution.store import write_results

    merged = merge_campaign(args.dir, keep_series=args.keep_series)
    path = os.path.join(args.dir, "campaign.nc")
    write_results(merged, path)
    figs = sweep_figures(merged, os.path.join(args.dir, "figures"))
    print(_json({"merged": path, "dims": dict(merged.sizes), "figures": figs}))
    return 0


def _add_probe_length(sub):
    p = _command(sub, "probe-length", "fit zR and the telescope radius to method 2",
                 "Fit the Rayleigh length zR and the telescope radius a0 it implies to the "
                 "method-2 transfer function of a results file, with the estimator-aware theory "
                 "(cwlidar_sim.analysis.fit_probe_length); prints JSON.",
                 ["cwlidar-sim probe-length results/a2012.nc",
                  "cwlidar-sim probe-length results --estimator centroid --band 0.02 0.6"])
    p.add_argument("results", help="a results file (DIR/<name>.nc) or a folder holding one")
    p.add_argument("--estimator", default=None, help="the lidar's own estimator (default) or one of its variants'")
    p.add_argument("--band", nargs=2, type=float, default=None, metavar=("K_LO", "K_HI"),
                   help="wavenumber band [rad/m] (default 0.02 0.6)")
    p.add_argument("--lines", type=int, default=4, help="theory ensemble: lines of 4096 points per zR (default 4)")
    p.set_defaults(func=_cmd_probe_length)


def _cmd_probe_length(args) -> int:
    import glob
    import os

    from .analysis.estimator_theory import DEFAULT_BAND
    from .campaign import fit_probe_length_results
    from .campaign.execution.results_file import lacking, open_results

    path = args.results
    if os.path.isdir(path):
        files = sorted(glob.glob(os.path.join(path, "*.nc")))
        if len(files) != 1:
            raise ValueError(f"{path!r} holds {len(files)} results files (*.nc); name one")
        path = files[0]
    if not os.path.lexists(path):
        raise ValueError(f"no results file {path!r}")
    ds = open_results(path, sensor="staring")
    try:
        fit = fit_probe_length_results(ds, estimator=args.estimator, band=tuple(args.band or DEFAULT_BAND),
                                       n_lines=args.lines)
    except (KeyError, AttributeError) as e:  # a variable or attribute missing from an older or edited file
        raise lacking(path, ds, e, "the probe-length fit") from None
    out = fit.summary()
    out.pop("zR_grid")
    out.pop("chi2_grid")
    out["results"] = os.path.abspath(path)
    print(_json(out))
    return 0


def _add_twin(sub):
    p = _command(sub, "twin", "virtual twin: the lidar in fields conditioned on records",
                 "Read the records the scene names in [turbulence] condition_on (or --records, one file per "
                 "record, in order), cut them into the scene's periods, and for each period fly the scene's lidar "
                 "and sonic through N fields conditioned on the records (Hoffman-Ribak). Writes DIR/<scene>_twin_"
                 "P<k>.nc per period: the twins' 10 Hz series, their mean and std, T1/T2 and the coherence "
                 "against the record, with the spread across the twins beside the record's own statistics (conical "
                 "scenes: the scanning lidar, cup and sonic in N conditioned boxes; per period every twin's "
                 "lidar mean and std, std ratio, TP, ... with their spread). Bad records are refused before "
                 "anything is computed; a rerun skips the finished periods whose inputs are unchanged; --dask runs "
                 "every (period, twin) on a cluster with the same result.\n\n" + _DASK_TRUST,
                 ["python -c 'from cwlidar_sim.campaign.twin.example import write_twin_example as w; "
                  "w(\"ex\")'   # the bundled example's truth and CSV",
                  "cwlidar-sim twin ex/twin.toml --twins 8 --out results/twin",
                  "cwlidar-sim twin my_scene.toml --records mast_40m.csv --twins 16 --out results/mine"])
    p.add_argument("scene", help="staring or conical scene TOML with [turbulence] condition_on")
    p.add_argument("--records", nargs="+", default=None, metavar="FILE",
                   help="record files replacing the scene's condition_on paths, in order")
    p.add_argument("--twins", type=int, default=8, help="twins per period (default 8)")
    p.add_argument("--out", required=True, help="output folder (created; resumed if it holds finished periods)")
    p.add_argument("--periods", type=int, nargs="+", default=None, metavar="K", help="only these period indices")
    p.add_argument("--no-progress", action="store_true", help="no progress lines on stderr")
    _add_dask_options(p, "dask", "every (period, twin) as a task (the files are the same bit for bit)")
    p.set_defaults(func=_cmd_twin)


def _cmd_twin(args) -> int:
    from ._preflight import preflight
    from .campaign import load_scene
    from .campaign.twin.run import run_twin

    def log(line):
        if not args.no_progress:
            print(line, file=sys.stderr)

    scene = load_scene(args.scene)
    # before any record is read or field computed: the folder can be made and written, the NetCDF
    # engine imports, the disk holds a period's file (each twin's two 10 Hz series dominate; periods
    # are written one by one, so a disk that fills later keeps the finished ones)
    longest = max(scene.period_duration(p) for p in scene.periods)
    preflight(args.out, 1e6 + 2 * 8 * 10 * longest * max(1, args.twins), engine=True)
    timeout = _worker_timeout(args)
    client = _client(args.dask, timeout)
    try:
        files = run_twin(scene, args.out, paths=args.records, n_twins=args.twins, progress=log, periods=args.periods,
                         client=client, worker_timeout=timeout)
    except KeyboardInterrupt:
        print(f"cwlidar-sim twin: interrupted; finished periods are kept in {args.out}; run the same command again "
              f"to resume", file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()
    print(_json({"periods": files}))
    return 0


# Files shipped with the package, found without importing cwlidar_sim.campaign (listing stays instant):
# scenes (``run NAME``, ``reproduce``) and campaign examples (``campaign NAME``).
def _add_scenes(sub):
    p = _command(sub, "scenes", "list the bundled scenes and examples; write one out",
                 "List the scenes (for 'run' and 'reproduce') and the campaign examples (for 'campaign') that "
                 "ship with the package, with their descriptions; or write one out as the starting point of "
                 "your own. The files are commented: every key they set is explained where it is set.",
                 ["cwlidar-sim scenes",
                  "cwlidar-sim scenes --write a2012 my_scene.toml      # then edit it and:",
                  "cwlidar-sim run my_scene.toml --out results/mine",
                  "cwlidar-sim scenes --write campaign_quick my_sweep.toml",
                  "cwlidar-sim scenes --show cs                        # print it"])
    p.add_argument("--write", nargs=2, metavar=("NAME", "FILE"), default=None,
                   help="write the bundled NAME to FILE (refuses to overwrite FILE unless --force)")
    p.add_argument("--force", action="store_true", help="--write: overwrite FILE if it exists")
    p.add_argument("--show", metavar="NAME", default=None, help="print the bundled NAME's TOML")
    p.add_argument("--json", action="store_true", help="print the list as JSON")
    p.set_defaults(func=_cmd_scenes)


def _cmd_scenes(args) -> int:
    import tomllib

    from ._atomic import atomic_open, check_output_file

    found = _bundled_files()

    def get(name):
        if name not in found:
            raise ValueError(f"no bundled scene or example {name!r}; bundled: {', '.join(sorted(found))}")
        return found[name]

    if args.show is not None:
        print(get(args.show)[1].read_text(encoding="utf-8"), end="")
        return 0
    if args.write is not None:
        name, path = args.write
        kind, f = get(name)
        if os.path.exists(path) and not args.force:
            raise ValueError(f"{path} exists; pass --force to overwrite it")
        # a missing folder is refused with its name (not created silently), a directory or
        # /dev/null too; the file appears whole or not at all
        check_output_file(path, label="--write FILE")
        with atomic_open(path, "w") as fh:
            fh.write(f.read_text(encoding="utf-8"))
        then = (f"cwlidar-sim run {path} --out results/{name}" if kind == "scene"
                else f"cwlidar-sim campaign {path} --dry-run")
        print(f"wrote {path} (bundled {kind} {name!r}); edit it, then: {then}")
        return 0
    rows = []
    for name, (kind, f) in found.items():
        d = tomllib.loads(f.read_text(encoding="utf-8"))
        rows.append({"name": name, "kind": kind, "description": d.get("description", ""), "file": str(f)})
    if args.json:
        print(_json(rows))
        return 0
    width = max(len(r["name"]) for r in rows)
    for r in rows:
        print(f"{r['name']:{width}}  {r['kind']:8}  {r['description']}")
    print("\nscenes: cwlidar-sim run NAME --out DIR; campaigns: cwlidar-sim campaign NAME --out DIR;\n"
          "your own: cwlidar-sim scenes --write NAME FILE, edit FILE, and run it")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="cwlidar-sim",
        description="Continuous-wave Doppler wind lidar simulator in synthetic Mann turbulence.",
        epilog="'cwlidar-sim COMMAND --help' shows a command's options and examples;\n"
               "'python -m cwlidar_sim' is the same program.",
        formatter_class=_Formatter,
    )

    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    _add_box(sub)
    _add_doppler(sub)
    _add_campaign(sub)
    _add_sweep(sub)
    _add_probe_length(sub)
    _add_scenes(sub)
    _add_twin(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        with sigterm_raises():  # a SIGTERM unwinds like Ctrl-C: temporary files go, old files stay
            return int(args.func(args) or 0)
    except Terminated:
        print(terminated_message(args.command, getattr(args, "out", None)), file=sys.stderr)
        return EXIT_SIGTERM
    except (ValueError, TypeError) as exc:
        # Bad input, or a run that cannot write its results: one clear line, not a traceback.
        print(f"cwlidar-sim {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        # Writing failed mid-run (e.g. a full disk): what was finished is on disk, the file being
        # replaced is unchanged (atomic writes); only some commands have anything to resume.
        tail = "; finished results are kept, run again to resume" if args.command in RESUMABLE else ""
        print(f"cwlidar-sim {args.command}: error: {exc}{tail}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
