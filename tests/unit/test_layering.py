"""The package's layering, read off the source: the core imports nothing above it, no module
imports another package's private names, names are taken from the module that defines them, and the
core is a strict stack without import cycles.

The core's stack, lowest first (:data:`STACK`); each layer imports only from the layers below it:

* ``yamlfile``: the YAML reader (errors only);
* ``hookspecs``, ``registry``: the plugin hook specs and the plugin manager (pluggy only; the
  running simulation process and the pseudo-experiments ask the registry for their backend);
* ``sheartest``: the shear test: spec, presets, stages, physics, peaks, result, yield locus;
* ``simulator``: the Simulator interface (spec in, result out);
* ``data``: experiments, features, the cell pin, pseudo-experiments (and
  ``EXPERIMENT_SEED_BASE``, above which their seeds lie);
* ``search``: parameters, metrics, the point records, Kriging models, acquisitions, the answer;
  it takes plain arguments, not a campaign's config, and knows nothing of the store;
* ``running``: executors, the isolated simulation process, the scheduler, the store;
* ``fidelities``: a multi-fidelity campaign's presets and the fidelity plan (it takes the Sobol
  design and the records from ``search``);
* ``resolved``: the resolved config's added fields (the search hash and warm start read them);
* ``warm_start``: a new store from an earlier campaign's;
* ``config``: the campaign config, parsed and checked;
* ``studies``: the campaign, crosschecks, convergence studies.

Every import counts, at module level or inside a function, except those under ``if
TYPE_CHECKING:`` (they never run: a lower module may name a higher one's type in annotations).
The only other exceptions are the lazy imports of :data:`LAZY_IMPORTS`, each with its reason; no
file inside the core imports another that imports it back (:data:`PENDING_CYCLES` lists the one
left, with why).
"""

from __future__ import annotations

import ast
import sys
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


#: the core's subpackages and top-level modules, lowest first: each imports only from those before it
STACK = ["yamlfile", "options", "hookspecs", "registry", "sheartest", "simulator", "data", "search", "running", "fidelities",
         "resolved", "warm_start", "config", "studies"]
#: (importer, imported) lazy imports allowed against the stack or into a cycle, with the reason:
#: only to keep torch, gpytorch, botorch or numba out of a simulation's process. None is needed
#: today: the lazy imports that do so (search/models.py's builders of the torch models,
#: surrogate.py's fidelity kernel, answer.py's Sobol design) all point down the stack
LAZY_IMPORTS: dict[tuple[str, str], str] = {}
#: file-level cycles not broken yet, with the reason
PENDING_CYCLES: dict[tuple[str, str], str] = {}


def _module_name(path: Path, src: Path) -> str:
    parts = path.relative_to(src).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _type_checking_lines(tree: ast.AST) -> set[int]:
    """Line numbers of the imports under ``if TYPE_CHECKING:`` (annotations only: they never run)."""
    lines = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            lines |= {n.lineno for stmt in node.body for n in ast.walk(stmt)
                      if isinstance(n, (ast.Import, ast.ImportFrom))}
    return lines


def import_graph(root: Path = ROOT, package: str = "calibrax.core") -> dict[str, set[str]]:
    """{module: modules of ``package`` it imports} of every file of ``package`` under ``root``/src,
    imports inside functions included, those under ``if TYPE_CHECKING:`` left out. ``from p
    import x`` imports the module ``p.x`` when there is one, else ``p``."""
    src = root / "src"
    folder = src.joinpath(*package.split("."))
    modules = {_module_name(path, src): path for path in sorted(folder.rglob("*.py"))}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        typing_only = _type_checking_lines(ast.parse(path.read_text(encoding="utf-8")))
        targets = set()
        for module, names, line in _imports(path, root):
            if line in typing_only:
                continue
            for target in [f"{module}.{n}" for n in names if f"{module}.{n}" in modules] or [module]:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target and target != name and target != package:
                    targets.add(target)
        graph[name] = targets
    return graph


def _layer(module: str, package: str = "calibrax.core") -> str:
    return module[len(package) + 1:].split(".")[0]


def upward_imports(graph: dict[str, set[str]], stack: list[str], package: str = "calibrax.core",
                   allowed=LAZY_IMPORTS) -> list[str]:
    """Every import of a layer by one at or below it in ``stack`` (lowest first), and every module
    whose layer is missing from ``stack``."""
    found = []
    for module, targets in sorted(graph.items()):
        if module == package:
            continue
        if _layer(module, package) not in stack:
            found.append(f"{module}: layer {_layer(module, package)!r} is not in the stack")
            continue
        for target in sorted(t for t in targets if _layer(t, package) in stack):
            low, high = stack.index(_layer(target, package)), stack.index(_layer(module, package))
            if low > high and (module, target) not in allowed:
                found.append(f"{module} ({stack[high]}) imports {target} ({stack[low]})")
    return found


def import_cycles(graph: dict[str, set[str]], allowed=()) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), edges in ``allowed`` left out."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if (v, w) in allowed or w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(graph) + 100))
    try:
        for v in sorted(graph):
            if v not in index:
                visit(v)
    finally:
        sys.setrecursionlimit(limit)
    return cycles


def test_the_core_is_a_strict_stack():
    """Each of the core's subpackages and top-level modules imports only from those below it."""
    found = upward_imports(import_graph(), STACK)
    assert not found, "imports against the core's stack (tests/unit/test_layering.py STACK):\n" + "\n".join(found)
    layers = {_layer(m) for m in import_graph() if m != "calibrax.core"}
    assert layers == set(STACK), f"the stack lists what the core does not have: {sorted(set(STACK) - layers)}"


def test_no_file_of_the_core_imports_one_that_imports_it_back():
    cycles = import_cycles(import_graph(), {*LAZY_IMPORTS, *PENDING_CYCLES})
    assert not cycles, "import cycles in the core:\n" + "\n".join(" <-> ".join(c) for c in cycles)


def test_the_allowed_exceptions_are_still_needed():
    """Every listed lazy import and pending cycle still exists (a stale entry would hide a new one)."""
    graph = import_graph()
    stale = [f"{a} -> {b}" for a, b in [*LAZY_IMPORTS, *PENDING_CYCLES] if b not in graph.get(a, ())]
    assert not stale, "exceptions the code no longer needs:\n" + "\n".join(stale)


def test_the_cycle_checks_see_a_cycle_and_an_upward_import(tmp_path):
    """The checks themselves can fail: in a mini-package, a cycle through an import inside a
    function is found, and so is an import against the stack; one under TYPE_CHECKING is not an edge."""
    pkg = tmp_path / "src" / "mini"
    for sub in ("low", "high"):
        (pkg / sub).mkdir(parents=True)
        (pkg / sub / "__init__.py").write_text("")
    (pkg / "__init__.py").write_text("")
    (pkg / "low" / "a.py").write_text("def f():\n    from mini.high.b import g\n    return g\n")
    (pkg / "high" / "b.py").write_text("from .c import h\n\ndef g():\n    return h\n")
    (pkg / "high" / "c.py").write_text("from mini.low import a\n\nh = a\n")
    (pkg / "high" / "d.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                       "    from mini.high.e import E\n")
    (pkg / "high" / "e.py").write_text("from mini.high import d\nE = d\n")
    graph = import_graph(tmp_path, "mini")
    assert graph["mini.low.a"] == {"mini.high.b"} and graph["mini.high.c"] == {"mini.low.a"}
    assert graph["mini.high.d"] == set()
    assert import_cycles(graph) == [["mini.high.b", "mini.high.c", "mini.low.a"]]
    assert import_cycles(graph, {("mini.low.a", "mini.high.b")}) == []
    assert upward_imports(graph, ["low", "high"], "mini") == ["mini.low.a (low) imports mini.high.b (high)"]
    assert upward_imports(graph, ["high", "low"], "mini") == ["mini.high.c (high) imports mini.low.a (low)"]
    assert upward_imports(graph, ["low"], "mini") == [f"mini.high{m}: layer 'high' is not in the stack"
                                                      for m in ("", ".b", ".c", ".d", ".e")]


def test_the_names_check_sees_a_name_passed_on(tmp_path):
    """A name taken through a module that only imports it is found; one it defines, a submodule
    and a package's ``__init__`` (outside the core) are not."""
    src = tmp_path / "src" / "calibrax"
    (src / "core").mkdir(parents=True)
    (src / "__init__.py").write_text("from calibrax.core.low import X\n")
    (src / "core" / "__init__.py").write_text("")
    (src / "core" / "low.py").write_text("X = 1\n")
    (src / "core" / "mid.py").write_text("from calibrax.core.low import X\nY = X\n")
    user = tmp_path / "user.py"
    user.write_text("from calibrax.core.mid import X, Y\nfrom calibrax.core import low\nfrom calibrax import X\n")
    assert names_taken_through_another_module([user], tmp_path) == ["user.py:1 takes X through calibrax.core.mid"]


def _defined_names(path: Path) -> set[str]:
    """The names a module defines at its top level (not the ones it imports)."""
    names = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif not isinstance(node, (ast.Import, ast.ImportFrom)):
            names |= {n.id for n in ast.walk(node) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)}
            names |= {n.name for n in ast.walk(node) if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    return names


def names_taken_through_another_module(files: list[Path], root: Path = ROOT, core_too: bool = True) -> list[str]:
    """``from calibrax.x import name`` where ``calibrax.x`` neither defines ``name`` nor has it as a
    submodule: a name passed on by a module that does not define it. A package's ``__init__``
    (the public API) may pass names on, except to the core's own modules (``core_too``)."""
    src = root / "src"
    modules = {_module_name(p, src): p for p in (src / "calibrax").rglob("*.py")}
    found = []
    for path in files:
        in_core = CORE in path.parents
        try:
            imports = _imports(path, root) if src in path.parents else _imports_absolute(path)
        except SyntaxError:
            continue
        for module, names, line in imports:
            if module not in modules or (modules[module].name == "__init__.py" and not (core_too and in_core)):
                continue
            defined = _defined_names(modules[module])
            passed = [n for n in names if n != "*" and n not in defined and f"{module}.{n}" not in modules]
            if passed:
                found.append(f"{path.relative_to(root)}:{line} takes {', '.join(passed)} through {module}")
    return found


def _imports_absolute(path: Path) -> list[tuple[str, list[str], int]]:
    return [(node.module or "", [a.name for a in node.names], node.lineno)
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(node, ast.ImportFrom) and not node.level]


def test_names_are_taken_from_the_module_that_defines_them():
    """No module takes a calibrax name through a module that only passes it on (such as
    studies/campaign.py did for ten names); the core does not even go through a package's
    ``__init__`` or the calibrax package."""
    files = [path for folder in ("src", "tests", "benchmarks", "examples")
             for path in sorted((ROOT / folder).rglob("*.py"))]
    found = names_taken_through_another_module(files)
    assert not found, "names passed on by a module that does not define them:\n" + "\n".join(found)
