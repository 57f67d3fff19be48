"""benchmarks/ holds timing scripts only, each run by run_all.py; studies/ the rest; every cited script exists.

No benchmark is run here (they time things; no test depends on wall-clock time): these read the scripts'
names.
"""

import ast
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[1]
#: Where scripts are cited as commands or sources (the changelog keeps the paths of its day).
CITING = ("README.md", "docs", "benchmarks", "studies", "tools", "tests", "notebooks", "examples")
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
