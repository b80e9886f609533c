"""The documentation site builds with warnings as errors: every page of docs/ is in the navigation, every link
between pages and every anchor resolves, and the API reference is printed from the docstrings."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import yaml
from conftest import ROOT

MKDOCS = Path(sys.executable).parent / "mkdocs"


def test_the_site_builds_strict(tmp_path):
    site = tmp_path / "site"
    built = subprocess.run([str(MKDOCS), "build", "--strict", "--site-dir", str(site)], cwd=ROOT,
                           capture_output=True, text=True, timeout=240)
    assert built.returncode == 0, built.stdout + built.stderr
    api = (site / "api" / "subsumption" / "index.html").read_text()
    assert 'id="subsumption.module.Param"' in api  # the reference is made from the code
    assert "A private parameter with a default" in api  # ... with its docstrings
    assert ":class:" not in api


def test_every_page_of_docs_is_in_the_navigation():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text().replace("!!python", "python"))

    def pages(nav):
        for item in nav:
            for value in item.values():
                yield from pages(value) if isinstance(value, list) else [value]
    listed = set(pages(config["nav"]))
    on_disk = {str(path.relative_to(ROOT / "docs")) for path in (ROOT / "docs").rglob("*.md")}
    assert on_disk - listed == set(), "docs pages missing from mkdocs.yml's nav"
