"""The grader's tripwire: code in a submission that reaches for the grader instead of answering the exercise.

The checks of a graded notebook run in the learner's own kernel (nbgrader's design), so a submission that replaces
a checker (``stair_lite.exercises.sensor.check_view_angle = lambda f: True``), patches what a checker compares with
(``np.allclose = ...``), calls the checker's reference, or opens files, processes or sockets could award itself
points or harm the machine. Before a submission runs, every code cell that is not verbatim one of the source
notebook's is read (never executed) and refused when it

- imports a module outside ``ALLOWED_MODULES`` (the exercises need numpy, torch, scipy and the package);
- names an escape hatch of ``FORBIDDEN_NAMES`` (``open``, ``exec``, ``getattr``, ``globals``, ``get_ipython``, ...);
- reads a private or special attribute (``x._close``, ``f.__globals__``; ``__init__`` and ``__name__`` are fine)
  or the checkers' ``reference``;
- assigns to or deletes an attribute (or an item of one) that a module of ``WATCHED_MODULES`` has (``np.allclose =
  ...``, ``sensor.check_view_angle = ...``, ``alias.allclose = ...``; ``buffer.use_counts[i] = ...`` is fine);
- holds a shell escape or magic (a line starting with ``!`` or ``%``).

This is a tripwire, not a proof: it reads Python as written, and the isolation of ``course.py`` (each notebook in
its own process, folder and user, with memory and time limits) is the second line.
"""
from __future__ import annotations

import ast
import functools
import importlib
import pkgutil

ALLOWED_MODULES = frozenset({
    "__future__", "collections", "dataclasses", "functools", "itertools", "math", "matplotlib", "numpy", "random",
    "scipy", "stair_lite", "statistics", "torch", "typing",
})
FORBIDDEN_NAMES = frozenset({
    "__builtins__", "__import__", "breakpoint", "compile", "delattr", "eval", "exec", "get_ipython", "getattr",
    "globals", "input", "locals", "open", "setattr", "vars",
})
ALLOWED_SPECIAL = frozenset({"__init__", "__name__"})
WATCHED_MODULES = ("builtins", "math", "numpy", "numpy.linalg", "numpy.random", "numpy.testing", "scipy.stats", "torch",
                   "torch.nn", "torch.nn.functional")  # and every module of the package


@functools.cache
def watched_names() -> frozenset[str]:
    """The attributes of the watched modules and of every stair_lite module: what a checker may rely on."""
    import stair_lite

    names = [m.name for m in pkgutil.walk_packages(stair_lite.__path__, prefix="stair_lite.")
             if m.name != "stair_lite.__main__"] + ["stair_lite", *WATCHED_MODULES]
    found = set()
    for name in names:
        found |= {a for a in dir(importlib.import_module(name)) if not a.startswith("__")}
    return frozenset(found)


def _root_name(node: ast.expr) -> str | None:
    """The variable an attribute or item chain starts from (``a`` in ``a.b[0].c``), if any."""
    while isinstance(node, (ast.Attribute, ast.Subscript)):
        node = node.value
    return node.id if isinstance(node, ast.Name) else None


class _Reader(ast.NodeVisitor):
    """Collects a cell's findings as (line, what)."""

    def __init__(self):
        self.findings: list[tuple[int, str]] = []

    def flag(self, node: ast.AST, what: str) -> None:
        self.findings.append((getattr(node, "lineno", 0), what))

    def visit_Import(self, node):
        for alias in node.names:
            self._module(node, alias.name)

    def visit_ImportFrom(self, node):
        self._module(node, "." if node.level else node.module or "")
        for alias in node.names:
            if alias.name.startswith("_") and alias.name != "__future__":
                self.flag(node, f"imports the private name {alias.name}")

    def _module(self, node, name: str) -> None:
        if name.split(".")[0] not in ALLOWED_MODULES:
            self.flag(node, f"imports {name} (allowed: {', '.join(sorted(ALLOWED_MODULES))})")

    def visit_Name(self, node):
        if node.id in FORBIDDEN_NAMES:
            self.flag(node, f"uses {node.id}")

    def visit_Attribute(self, node):
        special = node.attr.startswith("__") and node.attr not in ALLOWED_SPECIAL
        private = node.attr.startswith("_") and not node.attr.startswith("__") and _root_name(node) != "self"
        if special or private or node.attr == "reference":
            self.flag(node, f"reads the attribute {node.attr}")
        if isinstance(node.ctx, (ast.Store, ast.Del)):
            self._changes(node)
        self.generic_visit(node)

    def visit_Subscript(self, node):
        if isinstance(node.ctx, (ast.Store, ast.Del)) and isinstance(node.value, (ast.Attribute, ast.Subscript)):
            self._changes(node)
        self.generic_visit(node)

    def _changes(self, node) -> None:
        chain = node
        while isinstance(chain, (ast.Attribute, ast.Subscript)):
            if isinstance(chain, ast.Attribute) and chain.attr in watched_names():
                self.flag(node, f"changes {ast.unparse(node)} ({chain.attr} is a name the checkers rely on)")
                return
            chain = chain.value


def findings(cell_source: str) -> list[tuple[int, str]]:
    """What in one code cell reaches for the grader: (line, what) pairs, empty when nothing does."""
    lines = cell_source.splitlines()
    escapes = [(i + 1, f"runs the shell or a magic: {line.strip()}") for i, line in enumerate(lines)
               if line.lstrip().startswith(("!", "%"))]
    try:
        tree = ast.parse(cell_source)
    except SyntaxError:
        return escapes  # the kernel reports it; a cell that does not parse runs nothing
    reader = _Reader()
    reader.visit(tree)
    return escapes + sorted(reader.findings)


def tampering(submitted_cells: list[str], source_cells: list[str]) -> list[str]:
    """Each finding in the submission's code cells that are not verbatim one of the source notebook's, as
    ``"cell <index> line <line>: <what>"``."""
    known = set(source_cells)
    return [f"cell {i} line {line}: {what}" for i, text in enumerate(submitted_cells) if text not in known
            for line, what in findings(text)]
