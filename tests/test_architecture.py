"""The package's layout keeps its promises (docs/architecture.md): no import cycle,
lower rooms never import higher ones, no module over 600 lines, no collocation/IPOPT
builder outside the estimation room, no pickle loads of output files; in the folders
of :data:`PUBLIC_ONLY` (the whole package) only public names cross modules, and in
those of :data:`SHORT_FUNCTIONS` no function is longer than :data:`MAX_FUNCTION_LINES`
lines. The plotting room is in the import graph."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from tests.paths import PACKAGE

PKG = PACKAGE

#: Rooms from the bottom up; a module may import its own room and rooms below it.
ROOMS = ["utils", "physics", "datasets", "estimation", "vehicle", "design", "plots",
         "pipeline", "api", "cli"]


def module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(tree: ast.AST):
    """``(node, inside_function)`` for every import statement of ``tree``, leaving out the
    ones under ``if TYPE_CHECKING:`` (annotations only; nothing is imported at run time)."""
    def walk(node: ast.AST, in_function: bool):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                for sub in child.orelse:
                    yield from walk(sub, in_function)
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child, in_function
            yield from walk(child, in_function or isinstance(
                child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)))
    yield from walk(tree, False)


def import_graph() -> dict[str, set[str]]:
    """Edges module -> imported ehsa_opt module, from every import statement (also the
    ones inside functions; not the ones under ``if TYPE_CHECKING:``). ``ehsa_opt.plots``
    is in the graph; the one exception is an import of ``ehsa_opt.plots`` inside a
    function — a result's ``.plot()`` delegating lazily to the plotting room."""
    modules = {module_name(p): p for p in PKG.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for mod, path in modules.items():
        is_pkg = path.name == "__init__.py"
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node, in_function in _imports(tree):
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    base = base[: len(base) - node.level + 1]
                    stem = ".".join(base + ([node.module] if node.module else []))
                else:
                    stem = node.module or ""
                for alias in node.names:
                    cand = f"{stem}.{alias.name}"
                    targets.append(cand if cand in modules else stem)
            else:
                targets = [a.name for a in node.names]
            for t in targets:
                while t and t not in modules:
                    t = t.rpartition(".")[0]
                lazy_plot = in_function and t.startswith("ehsa_opt.plots") \
                    and not mod.startswith("ehsa_opt.plots")
                if t and t != mod and not lazy_plot:
                    graph[mod].add(t)
    return graph


def test_plots_are_in_the_graph() -> None:
    """The plotting room's own imports are checked like every other room's."""
    graph = import_graph()
    assert any(m.startswith("ehsa_opt.plots") for m in graph)
    assert any(t.startswith("ehsa_opt.plots") for m, ts in graph.items()
               if m.startswith("ehsa_opt.pipeline") for t in ts)


def room(mod: str) -> str | None:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else None


def test_no_import_cycles() -> None:
    graph = import_graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def strong(v: str) -> None:  # Tarjan
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in graph:
        if v not in index:
            strong(v)
    assert not cycles, f"import cycles: {cycles}"


def test_rooms_import_downwards_only() -> None:
    bad = []
    for mod, targets in import_graph().items():
        r = room(mod)
        if r not in ROOMS:
            continue
        for t in targets:
            rt = room(t)
            if rt in ROOMS and ROOMS.index(rt) > ROOMS.index(r):
                bad.append(f"{mod} -> {t}")
    assert not bad, "a lower room imports a higher one:\n" + "\n".join(bad)


def test_every_module_is_in_a_room() -> None:
    stray = [m for m in import_graph() if room(m) is not None and room(m) not in ROOMS
             and m.count(".") >= 1 and m.split(".")[1] not in ("__main__",)]
    assert not stray, f"modules outside the rooms of docs/architecture.md: {stray}"


@pytest.mark.parametrize("path", sorted(PKG.rglob("*.py")),
                         ids=lambda p: str(p.relative_to(PKG)))
def test_module_size(path: Path) -> None:
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= 600, f"{path.relative_to(PKG)} has {n} lines (limit 600): split it by concern"


def test_collocation_only_in_estimation() -> None:
    offenders = [str(p.relative_to(PKG)) for p in PKG.rglob("*.py")
                 if "nlpsol(" in p.read_text(encoding="utf-8")
                 and p.relative_to(PKG).parts[0] != "estimation"]
    assert not offenders, f"IPOPT/nlpsol builders outside ehsa_opt/estimation: {offenders}"




#: Folders (relative to ``ehsa_opt/``, as path prefixes) whose modules import no
#: ``_private`` name from another ehsa_opt module ("" is the whole package).
PUBLIC_ONLY: tuple[str, ...] = ("",)
#: Folders whose modules define no function over :data:`MAX_FUNCTION_LINES` lines.
SHORT_FUNCTIONS: tuple[str, ...] = ("estimation/", "physics/", "datasets/", "utils/",
                                    "design/", "api/", "pipeline/")
MAX_FUNCTION_LINES = 120


def _in_public_only(path: Path, prefixes: tuple[str, ...] = PUBLIC_ONLY) -> bool:
    rel = path.relative_to(PKG).as_posix()
    return any(rel.startswith(prefix) for prefix in prefixes)


def private_imports(source: str, mod: str) -> list[str]:
    """``module:line: from X import _name`` for every import of a private name from
    another ehsa_opt module (relative imports and ``ehsa_opt.…``) in the ``source`` of
    module ``mod``, also inside functions."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.ImportFrom):
            continue
        if not node.level and not (node.module or "").startswith("ehsa_opt"):
            continue  # third-party or standard library
        for alias in node.names:
            if alias.name.startswith("_") and not alias.name.startswith("__"):
                src = "." * node.level + (node.module or "")
                found.append(f"{mod}:{node.lineno}: from {src} import {alias.name}")
    return found


def test_private_imports_finds_a_private_name() -> None:
    """The rule below sees what it must refuse (and lets public names and stdlib pass)."""
    src = ("from .fit import _hidden, public\nfrom dataclasses import replace as _r\n"
           "def f():\n    from ehsa_opt.utils import _x\n")
    found = private_imports(src, "ehsa_opt.estimation.discrepancy.probe")
    assert [f.split(": ", 1)[1] for f in found] == ["from .fit import _hidden",
                                                    "from ehsa_opt.utils import _x"]


def test_only_public_names_cross_modules() -> None:
    bad = [f for p in sorted(PKG.rglob("*.py")) if _in_public_only(p)
           for f in private_imports(p.read_text(encoding="utf-8"), module_name(p))]
    assert not bad, ("a module imports a private name from another module; make it public "
                     "(no leading underscore, in __all__) or keep it in its module:\n"
                     + "\n".join(bad))


def test_no_long_functions() -> None:
    long = []
    for p in sorted(PKG.rglob("*.py")):
        if not _in_public_only(p, SHORT_FUNCTIONS):
            continue
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{p.relative_to(PKG)}:{node.lineno} {node.name}: {n} lines")
    assert not long, (f"functions over {MAX_FUNCTION_LINES} lines (split them into named "
                      "steps):\n" + "\n".join(long))


def test_no_pickle_loads_or_eval() -> None:
    """No module can run code from a file a user may receive: no ``pickle.load(s)`` and no
    Python ``eval(`` (CasADi's ``Callback.eval`` method and ``def eval`` are not it)."""
    import re
    pattern = re.compile(r"pickle\.loads?\(|(?<![.\w])(?<!def )eval\(")
    offenders = []
    for p in sorted(PKG.rglob("*.py")):
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), start=1):
            code = line.split("#", 1)[0]
            if pattern.search(code):
                offenders.append(f"{p.relative_to(PKG)}:{n}: {line.strip()}")
    assert not offenders, "code-executing loads:\n" + "\n".join(offenders)


def _verdict_writes(tree: ast.AST) -> list[int]:
    """Lines of ``tree`` that write a verdict: an assignment to an ``earns`` attribute or
    item, or ``earns=`` passed as a keyword."""
    lines = []
    for node in ast.walk(tree):
        targets = []
        if isinstance(node, (ast.Assign, ast.AugAssign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        for t in targets:
            for sub in ast.walk(t):
                if (isinstance(sub, ast.Attribute) and sub.attr == "earns") or (
                        isinstance(sub, ast.Subscript) and isinstance(sub.slice, ast.Constant)
                        and sub.slice.value == "earns"):
                    lines.append(node.lineno)
        if isinstance(node, ast.Call) and any(k.arg == "earns" for k in node.keywords):
            lines.append(node.lineno)
    return lines


def test_verdicts_are_written_by_the_judge_alone() -> None:
    """Whether a model change earns is decided and written in one module,
    ``estimation/discrepancy/judge.py`` (by one ``Criterion``); the declaration of the
    ``earns`` fields (a default in a dataclass body) is not a write."""
    offenders = []
    for p in sorted((PKG / "estimation" / "discrepancy").rglob("*.py")):
        if p.name == "judge.py":
            continue
        offenders += [f"{p.relative_to(PKG)}:{n}"
                      for n in _verdict_writes(ast.parse(p.read_text(encoding="utf-8")))]
    assert not offenders, "verdicts written outside judge.py:\n" + "\n".join(offenders)


def test_the_verdict_check_finds_a_write() -> None:
    src = "c.earns = True\nd['earns'] = False\nf(earns=1)\nclass A:\n    earns: bool = False\n"
    assert _verdict_writes(ast.parse(src)) == [1, 2, 3]


#: The ehsa_opt modules ``cli.py`` imports besides the public API (the top-level
#: ``ehsa_opt`` and its ``__all__``), each with the reason: the command line's own
#: utilities; every command calls the public API.
CLI_EXCEPTIONS: dict[str, str] = {
    "ehsa_opt.utils.cli_args": "the command line's own argument types and output checks",
    "ehsa_opt.utils.progress": "the command line's tqdm bars (the library logs instead)",
    "ehsa_opt.utils.process": "pool workers die with the command",
    "ehsa_opt.utils.lock": "one run at a time per output folder",
    "ehsa_opt.utils.output_folder": "a folder of the user's is refused before any work",
    "ehsa_opt.utils.log": "the command line's stderr handler of the ehsa_opt logger",
}


def test_cli_imports_only_the_public_api() -> None:
    """``cli.py`` parses, calls the public API and prints: it imports ``ehsa_opt``'s
    documented names, and other modules only for the reasons of :data:`CLI_EXCEPTIONS`."""
    import ehsa_opt
    tree = ast.parse((PKG / "cli.py").read_text(encoding="utf-8"))
    used, bad = set(), []
    for node, _ in _imports(tree):
        if not isinstance(node, ast.ImportFrom) or (not node.level and not (
                node.module or "").startswith("ehsa_opt")):
            continue
        mod = "ehsa_opt" + (f".{node.module}" if node.module else "") if node.level \
            else node.module
        if mod == "ehsa_opt":
            bad += [f"from ehsa_opt import {a.name} (not in ehsa_opt.__all__)"
                    for a in node.names if a.name not in ehsa_opt.__all__]
            continue
        reason = next((k for k in CLI_EXCEPTIONS if mod == k or mod.startswith(k + ".")), None)
        if reason is None:
            bad.append(f"line {node.lineno}: from {mod} import ...")
        else:
            used.add(reason)
    assert not bad, "cli.py imports beyond the public API:\n" + "\n".join(bad)
    stale = set(CLI_EXCEPTIONS) - used
    assert not stale, f"exceptions no longer needed (remove them): {sorted(stale)}"
