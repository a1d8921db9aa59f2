"""The code a stage runs, for its cache key: the source of every project module it imports.

A stage's code is the import closure of its module within the project's
packages (``tlsync_pipeline``, ``trackers``, ``calibration``), found by
reading the ``import`` statements of the source (also those inside
functions, not those under ``if TYPE_CHECKING:``), without the engine modules (they run every stage but compute no
artefact) and the command line. ``import a.b.c`` / ``from a.b import c``
count module ``a.b.c`` (or ``a.b`` when ``c`` is a name in it); a package's
``__init__`` counts when it is imported by its own name. Each module is
hashed by its source, so an upgrade re-runs exactly the stages whose code
changed.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
from functools import cache

PACKAGES = ("tlsync_pipeline", "trackers", "calibration")
ENGINE_MODULES = frozenset(
    f"tlsync_pipeline.pipeline.{name}"
    for name in ("graph", "engine", "cache", "codehash", "executors", "lock", "workspace", "spec")
)
_ENGINE_PACKAGES = ("tlsync_pipeline.cli",)


def module_source(name: str) -> bytes:
    """The source of a project module (bytes of its file)."""
    spec = importlib.util.find_spec(name)
    if spec is None or spec.origin is None:
        raise ImportError(f"no source for module {name}")
    with open(spec.origin, "rb") as handle:
        return handle.read()


@cache
def _is_module(name: str) -> bool:
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _counted(name: str) -> bool:
    return name.split(".")[0] in PACKAGES and name not in ENGINE_MODULES and not name.startswith(_ENGINE_PACKAGES)


@cache
def _imports(name: str) -> tuple[str, ...]:
    """The project modules one module's source imports."""
    spec = importlib.util.find_spec(name)
    tree = ast.parse(module_source(name))
    package = name if spec is not None and spec.submodule_search_locations is not None else name.rpartition(".")[0]
    found = []
    for node in _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(
                    package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else [])
                )
            if not _counted(base):
                continue  # another package's names: no need to ask the import system about them
            for alias in node.names:
                found.append(f"{base}.{alias.name}" if _is_module(f"{base}.{alias.name}") else base)
    return tuple(sorted({m for m in found if _counted(m) and _is_module(m)}))


def _runtime_nodes(tree: ast.Module):
    """Every statement of the tree, nested ones included, except the bodies of ``if TYPE_CHECKING:`` blocks (imports for
    annotations only).

    Only statements are visited: an import is a statement, and statements
    sit only in other statements' bodies (``body``, ``orelse``,
    ``finalbody``, ``handlers``, ``cases``), never inside expressions.
    """
    stack = list(tree.body)
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _names_type_checking(node.test):
            stack.extend(node.orelse)
            continue
        yield node
        for field in ("body", "orelse", "finalbody", "handlers", "cases"):
            stack.extend(getattr(node, field, ()))


def _names_type_checking(test: ast.expr) -> bool:
    """Whether a condition reads ``TYPE_CHECKING`` (the name, or an attribute such as ``typing.TYPE_CHECKING``)."""
    return any(
        (isinstance(node, ast.Name) and node.id == "TYPE_CHECKING")
        or (isinstance(node, ast.Attribute) and node.attr == "TYPE_CHECKING")
        for node in ast.walk(test)
    )


@cache
def closure(name: str) -> tuple[str, ...]:
    """The project modules ``name`` runs: itself and what it imports, transitively (engine modules excluded)."""
    seen: set[str] = set()
    stack = [name]
    while stack:
        module = stack.pop()
        if module in seen:
            continue
        seen.add(module)
        stack.extend(_imports(module))
    return tuple(sorted(seen))


def code_digests(module: str) -> dict[str, str]:
    """Module name -> SHA-256 of its source, for every module of ``module``'s closure."""
    return {name: hashlib.sha256(module_source(name)).hexdigest() for name in closure(module)}
