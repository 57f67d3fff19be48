"""The dimension-letter alphabet is closed: one letter, one meaning, documented once (the package docstring).

Checked statically over the modules already cleaned (the sensors, the signal chain, the probe cells and the beam kernels):

* the table in ``cwlidar_sim.__doc__`` gives every letter once;
* every name those modules define (assigned, an argument, a field) that ends in a dimension suffix
  (``_`` and one to three letters, not one of the few words below) uses only the table's letters;
* a scalar quantity per cell, look or estimate (a line-of-sight speed, a weight, a speed, a time) has no
  component axis: ``c`` is a vector's component, so ``vlos_elc`` or ``weight_c`` naming cells fails.
"""

from __future__ import annotations

import ast
import pathlib
import re

import cwlidar_sim

ROOT = pathlib.Path(cwlidar_sim.__file__).parent
#: Modules whose array names follow the table (the others are listed in the CHANGELOG as still to clean).
CLEANED = sorted((ROOT / "sensors").glob("*.py")) + [ROOT / "signal" / "chain.py", ROOT / "beam" / "cells.py",
                                                   ROOT / "beam" / "_kernels.py"]
#: Words and units that end names without being dimension suffixes.
WORDS = {"at", "in", "to", "or", "lo", "hi", "deg", "db", "rpm", "std", "rng", "key", "gap", "out", "bg", "sim",
         "cnr", "eff", "rev", "str", "int", "fft", "rho", "cl", "hz", "mid"}
#: Stems of scalar quantities: no component axis.
SCALARS = ("vlos", "weight", "w", "speed", "time", "t", "flags", "az", "azimuth", "spread")


def table_letters() -> dict:
    lines = cwlidar_sim.__doc__.split("The letters are:")[1].splitlines()
    rules = [i for i, ln in enumerate(lines) if ln.startswith("==  ===")]
    rows = [ln for ln in lines[rules[0] + 1: rules[1]] if re.match(r"^[a-z]\s{3}\S", ln)]
    letters = {}
    for ln in rows:
        letters.setdefault(ln[0], []).append(ln[4:].strip())
    return letters


def defined_names(path: pathlib.Path):
    """``(name, line)`` of every name the module defines: targets, arguments, class fields, attributes set."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            yield node.id, node.lineno
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            yield node.attr, node.lineno
        elif isinstance(node, ast.arg):
            yield node.arg, node.lineno
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            yield node.target.id, node.lineno


def suffix(name: str):
    m = re.fullmatch(r"_?[a-z][a-z0-9]*(?:_[a-z0-9]+)*_([a-z]{1,3})", name)
    return None if m is None or m.group(1) in WORDS else m.group(1)


def test_the_table_gives_each_letter_one_meaning():
    letters = table_letters()
    assert {"c", "s", "l", "e", "t"} <= set(letters)
    assert all(len(meanings) == 1 for meanings in letters.values()), letters
    assert "cell" in letters["s"][0] and "look" in letters["l"][0] and "component" in letters["c"][0]


def test_cleaned_modules_use_only_the_tables_letters():
    allowed = set(table_letters())
    bad = []
    for path in CLEANED:
        for name, line in defined_names(path):
            suf = suffix(name)
            if suf is not None and not set(suf) <= allowed:
                bad.append(f"{path.relative_to(ROOT)}:{line} {name}")
    assert not bad, "suffix letters outside the table (cwlidar_sim/__init__.py):\n" + "\n".join(sorted(set(bad)))


def test_scalars_per_cell_or_estimate_have_no_component_axis():
    bad = []
    for path in CLEANED:
        for name, line in defined_names(path):
            suf = suffix(name)
            if suf and "c" in suf and name[: -len(suf) - 1].lstrip("_") in SCALARS:
                bad.append(f"{path.relative_to(ROOT)}:{line} {name}")
    assert not bad, "a scalar with a component axis (c is a vector's component; cells are s):\n" + "\n".join(bad)


def test_the_check_sees_the_old_names():
    # the names the alphabet replaced, as they were written in chain.py and sensors/base.py
    assert suffix("vlos_elc") == "elc" and suffix("weight_c") == "c" and suffix("cnr_db") is None
    assert "vlos" in SCALARS and "weight" in SCALARS
