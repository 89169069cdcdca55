"""The worlds' own scenario sections: a table the scenario reader and the table of worlds share,
light enough for the command line to read at start-up."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mirl._registry import Registry
from mirl.world.world_sections import WORLD_SECTIONS, WorldSection, _check_section
from mirl.worlds import WORLDS


def test_every_world_section_is_declared_and_a_bare_key():
    assert WORLD_SECTIONS.names == ("physics",)
    assert {w.section for w in WORLDS.values() if w.section} <= set(WORLD_SECTIONS)
    with pytest.raises(ValueError, match="not a TOML bare key"):
        Registry("world section", [WorldSection("my world", "x")], check=_check_section)


def test_the_table_imports_nothing_heavy():
    code = "import sys, mirl.world.world_sections; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
