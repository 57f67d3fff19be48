"""The TOML examples in the package's docstrings are files the package reads: every whole scene parses, every
campaign file too (an example that has gone stale fails here, as the conical units' one did: its
``[scan] tier`` and ``lidar`` keys had moved to ``[lidar]``)."""

import ast
import pathlib
import re
import textwrap

import pytest

from cwlidar_sim.campaign import loads_scene
from cwlidar_sim.campaign.execution.sweep import loads_campaign

PACKAGE = pathlib.Path(__file__).resolve().parents[2] / "cwlidar_sim"


def toml_examples():
    """(module path, TOML text) of every ``.. code-block:: toml`` in a docstring of the package."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef)):
                continue
            doc = ast.get_docstring(node) or ""
            for block in doc.split(".. code-block:: toml")[1:]:
                body = []
                for line in block.split("\n")[1:]:
                    if line.strip() and not line.startswith("    "):
                        break
                    body.append(line)
                out.append((str(path.relative_to(PACKAGE)), textwrap.dedent("\n".join(body))))
    return out


EXAMPLES = toml_examples()


def test_every_scene_kind_documents_a_whole_scene():
    """The collector finds them: each kind's scene module holds one whole example (written once, not copied)."""
    where = sorted(w for w, text in EXAMPLES if "[[period]]" in text)
    assert where == ["campaign/scenes/conical.py", "campaign/scenes/nacelle.py", "campaign/scenes/spinner.py",
                     "campaign/scenes/staring.py", "campaign/scenes/windscanner.py"]


@pytest.mark.parametrize("where,text", [e for e in EXAMPLES if "[[period]]" in e[1]], ids=lambda v: str(v)[:40])
def test_every_scene_example_parses(where, text):
    loads_scene(text)


@pytest.mark.parametrize("where,text", [e for e in EXAMPLES if re.search(r"^base\s*=", e[1], re.M)], ids=lambda v: str(v)[:40])
def test_every_campaign_example_parses(where, text):
    loads_campaign(text, base_dir=".")
