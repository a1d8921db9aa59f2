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

Parsing the sources is most of the cost (about 0.3 s of CPU for every
stage's closure): an ``ImportMemo`` in the user's cache remembers each
module's imports by the SHA-256 of its source, so a run parses only the
modules that changed; a module file added or removed in the packages (which
can change what an import names) starts another memo.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import json
import os
from functools import cache
from pathlib import Path

from tlsync_pipeline.atomic import atomic_path

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
    return _imports_in(name, module_source(name))


def _imports_in(name: str, source: bytes) -> tuple[str, ...]:
    """The project modules the source of module ``name`` imports."""
    spec = importlib.util.find_spec(name)
    tree = ast.parse(source)
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


def code_digests(module: str, memo: ImportMemo | None = None) -> dict[str, str]:
    """Module name -> SHA-256 of its source, for every module of ``module``'s closure (sorted by name).

    memo: the imports of modules whose source is unchanged, remembered (None: every module parsed, once per process).
    """
    if memo is None:
        return {name: hashlib.sha256(module_source(name)).hexdigest() for name in closure(module)}
    digests: dict[str, str] = {}
    stack = [module]
    while stack:
        name = stack.pop()
        if name in digests:
            continue
        source = module_source(name)
        digests[name] = hashlib.sha256(source).hexdigest()
        stack.extend(memo.imports(name, source, digests[name]))
    return dict(sorted(digests.items()))


class StageCode:
    """The code digests of stage modules for one pass (``code_digests``, each module's once), with their imports
    remembered in ``memo``."""

    def __init__(self, memo: ImportMemo):
        self.memo = memo
        self._digests: dict[str, dict[str, str]] = {}

    def digests(self, module: str) -> dict[str, str]:
        if module not in self._digests:
            self._digests[module] = code_digests(module, self.memo)
        return self._digests[module]


class ImportMemo:
    """The project modules each module imports (``_imports``), remembered by the SHA-256 of its source, in a JSON file
    per layout of the packages' module files (their paths: one added or removed can change what an import names).

    folder: the cache folder the files are kept under (in ``tlsync/``); None: the user's (``$XDG_CACHE_HOME``, else
    ``~/.cache``): what a module imports is a fact of the installed code, not of a project, so a first run in a new
    work folder finds it too. A file that cannot be read or written is only not used.
    """

    def __init__(self, folder: Path | None = None):
        self.layout = _layout()
        folder = folder if folder is not None else Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
        self.path = folder / "tlsync" / f"imports-{self.layout[:16]}.json"
        self.modules: dict[str, list] = {}
        self.dirty = False
        try:
            data = json.loads(self.path.read_text(encoding="utf-8"))
            if data.get("layout") == self.layout:
                self.modules = dict(data["modules"])
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            self.modules = {}

    def imports(self, name: str, source: bytes, digest: str) -> tuple[str, ...]:
        """The project modules module ``name`` imports; ``source`` parsed only when its ``digest`` is not known."""
        known = self.modules.get(name)
        if isinstance(known, list) and len(known) == 2 and known[0] == digest:
            return tuple(known[1])
        found = _imports_in(name, source)
        self.modules[name] = [digest, list(found)]
        self.dirty = True
        return found

    def save(self) -> None:
        """Write the file when something was parsed (silently not, where it cannot be written)."""
        if not self.dirty:
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with atomic_path(self.path) as tmp:
                tmp.write_text(json.dumps({"layout": self.layout, "modules": self.modules}), encoding="utf-8")
        except OSError:
            return
        self.dirty = False


def _layout() -> str:
    """SHA-256 of the paths of the project packages' module files (relative to each package's folder)."""
    digest = hashlib.sha256()
    for package in PACKAGES:
        spec = importlib.util.find_spec(package)
        for folder in (spec.submodule_search_locations or []) if spec is not None else []:
            found = [
                os.path.relpath(os.path.join(root, file), folder)
                for root, _, files in os.walk(folder)
                for file in files
                if file.endswith(".py")
            ]
            digest.update("\n".join([package, *sorted(found)]).encode("utf-8"))
    return digest.hexdigest()
