"""The package's layering, read off the source: the core imports nothing above it, and no module
imports another package's private names."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CORE = ROOT / "src" / "calibrax" / "core"
#: what sits above the core: the builtin plugins, the diagnosis, the report, the CLI, the backends
ABOVE_CORE = ("calibrax.plugins", "calibrax.diagnosis", "calibrax.report", "calibrax.cli", "calibrax_")


def _imports(path: Path, root: Path = ROOT) -> list[tuple[str, list[str], int]]:
    """(module, imported names, line) of every import in ``path`` (a file under ``root``/src),
    relative ones made absolute."""
    package = ".".join(path.relative_to(root / "src").with_suffix("").parts[:-1])
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.extend((alias.name, [], node.lineno) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join([*base, module] if module else base)
            out.append((module, [alias.name for alias in node.names], node.lineno))
    return out


def test_the_core_imports_nothing_above_it():
    found = [f"{path.relative_to(ROOT)}:{line} imports {module}"
             for path in sorted(CORE.rglob("*.py")) for module, _, line in _imports(path)
             if module.startswith(ABOVE_CORE)]
    assert not found, "the core reaches above itself:\n" + "\n".join(found)


def test_no_module_imports_another_modules_private_names():
    found = []
    for path in sorted((ROOT / "src").rglob("*.py")):
        for module, names, line in _imports(path):
            private = [n for n in names if n.startswith("_") and not n.startswith("__")]
            if module.startswith("calibrax") and private:
                found.append(f"{path.relative_to(ROOT)}:{line} imports {', '.join(private)} from {module}")
    assert not found, "private names used across modules:\n" + "\n".join(found)


def test_the_layering_check_sees_an_upward_import(tmp_path):
    """The check itself can fail: a core module importing the builtin plugins, absolutely or
    relatively, is found."""
    core = tmp_path / "src" / "calibrax" / "core"
    core.mkdir(parents=True)
    (core / "bad.py").write_text("from calibrax.plugins.builtin.acquisitions import sobol_points\n"
                                 "from ..report import figures\nfrom .store import _private\n")
    found = _imports(core / "bad.py", tmp_path)
    assert [m for m, _, _ in found] == ["calibrax.plugins.builtin.acquisitions", "calibrax.report", "calibrax.core.store"]
    assert [m for m, _, _ in found if m.startswith(ABOVE_CORE)] == ["calibrax.plugins.builtin.acquisitions",
                                                                   "calibrax.report"]
    assert found[2][1] == ["_private"]


def test_no_module_is_over_500_lines():
    long = [f"{path.relative_to(ROOT)}: {n} lines" for path in sorted((ROOT / "src").rglob("*.py"))
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > 500]
    assert not long, "modules to split by job:\n" + "\n".join(long)

