"""The package's structure, measured from its source with the standard library alone.

``python scripts/structure.py`` reads every module of ``src/prehension`` with :mod:`ast`
(nothing of the package is imported or run) and prints:

* **import cycles**: every ``import`` / ``from ... import`` statement counts, at module
  level or inside a function, except a package's ``__init__`` importing its own children;
  an edge goes to the most specific module the statement names (``from .a import b`` is an
  edge to ``a.b`` when ``b`` is a submodule, else to ``a``).  A cycle is a strongly
  connected component of more than one module (Tarjan).
* **region-kind dispatch**: the modules that call ``isinstance`` on a region kind
  (``BezierRegion``, ``SphereCap``, ``PointRegion``).
* **layers**: every module belongs to one layer of :data:`LAYERS` (bottom first; the
  longest matching prefix decides, so ``verification.residuals`` sits below
  ``verification.claims``), and no import goes to a higher layer.  The layers are
  described in ``docs/architecture.md``; a module no layer names is reported.
* **long modules** (over ``--max-module-lines`` lines) and **long functions** (over
  ``--max-function-lines`` lines or ``--max-parameters`` parameters), numba kernels
  (functions decorated with ``njit``/``jit``) excepted.

``--check`` exits 1 when the limits are exceeded: no cycle at all, no upward import and no
module outside the layers, region-kind
``isinstance`` in at most ``--max-dispatch-modules`` modules, and the line and parameter
limits.  Without ``--check`` it only reports.
"""

from __future__ import annotations

import argparse
import ast
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent / "src" / "prehension"
PACKAGE = "prehension"
REGION_KINDS = frozenset({"BezierRegion", "SphereCap", "PointRegion"})
KERNEL_DECORATORS = frozenset({"njit", "jit", "vectorize", "guvectorize"})

#: The layers of docs/architecture.md, bottom first: module-name prefixes under the package.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "frozen", "deadline", "atomic", "disk_cache", "lp", "kernels", "paper", "_aot_build", "_dask_plugins",
     "mujoco_log"),
    ("geometry",),
    ("hands", "objects", "tasks.model", "tasks.locate"),
    ("tasks",),
    ("verification.residuals", "verification"),
    ("results",),
    ("system",),
    ("quality", "sim", "pregrasp", "tessellation", "ascent"),
    ("solvers",),
    ("solve", "best", "hold", "batch_extras", "region_closure"),
    ("parallel", "batch", "assignment"),
    ("planning",),
    ("verification.claims", "viewer", "interop", "cli"),
)


@dataclass
class Module:
    """One source file: its dotted name, whether it is a package's ``__init__``, its tree."""

    name: str
    path: Path
    is_package: bool
    tree: ast.Module
    lines: int
    imports: set[str] = field(default_factory=set)


def read_modules(root: Path = ROOT) -> dict[str, Module]:
    """Every ``.py`` file under ``root``, parsed, by dotted module name."""
    modules = {}
    for path in sorted(root.rglob("*.py")):
        parts = (PACKAGE,) + path.relative_to(root).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        name = ".".join(parts[:-1] if is_package else parts)
        text = path.read_text(encoding="utf-8")
        modules[name] = Module(name, path, is_package, ast.parse(text, str(path)), text.count("\n") + 1)
    return modules


def _base(module: Module, node: ast.ImportFrom) -> str:
    """The absolute dotted name a ``from X import ...`` statement starts from."""
    if node.level == 0:
        return node.module or ""
    package = module.name if module.is_package else module.name.rpartition(".")[0]
    for _ in range(node.level - 1):
        package = package.rpartition(".")[0]
    return f"{package}.{node.module}" if node.module else package


def _targets(module: Module, node: ast.AST, known: set[str]) -> set[str]:
    """The project modules one import statement names (most specific known module)."""
    names: list[str] = []
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    elif isinstance(node, ast.ImportFrom):
        base = _base(module, node)
        names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in known else base for alias in node.names]
    out = set()
    for name in names:
        while name and name not in known:
            name = name.rpartition(".")[0]
        if name:
            out.add(name)
    return out


def resolve_imports(modules: dict[str, Module]) -> None:
    """Fill each module's ``imports`` (a package's ``__init__`` importing its children excepted)."""
    known = set(modules)
    for module in modules.values():
        for node in ast.walk(module.tree):
            for target in _targets(module, node, known):
                child_of_package = module.is_package and target.startswith(module.name + ".")
                if target != module.name and not child_of_package:
                    module.imports.add(target)


def cycles(modules: dict[str, Module]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for start in sorted(modules):
        if start in index:
            continue
        work = [(start, iter(sorted(modules[start].imports)))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(modules[child].imports))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def layer_of(name: str) -> int | None:
    """The layer (index into :data:`LAYERS`) of a module: its longest matching prefix;
    ``None`` when no layer names it.  The package's ``__init__`` (the public facade, which
    loads its names lazily) belongs to the top layer."""
    if name == PACKAGE:
        return len(LAYERS) - 1
    rel = name[len(PACKAGE) + 1:]
    best: tuple[int, int] | None = None
    for i, prefixes in enumerate(LAYERS):
        for prefix in prefixes:
            if (rel == prefix or rel.startswith(prefix + ".")) and (best is None or len(prefix) > best[1]):
                best = (i, len(prefix))
    return None if best is None else best[0]


def upward_imports(modules: dict[str, Module]) -> tuple[list[tuple[str, str]], list[str]]:
    """``(imports from a lower layer to a higher one, modules no layer names)``."""
    upward, unplaced = [], sorted(n for n in modules if layer_of(n) is None)
    for name, module in sorted(modules.items()):
        here = layer_of(name)
        for target in sorted(module.imports):
            there = layer_of(target)
            if here is not None and there is not None and there > here:
                upward.append((name, target))
    return upward, unplaced


def _isinstance_kinds(node: ast.Call) -> set[str]:
    """Region kinds named in an ``isinstance(x, K)`` or ``isinstance(x, (K1, K2))`` call."""
    if not (isinstance(node.func, ast.Name) and node.func.id == "isinstance" and len(node.args) == 2):
        return set()
    kinds = node.args[1].elts if isinstance(node.args[1], ast.Tuple) else [node.args[1]]
    names = {k.id if isinstance(k, ast.Name) else getattr(k, "attr", "") for k in kinds}
    return names & REGION_KINDS


def dispatch_modules(modules: dict[str, Module]) -> dict[str, int]:
    """Module -> number of ``isinstance`` calls on a region kind (modules with at least one)."""
    counts = {}
    for module in modules.values():
        n = sum(bool(_isinstance_kinds(node)) for node in ast.walk(module.tree) if isinstance(node, ast.Call))
        if n:
            counts[module.name] = n
    return counts


def _is_kernel(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    for decorator in node.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.id if isinstance(target, ast.Name) else getattr(target, "attr", "")
        if name in KERNEL_DECORATORS:
            return True
    return False


def functions(modules: dict[str, Module]):
    """``(module, qualified-ish name, lines, parameters)`` of every function but numba kernels."""
    for module in modules.values():
        for node in ast.walk(module.tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _is_kernel(node):
                a = node.args
                params = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs)
                params -= bool(a.args) and a.args[0].arg in ("self", "cls")
                yield module.name, node.name, node.end_lineno - node.lineno + 1, params


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 when a limit is exceeded")
    parser.add_argument("--max-module-lines", type=int, default=600)
    parser.add_argument("--max-function-lines", type=int, default=60)
    parser.add_argument("--max-parameters", type=int, default=8)
    parser.add_argument("--max-dispatch-modules", type=int, default=7)
    args = parser.parse_args(argv)

    modules = read_modules()
    resolve_imports(modules)
    found = cycles(modules)
    dispatch = dispatch_modules(modules)
    upward, unplaced = upward_imports(modules)
    long_modules = sorted((m.lines, m.name) for m in modules.values() if m.lines > args.max_module_lines)
    long_functions = sorted(
        (f for f in functions(modules) if f[2] > args.max_function_lines or f[3] > args.max_parameters),
        key=lambda f: (f[0], f[1]),
    )
    n_imports = sum(len(m.imports) for m in modules.values())
    print(f"{len(modules)} modules, {n_imports} project import edges")
    print(f"import cycles: {len(found)} ({sum(map(len, found))} modules)")
    for component in found:
        print("  " + " <-> ".join(component))
    print(f"imports to a higher layer: {len(upward)}; modules outside the layers: {len(unplaced)}")
    for name, target in upward:
        print(f"  {name} -> {target} (layer {layer_of(name)} -> {layer_of(target)})")
    for name in unplaced:
        print(f"  {name}: in no layer (scripts/structure.py LAYERS)")
    print(f"region-kind isinstance: {sum(dispatch.values())} calls in {len(dispatch)} modules "
          f"(limit {args.max_dispatch_modules} modules)")  # fmt: skip
    for name, n in sorted(dispatch.items()):
        print(f"  {name}: {n}")
    print(f"modules over {args.max_module_lines} lines: {len(long_modules)}")
    for lines, name in long_modules:
        print(f"  {name}: {lines}")
    print(f"functions over {args.max_function_lines} lines or {args.max_parameters} parameters "
          f"(numba kernels excepted): {len(long_functions)}")  # fmt: skip
    for module, name, lines, params in long_functions:
        print(f"  {module}.{name}: {lines} lines, {params} parameters")
    failed = found or upward or unplaced or len(dispatch) > args.max_dispatch_modules or long_modules or long_functions
    return 1 if args.check and failed else 0


if __name__ == "__main__":
    sys.exit(main())
