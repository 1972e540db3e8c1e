"""The layers import one way: engine (warpdem) <- scenes <- calibration (README, "Layout"). Checked on the
source, so a lazy import inside a function counts too. And the engine's functions stay under 100 lines."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = {"warpdem": {"scenes", "calibration"}, "scenes": {"calibration"}}


def _imported_packages(path: Path) -> set[str]:
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module.split(".")[0])
    return found


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_a_lower_layer_imports_no_upper_one(package: str) -> None:
    bad = {str(p.relative_to(ROOT)): sorted(_imported_packages(p) & FORBIDDEN[package])
           for p in sorted((ROOT / package).rglob("*.py"))}
    assert {k: v for k, v in bad.items() if v} == {}


def test_no_engine_function_is_longer_than_a_hundred_lines() -> None:
    """The engine's functions stay readable in one screen or two (issue #40's bound: none over 100 lines in warpdem/,
    kernels included), counted from the def to the last line of the body on the source."""
    long = []
    for path in sorted((ROOT / "warpdem").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > 100:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    assert not long, long
