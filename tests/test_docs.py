"""The documentation site's sources and the release files: the API reference covers every public
name, the pages' README sections exist, the version is set in one place, the package data ships.

The site itself is built by ``python -m sphinx -n -W -b html docs docs/_build/html`` (CI does, and
then opens it in a browser, .ci/check_site.py); these tests need no Sphinx and run in seconds.
When a built site is present and newer than the package's sources, its object inventory is
checked too.
"""

import fnmatch
import importlib
import importlib.metadata
import os
import pathlib
import re
import sys
import tomllib
import subprocess
import zlib

import pytest

import cwlidar_sim

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_ext"))

import apigen  # noqa: E402
import sitetools  # noqa: E402

PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


# ---------------------------------------------------------------------------------------------
# the API reference
# ---------------------------------------------------------------------------------------------
def _documented(rst: str) -> set[str]:
    """Names an API page documents: autosummary entries, ``.. data::`` and ``:mod:`` links."""
    names, in_table = set(), False
    for line in rst.splitlines():
        if line.startswith(".. autosummary::"):
            in_table = True
            continue
        if in_table:
            if line.strip().startswith(":") or not line.strip():
                continue
            if line.startswith("   "):
                names.add(line.strip())
                continue
            in_table = False
        m = re.match(r"\.\. data:: (\S+)", line)
        if m:
            names.add(m.group(1))
        names.update(n.rsplit(".", 1)[-1] for n in re.findall(r"^\* :mod:`([\w.]+)`", line))
    return names


@pytest.fixture(scope="module")
def api_sources(tmp_path_factory):
    out = tmp_path_factory.mktemp("api")
    apigen.generate(str(out))
    return out


def test_every_public_name_is_in_the_api_reference(api_sources):
    names = apigen.public_names()
    assert set(names) >= {f"cwlidar_sim.{s}" for s in ("turbulence", "beam", "signal", "sensors", "analysis",
                                                       "campaign")}
    index = (api_sources / "index.rst").read_text(encoding="utf-8")
    assert set(apigen.root_names()) >= {"open_scene", "run", "open_results"}
    names = {"cwlidar_sim": apigen.root_names(), **names}  # the high-level API, on the package's own page
    for sub, public in names.items():
        assert f"   {sub}\n" in index, f"{sub} missing from the API index"
        page = (api_sources / f"{sub}.rst").read_text(encoding="utf-8")
        missing = set(public) - _documented(page)
        assert not missing, f"{sub}: {sorted(missing)} in __all__ but not in the API reference"


def test_every_public_module_and_its_own_names_are_documented(api_sources):
    for sub, public in apigen.public_names().items():
        pkg = importlib.import_module(sub)
        page = (api_sources / f"{sub}.rst").read_text(encoding="utf-8")
        for modname in apigen.public_modules(sub):
            assert f"   {modname}\n" in page, f"module {modname} not listed on {sub}'s page"
            mod = importlib.import_module(modname)
            text = (api_sources / f"{modname}.rst").read_text(encoding="utf-8")
            assert f".. automodule:: {modname}" in text
            for name in apigen.module_names(modname):
                shared = name in public and getattr(pkg, name) is getattr(mod, name)
                if shared:
                    assert f":obj:`~{sub}.{name}`" in text, (modname, name)
                else:
                    assert name in _documented(text), f"{modname}.{name} is not in the API reference"


def _inventory(path: pathlib.Path) -> dict[str, str]:
    """``{name: domain:role}`` of a Sphinx objects.inv (version 2: four header lines, then zlib)."""
    raw = path.read_bytes()
    body = raw.split(b"\n", 4)[4]
    out = {}
    for line in zlib.decompress(body).decode("utf-8").splitlines():
        m = re.match(r"(.+?)\s+(\S+:\S+)\s+(-?\d+)\s+(\S*)\s+(.*)", line)
        if m:
            out[m.group(1)] = m.group(2)
    return out


def _fresh_inventory():
    inv = DOCS / "_build" / "html" / "objects.inv"
    if not inv.is_file():
        return None
    newest = max(p.stat().st_mtime for p in (ROOT / "cwlidar_sim").rglob("*.py"))
    return inv if inv.stat().st_mtime >= newest else None


def test_built_site_documents_every_public_name():
    inv = _fresh_inventory()
    if inv is None:
        pytest.skip("no built site newer than the package (python -m sphinx -n -W -b html docs docs/_build/html)")
    objects = _inventory(inv)
    for sub, public in apigen.public_names().items():
        assert objects.get(sub) == "py:module", sub
        pkg = importlib.import_module(sub)
        for name in public:
            obj = getattr(pkg, name)
            target = obj.__name__ if apigen.kind_of(obj) == "module" else f"{sub}.{name}"
            assert target in objects, f"{target} was not rendered into the site"
    # a function's page carries its parameters (numpydoc) and at least one unit
    page = (inv.parent / "api" / "generated" / "cwlidar_sim.turbulence.generate_box.html").read_text(encoding="utf-8")
    assert "Parameters" in page and "[m]" in page


# ---------------------------------------------------------------------------------------------
# the pages' sources
# ---------------------------------------------------------------------------------------------
def _include_markers():
    for md in DOCS.rglob("*.md"):
        if "_build" in md.parts:
            continue
        for kind, title in sitetools.INCLUDE_MARKERS.findall(md.read_text(encoding="utf-8")):
            yield md.relative_to(DOCS), kind, title


def test_pages_include_readme_sections_that_exist():
    """A page includes a README section by its heading: renaming a heading must fail here, by name."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    headings = set(re.findall(r"^#{1,6} +(.+?) *$", sitetools.mark_headings(readme), flags=re.M))
    found = list(_include_markers())
    assert {page.as_posix() for page, _, _ in found} >= {"index.md", "getting_started.md"}
    for page, kind, title in found:
        assert title in headings, f"docs/{page} includes the README section {title!r}, which README.md lacks"


def test_mark_headings_brackets_each_heading_outside_code():
    text = "# A\ntext\n```bash\n# not a heading\n```\n### A b\n"
    marked = sitetools.mark_headings(text)
    assert marked.split("\n") == ["<!-- before: A -->", "# A", "<!-- after: A -->", "text", "```bash",
                                  "# not a heading", "```", "<!-- before: A b -->", "### A b", "<!-- after: A b -->",
                                  ""]


def test_escape_bars_touches_prose_only():
    lines = ["exp(-2 |k| zR), |phi_hat(k)|^2", "``|k|`` and :math:`|k|`", "| a | b |", "+---+---+",
             "Example::", "", "    |x| stays", "after |y|", ".. math::", "", "   |z|"]
    assert sitetools.escape_bars(lines) == [
        r"exp(-2 \|k\| zR), \|phi_hat(k)\|^2", "``|k|`` and :math:`|k|`", "| a | b |", "+---+---+",
        "Example::", "", "    |x| stays", r"after \|y\|", ".. math::", "", "   |z|"]


def test_every_markdown_note_has_a_place_in_the_site():
    """docs/*.md are pages of their own: the guide's or a physics note (listed by conf.py)."""
    conf = (DOCS / "conf.py").read_text(encoding="utf-8")
    assert "PHYSICS_NOTES = sorted(p.stem for p in DOCS.glob(\"*.md\")" in conf
    for page in ("index", "getting_started", "changelog", "physics/index", "guide/index", "reproductions/index"):
        assert (DOCS / f"{page}.md").is_file(), page


# ---------------------------------------------------------------------------------------------
# release hygiene
# ---------------------------------------------------------------------------------------------
def test_version_is_set_in_one_place():
    project = PYPROJECT["project"]
    assert "version" not in project and "version" in project["dynamic"]
    assert PYPROJECT["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "cwlidar_sim._version.__version__"}
    assert re.fullmatch(r"\d+\.\d+\.\d+([ab]\d+|rc\d+|\.dev\d+|\.post\d+)?", cwlidar_sim.__version__)
    try:
        installed = importlib.metadata.version("cwlidar_sim")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("cwlidar_sim is not installed (pip install -e .)")
    assert installed == cwlidar_sim.__version__, "installed metadata differs from __version__: reinstall"


def test_license_and_citation_match_the_declared_license():
    assert PYPROJECT["project"]["license"] == "MIT"
    assert "LICENSE" in PYPROJECT["project"]["license-files"]
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License") and "Permission is hereby granted, free of charge" in text
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["cff-version"].startswith("1.2") and cff["license"] == "MIT" and cff["authors"]
    assert cff["title"].startswith("cwlidar_sim")
    # the version is not repeated here (one place); the references are the two reproduced papers
    assert "version" not in cff
    assert any("10.1063/1.3697728" == r.get("doi") for r in cff["references"])


def test_changelog_has_an_entry_for_this_version():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert text.startswith("# Changelog")
    assert "## Unreleased" in text or f"## {cwlidar_sim.__version__}" in text


def test_every_data_file_of_the_package_ships_in_the_wheel():
    """A file under cwlidar_sim/ that is not Python must match the package-data globs, or the wheel
    would lack it (CI also installs the wheel and runs from it)."""
    patterns = PYPROJECT["tool"]["setuptools"]["package-data"]
    pkg_root = ROOT / "cwlidar_sim"
    data = [p for p in pkg_root.rglob("*") if p.is_file() and p.suffix not in (".py", ".pyc", ".nbi", ".nbc")
            and "__pycache__" not in p.parts]
    assert data, "no package data found"
    for path in data:
        rel = path.relative_to(ROOT).as_posix()
        ok = any(rel.startswith(pkg.replace(".", "/") + "/")
                 and any(fnmatch.fnmatch(rel[len(pkg) + 1:], g) for g in globs)
                 for pkg, globs in patterns.items())
        assert ok, f"{rel} is not in [tool.setuptools.package-data]: the wheel would not ship it"


def test_no_examples_outside_the_package():
    """The campaign examples ship with the package (cwlidar-sim scenes lists them); a top-level
    examples/ folder would not be in the wheel."""
    stray = sorted(os.path.relpath(p, ROOT) for p in (ROOT / "examples").glob("*.toml")) if (ROOT / "examples").is_dir() else []
    assert not stray, f"{stray}: move them to cwlidar_sim/campaign/data/examples/ (package data)"


def _mini_site(tmp_path, body: str):
    """A one-page Sphinx project with the site's cross-reference rules (docs/_ext/xref.py, nitpicky)."""
    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text(
        "import sys\n"
        f"sys.path.insert(0, {str(ROOT / 'docs' / '_ext')!r}); sys.path.insert(0, {str(ROOT)!r})\n"
        "extensions = ['xref']\nnitpicky = True\n", encoding="utf-8")
    (src / "index.rst").write_text(
        "Mini\n====\n\n.. py:function:: cwlidar_sim.signal.run_chain\n\n" + body + "\n", encoding="utf-8")
    return src


@pytest.mark.parametrize("ref, dead", [
    (":func:`cwlidar_sim.signal.chain.run_chain`", False),   # defined there, documented at the re-export
    (":func:`cwlidar_sim.signal.run_chain`", False),
    (":func:`cwlidar_sim.signal.chain.no_such_function`", True),
    (":func:`cwlidar_sim.sensors.simulate_conical_period`", True),  # the dead link the guide had
])
def test_nitpicky_build_fails_on_a_dead_reference_only(tmp_path, ref, dead):
    """The docs build is nitpicky (-n -W): a dead cross-reference fails it; a reference through the
    defining module's path resolves to where the reference documents the object."""
    pytest.importorskip("sphinx")
    src = _mini_site(tmp_path, "See " + ref + ".")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-n", "-W", "-q", "-b", "html", str(src),
                           str(tmp_path / "out")], capture_output=True, text=True, timeout=300)
    assert (proc.returncode != 0) == dead, proc.stderr[-3000:]
    if dead:
        assert "reference target not found" in proc.stderr, proc.stderr[-3000:]


def test_the_site_is_built_nitpicky():
    """conf.py sets nitpicky, and the README's and CI's docs commands pass -n -W."""
    conf = (ROOT / "docs" / "conf.py").read_text(encoding="utf-8")
    assert re.search(r"^nitpicky = True$", conf, re.M)
    for f in ("README.md", ".ci/run"):
        assert "sphinx -n -W -b html docs docs/_build/html" in (ROOT / f).read_text(encoding="utf-8"), f
