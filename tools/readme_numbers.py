#!/usr/bin/env python3
"""The README's numbers, written from committed results files so that none can go stale.

Every number the README states that comes from a run stands between
``<!-- BEGIN generated:NAME -->`` and ``<!-- END generated:NAME -->``; this script writes those
blocks from the files below, and ``tests/test_readme.py`` regenerates them and fails when the README
differs (a results file changed without re-running this script, or a block edited by hand).

The sources (all committed):

* ``docs/a2012_reproduce.json``: a full ``cwlidar-sim reproduce a2012`` run's headline numbers
  (``--a2012 RESULTS.nc`` writes it from the run's results file);
* ``docs/cs_reproduce.json``: ``python studies/cs_reproduce.py --out DIR --json docs/cs_reproduce.json``;
* ``docs/cs_attribution.json``: ``python studies/cs_attribution.py --json docs/cs_attribution.json`` (the CS
  ratio walked from CS's filter model to the simulation by the linear theory);
* ``docs/cs_theory.json``: ``python studies/cs_theory.py --json docs/cs_theory.json`` (the linear theory of the
  CS table, the bundled scene with ``scan.theory = "only"``);
* ``docs/nacelle_coherence.json``: ``python studies/nacelle_coherence.py --json docs/nacelle_coherence.json``;
* ``docs/readme_timings.json``: the wall time of the README's commands, cold (numba compiling into
  an empty cache) and warm (``--measure`` runs them here and writes it).

Usage (from the repository root)::

    python tools/readme_numbers.py                        # rewrite the README's generated blocks
    python tools/readme_numbers.py --check                # exit status 1 if the README is not up to date
    python tools/readme_numbers.py --a2012 results/a2012.nc   # summarise a full A2012 run, then rewrite
    python tools/readme_numbers.py --measure              # time the README's commands, then rewrite
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
README = os.path.join(ROOT, "README.md")
DOCS = os.path.join(ROOT, "docs")
A2012_JSON = os.path.join(DOCS, "a2012_reproduce.json")
CS_JSON = os.path.join(DOCS, "cs_reproduce.json")
CS_ATTRIBUTION_JSON = os.path.join(DOCS, "cs_attribution.json")
CS_THEORY_JSON = os.path.join(DOCS, "cs_theory.json")
NACELLE_JSON = os.path.join(DOCS, "nacelle_coherence.json")
TIMINGS_JSON = os.path.join(DOCS, "readme_timings.json")

BLOCK = re.compile(r"(<!-- BEGIN generated:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- END generated:(?P=name) -->)", re.S)
#: The wavenumber below which A2012 reads both transfer functions as 1 [rad/m].
LOW_K = 0.02
#: The nacelle headline: the focus distance [m] and the segment length of the table's row.
NACELLE_FOCUS, NACELLE_SEGMENT = "100", "segment_60s"


def _load(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _about(seconds: float) -> str:
    """A wall time as the README says it: whole seconds under 10 s, else to the nearest 5 s."""
    return f"{round(seconds):d} s" if seconds < 10 else f"{5 * round(seconds / 5):d} s"


def _duration(seconds: float) -> str:
    """A period's length: '1 h', '20 min'."""
    return f"{seconds / 3600:g} h" if seconds >= 3600 else f"{seconds / 60:g} min"


# ---------------------------------------------------------------------------------------------------
# the README's code blocks that the timings run
# ---------------------------------------------------------------------------------------------------
def readme_text() -> str:
    with open(README, encoding="utf-8") as f:
        return f.read()


def section(text: str, title: str) -> str:
    """The text of the README section headed ``title`` (any level), up to the next heading."""
    m = re.search(rf"^#+ {re.escape(title)}\n(.*?)(?=^#+ |\Z)", text, re.S | re.M)
    if not m:
        raise KeyError(f"README.md has no section {title!r}")
    return m.group(1)


def scene_block(text: str | None = None) -> str:
    """The TOML scene of the README's 'Your own scene' section (the one ```toml block there)."""
    blocks = re.findall(r"^```toml\n(.*?)^```", section(text or readme_text(), "Your own scene"), re.S | re.M)
    if len(blocks) != 1:
        raise ValueError(f"'Your own scene' holds {len(blocks)} toml blocks, not one")
    return blocks[0]


# ---------------------------------------------------------------------------------------------------
# the blocks
# ---------------------------------------------------------------------------------------------------
def _first_result(a2012, timings) -> str:
    runs = timings["runs"]
    full, quick, m = runs["a2012"], runs["a2012_quick"], timings["machine"]
    (dur,) = {p["duration_s"] for p in a2012["periods"]}
    return (f"It simulates {len(a2012['periods'])} periods of {_duration(dur)} with the focus at "
            f"{a2012['focus_m']:g} m, in about "
            f"{_about(full['warm_s'])} on {timings['machine']['cpu_count']} cores (about {_about(full['cold_s'])} the "
            f"first time, while numba compiles). For a first result sooner, add `--quick` "
            f"(periods of {_duration(quick['period_s'])}): about {_about(quick['warm_s'])}, or "
            f"{_about(quick['cold_s'])} the first time. (Measured on {m['date'][:10]} with "
            f"`python tools/readme_numbers.py --measure`, at a load average of {m['loadavg_before'][0]:.1f}–"
            f"{m['loadavg_after'][0]:.1f}: less on an idle machine.)\n")


def _own_scene(timings) -> str:
    run = timings["runs"]["own_scene"]
    return (f"It runs in about {_about(run['warm_s'])} on {timings['machine']['cpu_count']} cores "
            f"({_about(run['cold_s'])} before numba has compiled).\n")


def _cs_cells(cs, theory) -> str:
    """Per height, the simulated 1 s / 3 s ratios ± s.e. and the linear theory beside them."""
    cells = []
    for z in sorted(cs["heights"], key=float):
        h, t = cs["heights"][z], theory["heights"][z]
        cells.append(f"{z} m {h['std_ratio_1s']:.3f} ± {h['std_ratio_1s_se']:.3f} / {h['std_ratio_3s']:.3f} ± "
                     f"{h['std_ratio_3s_se']:.3f} (theory {t['std_ratio_1s_theory']:.3f} / "
                     f"{t['std_ratio_3s_theory']:.3f})")
    return "; ".join(cells)


def _reproductions(a2012, cs, nacelle, theory) -> str:
    lo, hi = a2012["low_k"]["min"], a2012["low_k"]["max"]
    heights = sorted(cs["heights"], key=float)
    h0, h1 = cs["heights"][heights[0]], cs["heights"][heights[-1]]
    fo = nacelle["focus"][NACELLE_FOCUS][NACELLE_SEGMENT]
    k_lo, k_hi = fo["k_half_interval"]
    inside = total = 0
    for f in nacelle["focus"].values():
        for seg in ("segment_60s", "segment_600s"):
            a, b = f[seg]["inside95_exact"].split("/")
            inside, total = inside + int(a), total + int(b)
    focuses = sorted(nacelle["focus"], key=float)
    rows = [
        "| study | what runs | headline |",
        "|---|---|---|",
        f"| [A2012](docs/reproductions/a2012.md): `reproduce a2012` | staring lidar against a sonic at its "
        f"{a2012['focus_m']:g} m focus, {len(a2012['periods'])} periods of {_duration(a2012['periods'][0]['duration_s'])}"
        f" | both transfer functions {lo:.2f}–{hi:.2f} below {LOW_K:g} rad/m (A2012: about 1), where the probe "
        f"volume's filter exp(−2 k zR), zR = {a2012['rayleigh_length_m']:.2f} m, is close to 1 |",
        f"| [CS](docs/reproductions/cs.md): `reproduce cs` | conically scanning ZephIR against a cup at "
        f"{heights[0]}–{heights[-1]} m, {cs['units']} ten-minute periods (about "
        f"{round(cs['run']['wall_s'] / 60)} minutes on {cs['machine']['cpu_count']} cores) | lidar/cup σ ratio, 1 s / 3 s scans, simulated ± s.e. "
        f"and the linear theory beside it (continuum, tier los's answer, `studies/cs_theory.py`): "
        f"{_cs_cells(cs, theory)}; CS's filter model (1 s) "
        f"{h0['std_ratio_1s_model_kaimal']:.3f} to {h1['std_ratio_1s_model_kaimal']:.3f} |",
        f"| [nacelle](docs/reproductions/nacelle.md): `reproduce nacelle` | forward-looking scanning lidar, "
        f"rotor-effective wind speed preview at {', '.join(focuses)} m | wavenumber of coherence 0.5 at "
        f"{NACELLE_FOCUS} m ({nacelle['periods']} frozen periods, `studies/nacelle_coherence.py`): {fo['k_half_simulated']:.4f} [{k_lo:.4f}, {k_hi:.4f}] rad/m simulated, "
        f"{fo['k_half_theory_exact']:.4f} analytic; {inside} of {total} bins hold the analytic coherence in "
        f"their 95 % interval |",
    ]
    return "\n".join(rows) + "\n"


def _span(values, signed=False) -> str:
    """A range of changes as the README says it: '0.118–0.162' (magnitudes), or signed '−0.010 to +0.003'."""
    lo, hi = min(values), max(values)
    if signed:
        return f"{lo:+.3f} to {hi:+.3f}".replace("-", "−")
    return f"{lo:.3f}–{hi:.3f}" if f"{lo:.3f}" != f"{hi:.3f}" else f"{lo:.3f}"


def _cs_residual(attribution, cs) -> str:
    """Why the CS ratio lies below CS's filter model: the linear theory's steps, over every height and scan of
    the attribution run (``studies/cs_attribution.py``), against the simulation (``docs/cs_reproduce.json``)."""
    heights = sorted(attribution["heights"], key=float)
    scans = sorted({n for z in heights for n in attribution["heights"][z]["steps"]["box"]}, key=int)

    def change(step, before):
        return [attribution["heights"][z]["steps"][step][n] - attribution["heights"][z]["steps"][before][n]
                for z in heights for n in scans]

    period = [attribution["heights"][z]["steps"]["period"][n] for z in heights for n in scans]
    gap, sigmas = [], []
    for z in heights:
        for n in scans:
            sim, se = cs["heights"][z][f"std_ratio_{n}s"], cs["heights"][z][f"std_ratio_{n}s_se"]
            gap.append(sim - attribution["heights"][z]["steps"]["box"][n])
            sigmas.append(abs(gap[-1]) / se)
    drop, w, exact, box = (change(*p) for p in (("uv_3d", "period"), ("w", "uv_3d"), ("exact", "w"), ("box", "exact")))
    return (f"Why the CS ratio lies below CS's filter model, by the linear theory one step at a time "
            f"([the CS page](docs/reproductions/cs.md), "
            f"`studies/cs_attribution.py`; {heights[0]}–{heights[-1]} m, {' and '.join(scans)} s scans): with the "
            f"scan's own looks, 10-minute periods and the cup, a field varying along the wind only gives "
            f"{_span(period)}. u and v decorrelating across the scan circle and along the slanted beams lower it by "
            f"{_span([-d for d in drop])}; w's contamination of the fit's horizontal speed raises it by {_span(w)}, "
            f"the beam's exact weighting (mostly its cut at the telescope) by {_span(exact)} and the box's discrete modes by {_span(box)}. The theory "
            f"then lies within {max(sigmas):.1f} standard errors of the simulation (simulated − theory "
            f"{_span(gap, signed=True)}; the 3-D steps at one speed, {attribution['settings']['u_ref']:g} m/s).\n")


def blocks() -> dict:
    """Every generated block's text, by name, from the committed results files."""
    a2012, cs, nacelle, timings, attribution, theory = (_load(p) for p in (A2012_JSON, CS_JSON, NACELLE_JSON,
                                                                            TIMINGS_JSON, CS_ATTRIBUTION_JSON,
                                                                            CS_THEORY_JSON))
    return {"first-result": _first_result(a2012, timings), "own-scene": _own_scene(timings),
            "reproductions": _reproductions(a2012, cs, nacelle, theory), "cs-residual": _cs_residual(attribution, cs)}


def render(text: str, made: dict) -> str:
    """``text`` with every generated block replaced; a block the README names but the script does not
    make, or one it makes but the README lacks, is an error."""
    found = [m.group("name") for m in BLOCK.finditer(text)]
    if sorted(found) != sorted(made):
        raise ValueError(f"README.md's generated blocks {sorted(found)} are not the script's {sorted(made)}")
    return BLOCK.sub(lambda m: m.group(1) + made[m.group("name")] + m.group(4), text)


# ---------------------------------------------------------------------------------------------------
# the sources
# ---------------------------------------------------------------------------------------------------
def summarise_a2012(path: str) -> dict:
    """Headline numbers of a full A2012 run's results file."""
    import numpy as np
    import xarray as xr

    ds = xr.load_dataset(path, engine="h5netcdf")
    scene = json.loads(ds.attrs["scene"])
    low = ds.k.values < LOW_K
    both = np.concatenate([ds.transfer_ratio.values[:, low].ravel(), ds.transfer_cross.values[:, low].ravel()])
    durations = dict(zip([str(p) for p in ds.period.values], ds.duration.values.tolist()))
    return {
        "source": f"cwlidar-sim reproduce a2012 --out DIR: DIR/{os.path.basename(path)}",
        "cwlidar_sim_version": ds.attrs.get("cwlidar_sim_version"),
        "scene": scene.get("name"),
        "periods": [{"name": n, "duration_s": d} for n, d in durations.items()],
        "focus_m": float(ds.attrs["focus"]),
        "rayleigh_length_m": float(ds.attrs["rayleigh_length"]),
        "estimator": ds.attrs["lidar_estimator"],
        "low_k": {"k_max": LOW_K, "what": "transfer_ratio and transfer_cross, every period, k < k_max",
                  "min": float(np.nanmin(both)), "max": float(np.nanmax(both))},
        "wall_time_s": float(ds.attrs["wall_time"]),
    }


def _timed(cmd, env, cwd) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, env=env, cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def measure(repeats: int = 2) -> dict:
    """Wall time of the README's commands: cold (an empty numba cache) and warm (the same cache again),
    each the shortest of ``repeats`` tries (other load on the machine only ever lengthens a run)."""
    sys.path.insert(0, ROOT)
    from cwlidar_sim.campaign.execution.reproduce import bundled_scene

    cli = [sys.executable, "-m", "cwlidar_sim"]
    runs, load_before = {}, os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="readme_numbers_") as tmp:
        scene_path = os.path.join(tmp, "my_scene.toml")
        with open(scene_path, "w", encoding="utf-8") as f:
            f.write(scene_block())
        commands = {
            "a2012": cli + ["reproduce", "a2012", "--no-progress"],
            "a2012_quick": cli + ["reproduce", "a2012", "--quick", "--no-progress"],
            "own_scene": cli + ["run", scene_path, "--figures", "--no-progress"],
        }
        for name, cmd in commands.items():
            tries = {"cold": [], "warm": []}
            for i in range(repeats):
                env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, f"numba_{name}_{i}"), PYTHONPATH=ROOT)
                for state in ("cold", "warm"):
                    out = os.path.join(tmp, f"out_{name}_{state}")
                    tries[state].append(round(_timed(cmd + ["--out", out], env, tmp), 1))
                    shutil.rmtree(out)
            shown = " ".join(["cwlidar-sim"] + cmd[3:]).replace(scene_path, "my_scene.toml")
            runs[name] = {"command": shown + " --out DIR", "cold_s": min(tries["cold"]), "warm_s": min(tries["warm"]),
                          "tries_s": tries}
            print(name, runs[name], flush=True)
    quick = bundled_scene("a2012", quick=True)
    runs["a2012_quick"]["period_s"] = quick.period_duration(quick.periods[0])
    load = os.getloadavg()
    return {"machine": {"date": datetime.datetime.now().isoformat(timespec="seconds"), "cpu_count": os.cpu_count(),
                        "python": sys.version.split()[0], "loadavg_before": [round(x, 2) for x in load_before],
                        "loadavg_after": [round(x, 2) for x in load]},
            "note": ("cold: numba compiling into an empty NUMBA_CACHE_DIR; warm: the same command again; "
                     "each the shortest of its tries"),
            "runs": runs}


def _write_json(path, data):
    with open(path, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
        f.write("\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="only compare; exit status 1 if the README differs")
    ap.add_argument("--a2012", metavar="RESULTS", help="write docs/a2012_reproduce.json from a full run's a2012.nc")
    ap.add_argument("--measure", action="store_true", help="time the README's commands into docs/readme_timings.json")
    ap.add_argument("--repeats", type=int, default=2, help="tries per command and state with --measure (default 2)")
    args = ap.parse_args(argv)
    if args.a2012:
        _write_json(A2012_JSON, summarise_a2012(args.a2012))
    if args.measure:
        _write_json(TIMINGS_JSON, measure(args.repeats))
    text = readme_text()
    new = render(text, blocks())
    if args.check:
        if new != text:
            print("README.md's generated blocks are out of date: run python tools/readme_numbers.py", file=sys.stderr)
            return 1
        return 0
    if new != text:
        with open(README, "w", encoding="utf-8") as f:
            f.write(new)
        print("README.md updated")
    return 0


if __name__ == "__main__":
    sys.exit(main())
