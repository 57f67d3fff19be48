"""benchmarks/ holds timing scripts only, each run by run_all.py; studies/ the rest; every cited script exists.

No benchmark is run here (they time things; no test depends on wall-clock time): these read the scripts'
names, and check tools/compare_benchmarks.py's comparison on made-up headlines.
"""

import ast
import importlib.util
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: Where scripts are cited as commands or sources (the changelog keeps the paths of its day).
CITING = ("README.md", "docs", "benchmarks", "studies", "tools", "tests", "notebooks", "examples", "cwlidar_sim")
#: Names that stand for any script (benchmarks/_protocol.py's "python benchmarks/x.py").
PLACEHOLDERS = {"benchmarks/x.py"}


def _run_all_scripts():
    tree = ast.parse((ROOT / "benchmarks" / "run_all.py").read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.AnnAssign | ast.Assign) and "BENCHMARKS" in ast.unparse(node):
            return {v.elts[0].value for v in node.value.values}
    raise AssertionError("run_all.py has no BENCHMARKS table")


def test_every_benchmark_script_is_run_by_run_all_and_no_study_is():
    scripts = {p.name for p in (ROOT / "benchmarks").glob("*.py")} - {"_protocol.py", "run_all.py"}
    run = _run_all_scripts()
    assert scripts - run == set(), "timing scripts in benchmarks/ that run_all.py does not run (or move to studies/)"
    assert run <= scripts, f"run_all.py names scripts that are not in benchmarks/: {sorted(run - scripts)}"
    studies = {p.name for p in (ROOT / "studies").glob("*.py")}
    assert studies and not (studies & scripts)
    listed = (ROOT / "studies" / "README.md").read_text(encoding="utf-8")
    assert [s for s in sorted(studies) if f"`{s}`" not in listed] == [], "studies missing from studies/README.md"


def test_every_cited_benchmark_or_study_script_exists():
    cited = {}
    for top in CITING:
        path = ROOT / top
        files = [path] if path.is_file() else [p for p in path.rglob("*") if p.suffix in (".md", ".py", ".ipynb", ".toml")
                                               and "_build" not in p.parts]
        for f in files:
            for m in re.finditer(r"\b((?:benchmarks|studies)/[A-Za-z0-9_]+\.py)", f.read_text(encoding="utf-8")):
                cited.setdefault(m.group(1), set()).add(str(f.relative_to(ROOT)))
    missing = {c: sorted(w) for c, w in cited.items() if c not in PLACEHOLDERS and not (ROOT / c).is_file()}
    assert missing == {}


def _tool():
    spec = importlib.util.spec_from_file_location("compare_benchmarks", ROOT / "tools" / "compare_benchmarks.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_compare_flags_only_a_change_worse_than_the_noise_in_the_slower_direction():
    tool = _tool()
    base = [{"ratios": {"wall_s": 10.0, "tier3_realtime_factor": 4.0, "peak_gib": 1.0, "x/error": 0.1}},
            {"ratios": {"wall_s": 10.5, "tier3_realtime_factor": 4.1, "peak_gib": 1.0, "x/error": 0.1}}]
    new = [{"ratios": {"wall_s": 10.3, "tier3_realtime_factor": 3.0, "peak_gib": 1.5, "x/error": 0.5}},
           {"ratios": {"wall_s": 10.2, "tier3_realtime_factor": 3.1, "peak_gib": 1.5, "x/error": 0.5}}]
    rows = {r[0]: r for r in tool.compare(base, new, min_noise=0.01, noise_factor=1.0)}
    # 10.0 -> 10.2: +2 %, inside the base's own spread of 5 %
    assert rows["wall_s"][2:4] == (10.0, 10.2) and rows["wall_s"][5] == 0.05 and rows["wall_s"][6] == ""
    # a real-time factor is higher-is-better: its best is the maximum, and a drop is the slower direction
    assert rows["tier3_realtime_factor"][2:4] == (4.1, 3.1) and rows["tier3_realtime_factor"][6] == "SLOWER"
    assert rows["peak_gib"][6] == "MORE MEMORY"
    assert rows["x/error"][1] == "info" and rows["x/error"][6] == ""
    # faster is never flagged, however large
    rows = {r[0]: r for r in tool.compare(new, base, min_noise=0.01, noise_factor=1.0)}
    assert rows["tier3_realtime_factor"][6] == "" and rows["peak_gib"][6] == ""
    # one round per side: no measured noise, the floor decides
    rows = {r[0]: r for r in tool.compare(base[:1], [{"ratios": {"wall_s": 10.4}}], min_noise=0.05)}
    assert rows["wall_s"][5] is None and rows["wall_s"][6] == ""
    rows = {r[0]: r for r in tool.compare(base[:1], [{"ratios": {"wall_s": 10.6}}], min_noise=0.05)}
    assert rows["wall_s"][6] == "SLOWER"
    # the noise counts noise_factor times: 10.0 -> 10.8 (+8 %) against a spread of 5 %
    slower = [{"ratios": {"wall_s": 10.8}}, {"ratios": {"wall_s": 10.9}}]
    for factor, flag in ((1.0, "SLOWER"), (2.0, "")):
        rows = {r[0]: r for r in tool.compare(base, slower, min_noise=0.01, noise_factor=factor)}
        assert rows["wall_s"][6] == flag and rows["peak_gib"][6] == "one side only"


def test_headline_directions_of_run_all_keys():
    kind = _tool().kind
    assert kind("4096x32x32@2/ours/mannrs_periodic") == "higher"  # the peer's time over ours
    assert kind("4096x32x32@2/speedup_vs_faster_peer_periodic") == "higher"
    assert kind("1w_x_2t/sim_h_per_wall_h") == "higher"
    assert kind("4096x32x32@2/ours_second/floor") == "lower"
    assert kind("4096x32x32@2/ours_peak/output") == "memory"
    assert kind("hour: speckle peak/wall_s_per_sim_hour") == "lower"  # a label is not the headline's name
    assert kind("hour: dx1/pareto") == "info"
