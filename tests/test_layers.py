"""The import layers of inkmotion, one line each, kept by walking every module's imports.

- foundation: the top-level modules ``inkmotion.errors, json_files, settings, rng, lazy,
  events, devices, browser`` — import only the foundation.
- engines: ``sigma_lognormal, geometry, inputs, tracing, rendering, image_losses, fitting,
  clip, saliency, initialisers, images, outputs, robot, evaluation, recording, profiling,
  store, samples``
  and the top-level ``speed_extrema`` — import the foundation, the engines and
  ``inkmotion.plugin_host.protocols`` only.
- plugin host: ``inkmotion.plugin_host`` — imports the foundation (the protocols' engine
  types are ``TYPE_CHECKING`` hints).
- jobs: ``inkmotion.jobs`` — the foundation, engines, plugin host.
- kinds: ``inkmotion.kinds`` — the foundation, engines, plugin host, jobs.
- plugins: ``inkmotion.plugins`` — the foundation, engines, plugin host, jobs, kinds.
- workers: ``inkmotion.workers``, a top — anything but the CLI and the CLI's tools.
- benchmarks: ``inkmotion.benchmarks``, a tool of the CLI — anything but the CLI and
  the gallery (it may use the workers).
- gallery: ``inkmotion.gallery``, a tool of the CLI — anything but the CLI, the workers and
  the benchmarks.
- studio: ``inkmotion.studio``, a tool of the CLI — anything but the CLI, the benchmarks
  and the gallery (it runs jobs here or sends them to the workers).
- cli: ``inkmotion.cli``, the top — anything; nothing imports it.

In short, imports point down the list; the benchmarks, the gallery and the studio are
imported by the CLI only. Checked: every ``import`` and ``from … import`` in every module under
``framework/``, ``plugins/`` and ``workers/``, those inside functions included (they run
too, later), those under ``if TYPE_CHECKING:`` not (they never run). Outside the check:
``inkmotion/__init__.py`` (the package's lazy facade: it imports only ``inkmotion.lazy``
and loads its names on first use) and ``inkmotion/__main__.py`` (``python -m inkmotion``,
the CLI's door). ``import inkmotion`` (for ``__version__``) is allowed everywhere, and
``from inkmotion import NAME`` counts as an import of the module the facade loads NAME
from, and so does ``inkmotion.NAME`` used as an attribute after ``import inkmotion``.

A module whose package has no layer fails the test until it is given one here; a second
test keeps the engine packages free of import cycles. ``python tests/test_layers.py``
prints the package-level import table (from-package → to-packages; ``!`` marks an import
that breaks the layers).
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: source folder -> the dotted package it is installed as (pyproject's package-dir)
SOURCES = {"framework": "inkmotion", "plugins": "inkmotion.plugins",
           "workers": "inkmotion.workers"}
#: modules that are not checked (module docstring): the facade and ``python -m``
OUTSIDE = {"inkmotion", "inkmotion.__main__"}
PROTOCOLS = "inkmotion.plugin_host.protocols"

FOUNDATION = ("errors", "json_files", "settings", "rng", "lazy", "events", "devices",
              "browser", "portable_math", "scalar_tensors")
ENGINES = ("sigma_lognormal", "geometry", "inputs", "tracing", "rendering", "image_losses",
           "fitting", "clip", "saliency", "initialisers", "images", "outputs", "robot", "plotter",
           "evaluation", "recording", "profiling", "store", "samples", "speed_extrema")

#: layer -> (its packages under ``inkmotion.``, the layers it may import, the rule in words)
LAYERS: dict[str, tuple[tuple[str, ...], frozenset[str], str]] = {
    "foundation": (FOUNDATION, frozenset({"foundation"}),
                   "the foundation imports only the foundation"),
    "engines": (ENGINES, frozenset({"foundation", "engines"}),
                f"engines import the foundation, engines and {PROTOCOLS} only"),
    "plugin host": (("plugin_host",), frozenset({"foundation", "plugin host"}),
                    "the plugin host imports the foundation only"),
    "jobs": (("jobs",), frozenset({"foundation", "engines", "plugin host", "jobs"}),
             "jobs import the foundation, engines and the plugin host"),
    "kinds": (("kinds",), frozenset({"foundation", "engines", "plugin host", "jobs", "kinds"}),
              "kinds import the foundation, engines, plugin host and jobs"),
    "plugins": (("plugins",), frozenset({"foundation", "engines", "plugin host", "jobs",
                                         "kinds", "plugins"}),
                "plugins import the foundation, engines, plugin host, jobs and kinds"),
    "workers": (("workers",), frozenset({"foundation", "engines", "plugin host", "jobs",
                                         "kinds", "plugins", "workers"}),
                "the workers import anything but the CLI and its tools (benchmarks, gallery, "
                "studio)"),
    "benchmarks": (("benchmarks",), frozenset({"foundation", "engines", "plugin host", "jobs",
                                               "kinds", "plugins", "workers", "benchmarks"}),
                   "the benchmarks, a tool of the CLI, import anything but the CLI and the "
                   "gallery"),
    "gallery": (("gallery",), frozenset({"foundation", "engines", "plugin host", "jobs",
                                         "kinds", "plugins", "gallery"}),
                "the gallery, a tool of the CLI, imports anything but the CLI, the workers "
                "and the benchmarks"),
    "studio": (("studio",), frozenset({"foundation", "engines", "plugin host", "jobs",
                                       "kinds", "plugins", "workers", "studio"}),
               "the studio, a tool of the CLI, imports anything but the CLI, the benchmarks "
               "and the gallery"),
    "cli": (("cli",), frozenset({"foundation", "engines", "plugin host", "jobs", "kinds",
                                 "plugins", "workers", "benchmarks", "gallery", "studio",
                                 "cli"}),
            "the CLI imports anything; nothing imports it"),
}
LAYER_OF = {package: layer for layer, (packages, _, _) in LAYERS.items()
            for package in packages}


@dataclass(frozen=True)
class Import:
    """One runtime import of an inkmotion module: where it is and what it names."""

    source: str  # importing module, e.g. "inkmotion.kinds.read"
    path: str  # its file, relative to the repository, e.g. "framework/kinds/read.py"
    line: int
    target: str  # imported module, e.g. "inkmotion.plugin_host.manager"


def modules() -> dict[str, Path]:
    """Every module under the source folders, by dotted name (a package by its name)."""
    found: dict[str, Path] = {}
    for folder, package in SOURCES.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = path.relative_to(ROOT / folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join((package, *parts))] = path
    return found


def facade_names() -> dict[str, str]:
    """The facade's public names -> the module each loads from (``_PUBLIC`` in
    ``inkmotion/__init__.py``), so ``from inkmotion import plugin`` counts as an import of
    the plugin manager."""
    tree = ast.parse((ROOT / "framework" / "__init__.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            if any(isinstance(t, ast.Name) and t.id == "_PUBLIC" for t in targets):
                return ast.literal_eval(node.value)
    return {}


def _is_type_checking(test: ast.expr) -> bool:
    """``if TYPE_CHECKING:`` or ``if typing.TYPE_CHECKING:``."""
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _runtime_imports(tree: ast.AST) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement in ``tree``, at any depth, except under TYPE_CHECKING."""
    found: list[ast.Import | ast.ImportFrom] = []

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import | ast.ImportFrom):
            found.append(node)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def imports() -> list[Import]:
    """Every runtime import of an inkmotion module by a checked module."""
    known = modules()
    facade = facade_names()
    found: list[Import] = []
    for name, path in known.items():
        if name in OUTSIDE:
            continue
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        rel = str(path.relative_to(ROOT))
        for node in _runtime_imports(ast.parse(path.read_text(), filename=rel)):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = node.module or ""
                if node.level:  # relative: from the importing module's package upwards
                    up = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*up, *([base] if base else [])])
                targets = []
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    if full in known:
                        targets.append(full)
                    elif base == "inkmotion" and alias.name in facade:
                        targets.append(facade[alias.name])
                    else:
                        targets.append(base)
            found += [Import(name, rel, node.lineno, t) for t in dict.fromkeys(targets)
                      if t.split(".")[0] == "inkmotion" and t not in OUTSIDE]
        found += [Import(name, rel, line, target) for line, target in
                  _facade_uses(ast.parse(path.read_text(), filename=rel), facade)]
    return found


def _facade_uses(tree: ast.AST, facade: dict[str, str]) -> list[tuple[int, str]]:
    """``inkmotion.NAME`` in a module that imports ``inkmotion``: (line, the module the
    facade loads NAME from), so ``import inkmotion; inkmotion.plugin(...)`` counts as an
    import of the plugin manager (except under TYPE_CHECKING, as for imports)."""
    if not any(isinstance(n, ast.Import) and any(a.name == "inkmotion" and a.asname is None
                                                  for a in n.names)
               for n in _runtime_imports(tree)):
        return []
    return [(node.lineno, facade[node.attr]) for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
            and node.value.id == "inkmotion" and node.attr in facade]


def package_of(module: str) -> str:
    """The package a module counts under: ``inkmotion.X`` for anything in X (a top-level
    module being its own package)."""
    return ".".join(module.split(".")[:2])


def layer_of(module: str) -> str | None:
    """The layer of ``module`` (None for a package no layer lists)."""
    return LAYER_OF.get(module.split(".")[1]) if "." in module else None


def allowed(source: str, target: str) -> bool:
    """Whether ``source`` may import ``target`` by the layers."""
    src, dst = layer_of(source), layer_of(target)
    if src is None or dst is None:
        return False
    return dst in LAYERS[src][1] or (src == "engines" and target == PROTOCOLS)


def violations() -> list[str]:
    """One line per import that breaks the layers: file:line, from-layer → to-layer,
    what is imported, the rule."""
    lines = []
    for imp in imports():
        if allowed(imp.source, imp.target):
            continue
        src, dst = layer_of(imp.source), layer_of(imp.target)
        if src is None or dst is None:
            rule = (f"{package_of(imp.source if src is None else imp.target)} has no layer: "
                    "add it to LAYERS in tests/test_layers.py")
        else:
            rule = LAYERS[src][2]
        lines.append(f"{imp.path}:{imp.line}: {src} → {dst} ({imp.target}): {rule}")
    return lines


def test_every_package_has_a_layer() -> None:
    unplaced = sorted({package_of(m) for m in modules() if m not in OUTSIDE
                       and layer_of(m) is None})
    assert not unplaced, f"packages with no layer (add them to LAYERS): {unplaced}"


def test_imports_keep_the_layers() -> None:
    found = violations()
    assert not found, f"{len(found)} imports break the layers:\n" + "\n".join(found)


def engine_graph() -> dict[str, dict[str, Import]]:
    """The runtime imports between engine packages: package -> package -> one import
    that makes the edge (the first found, to name it)."""
    graph: dict[str, dict[str, Import]] = defaultdict(dict)
    for imp in imports():
        src, dst = package_of(imp.source), package_of(imp.target)
        if src != dst and layer_of(imp.source) == layer_of(imp.target) == "engines":
            graph[src].setdefault(dst, imp)
    return graph


def cycles(graph: dict[str, dict[str, Import]]) -> list[list[str]]:
    """One cycle (its packages, the first repeated at the end) per strongly connected
    component of more than one package (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[set[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(component)

    for v in sorted(graph):
        if v not in index:
            connect(v)
    found = []
    for component in components:  # a path back to the start within the component
        start = min(component)
        path, seen = [start], {start}
        while True:
            here = path[-1]
            nexts = sorted(w for w in graph[here] if w in component)
            if start in nexts and len(path) > 1:
                found.append([*path, start])
                break
            step = next((w for w in nexts if w not in seen), None)
            if step is None:  # dead end inside the component: back up
                path.pop()
                if not path:
                    break
                continue
            path.append(step)
            seen.add(step)
    return found


def test_no_import_cycle_between_engine_packages() -> None:
    graph = engine_graph()
    named = []
    for cycle in cycles(graph):
        edges = [graph[a][b] for a, b in zip(cycle, cycle[1:], strict=False)]
        named.append(" → ".join(cycle) + ": " + "; ".join(
            f"{e.path}:{e.line} imports {e.target}" for e in edges))
    assert not named, "import cycles between engine packages:\n" + "\n".join(named)


def test_the_checker_sees_what_it_should() -> None:
    """Imports inside functions count, TYPE_CHECKING ones do not; relative imports and
    ``from inkmotion import NAME`` resolve to modules."""
    code = ("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import a\nelse:\n"
            "    import b\ndef f():\n    import c\n")
    names = [a.name for n in _runtime_imports(ast.parse(code)) for a in n.names]
    assert names == ["TYPE_CHECKING", "b", "c"]
    assert facade_names()["plugin"] == "inkmotion.plugin_host.manager"
    uses = _facade_uses(ast.parse("import inkmotion\nr = inkmotion.plugin('renderer', 'x')\n"),
                        facade_names())
    assert uses == [(2, "inkmotion.plugin_host.manager")]
    assert allowed("inkmotion.fitting.objective", PROTOCOLS)
    assert not allowed("inkmotion.fitting.objective", "inkmotion.plugin_host.manager")
    assert not allowed("inkmotion.workers.tasks", "inkmotion.cli.main")
    assert allowed("inkmotion.cli.main", "inkmotion.benchmarks.suite")


def table() -> str:
    """The package-level import table: each package, its layer, the packages it imports
    at run time (``!`` after one that breaks the layers)."""
    edges: dict[str, dict[str, bool]] = defaultdict(dict)
    for imp in imports():
        src, dst = package_of(imp.source), package_of(imp.target)
        dst = imp.target if imp.target == PROTOCOLS else dst  # the one module engines may
        if src != dst:
            bad = not allowed(imp.source, imp.target)
            edges[src][dst] = edges[src].get(dst, False) or bad
    order = {layer: i for i, layer in enumerate(LAYERS)}
    packages = sorted({package_of(m) for m in modules() if m not in OUTSIDE},
                      key=lambda p: (order.get(layer_of(p) or "", len(order)), p))
    lines = ["package | layer | imports (! breaks the layers)", "---|---|---"]
    for package in packages:
        targets = sorted(edges.get(package, {}).items(),
                         key=lambda kv: (order.get(layer_of(kv[0]) or "", len(order)), kv[0]))
        shown = ", ".join(t.removeprefix("inkmotion.") + ("!" if bad else "")
                          for t, bad in targets)
        lines.append(f"{package.removeprefix('inkmotion.')} | {layer_of(package) or '?'} | "
                     f"{shown or '—'}")
    return "\n".join(lines)


if __name__ == "__main__":
    print(table())
    found = violations()
    print(f"\n{len(found)} imports break the layers" + (":" if found else "."))
    print("\n".join(found))
    sys.exit(0)
