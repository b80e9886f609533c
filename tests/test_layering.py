"""The shape of the code, read from its source: imports point down, nobody imports another module's private
names, experiments/ has no circles and imports at the top, benchmarks are modules, and the kernel's formulas
are not copied back into the packages."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("subsumption", "subsim", "navigation", "vision", "terminal", "robots", "experiments", "bench")


def _sources(*folders: str) -> list[Path]:
    return sorted(p for folder in folders for p in (ROOT / folder).rglob("*.py") if ".venv" not in p.parts)


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), str(path))


def test_nobody_imports_another_modules_private_names():
    found = [f"{p.relative_to(ROOT)}:{node.lineno}: {alias.name} from {node.module or '.'}"
             for p in _sources(*PACKAGES, "tests") for node in ast.walk(_tree(p))
             if isinstance(node, ast.ImportFrom) and node.module != "__future__"
             for alias in node.names if alias.name.startswith("_")]
    assert found == []


def _experiments_graph() -> dict[str, set[str]]:
    modules = {p.stem for p in (ROOT / "experiments").glob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for m in modules:
        for node in ast.walk(_tree(ROOT / "experiments" / f"{m}.py")):
            if isinstance(node, ast.ImportFrom):
                name = node.module or ""
                if node.level == 1:
                    targets = [name.split(".")[0]] if name else [a.name for a in node.names]
                elif name.startswith("experiments."):
                    targets = [name.split(".")[1]]
                else:
                    continue
                graph[m].update(t for t in targets if t in modules)
    return graph


def test_experiments_has_no_import_circles():
    graph, done, path = _experiments_graph(), set(), []

    def visit(module: str) -> None:
        assert module not in path, f"import circle: {' -> '.join(path[path.index(module):] + [module])}"
        if module in done:
            return
        path.append(module)
        for imported in sorted(graph[module]):
            visit(imported)
        path.pop()
        done.add(module)

    for module in sorted(graph):
        visit(module)


def test_experiments_import_at_the_top():
    inside = [f"{p.relative_to(ROOT)}:{sub.lineno}" for p in _sources("experiments") for node in ast.walk(_tree(p))
              if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
              for sub in ast.walk(node) if isinstance(sub, (ast.Import, ast.ImportFrom))]
    assert inside == []


def test_benchmarks_are_modules_of_the_bench_package():
    assert (ROOT / "bench" / "__init__.py").is_file()
    scripts = [p.name for p in (ROOT / "bench").iterdir() if p.is_file() and p.suffix != ".py"]
    assert scripts == [], "a benchmark is bench/NAME.py, run as python -m bench.NAME"
    patched = [str(p.relative_to(ROOT)) for p in _sources("bench", "experiments") if "sys.path.insert" in p.read_text()]
    assert patched == []


@pytest.mark.parametrize("pattern, what", [
    (r"atan2\(\s*2(\.0)?\s*\*\s*\(\s*q\.w", "the yaw formula (subsumption.planar.yaw_of)"),
    (r"^def (wrap|quaternion|quaternion_of|yaw_quaternion)\(", "wrap / quaternion (subsumption.planar)"),
    (r"^class Pinhole\b", "a pinhole model (subsumption.pinhole.Pinhole)"),
    (r"^class \w+Error\(ValueError\):\n\s+\"\"\"A (world|map) file", "a bad-file error (subsumption.InputFileError)"),
])
def test_the_kernels_formulas_are_not_copied(pattern, what):
    kernel = {ROOT / "subsumption" / "planar.py", ROOT / "subsumption" / "pinhole.py"}
    copies = [str(p.relative_to(ROOT)) for p in _sources(*PACKAGES) if p not in kernel
              and re.search(pattern, p.read_text(), re.MULTILINE)]
    assert copies == [], f"{what} copied"
