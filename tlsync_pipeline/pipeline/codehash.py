"""The code a stage runs, for its cache key: the source of every project module it imports.

A stage's code is the import closure of its module within the project's
packages (``tlsync_pipeline``, ``trackers``, ``calibration``), found by
reading the ``import`` statements of the source (also those inside
functions, not those under ``if TYPE_CHECKING:``), without the engine modules (they run every stage but compute no
artefact) and the command line. Only the statements are parsed, not the
whole source (a run's 130 modules: 0.02 s instead of 0.35): the lines
that start with ``import`` or ``from`` (with their continuation lines),
outside the blocks of an ``if`` line that names ``TYPE_CHECKING``; a
line of prose that starts so is no statement Python parses.
``import a.b.c`` / ``from a.b import c`` count module ``a.b.c`` (or ``a.b`` when ``c`` is a name in it); a package's
``__init__`` counts when it is imported by its own name. Each module is
hashed by its source, so an upgrade re-runs exactly the stages whose code
changed.
"""

from __future__ import annotations

import ast
import bisect
import hashlib
import importlib.util
import itertools
import re
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
    package = name if spec is not None and spec.submodule_search_locations is not None else name.rpartition(".")[0]
    found = []
    for node in import_statements(module_source(name).decode("utf-8")):
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


_STATEMENT = re.compile(r"^[ \t]*(?:import|from)[ \t]", re.MULTILINE)
_TYPE_CHECKING_BLOCK = re.compile(
    r"^[ \t]*(?:if|elif)\b[^\n]*\bTYPE_CHECKING\b[^\n]*:[ \t]*(?:#[^\n]*)?$", re.MULTILINE
)


def import_statements(source: str) -> list[ast.Import | ast.ImportFrom]:
    """The import statements of a module's source that run (not those in the block of an ``if TYPE_CHECKING:``), in
    order: each line that starts with ``import`` or ``from`` (after its indentation), with its continuation lines
    (inside brackets, or after a backslash), parsed alone; a line that does not parse so is prose (a docstring's)."""
    lines = source.split("\n")
    starts = list(itertools.accumulate((len(line) + 1 for line in lines), initial=0))

    def line_of(match: re.Match) -> int:
        return bisect.bisect_right(starts, match.start()) - 1

    hidden = _type_checking_lines(lines, [line_of(m) for m in _TYPE_CHECKING_BLOCK.finditer(source)])
    found: list[ast.Import | ast.ImportFrom] = []
    for match in _STATEMENT.finditer(source):
        last = line_of(match)
        if last in hidden:
            continue
        text = _code(lines[last])
        while (text.endswith("\\") or text.count("(") > text.count(")")) and last + 1 < len(lines):
            last += 1
            text = text.removesuffix("\\") + " " + _code(lines[last])
        try:
            tree = ast.parse(text)
        except SyntaxError:
            continue
        found += [node for node in tree.body if isinstance(node, (ast.Import, ast.ImportFrom))]
    return found


def _code(line: str) -> str:
    """A line of an import statement without its comment (an import names no string that could hold a ``#``)."""
    return line.split("#", 1)[0].strip()


def _type_checking_lines(lines: list[str], headers: list[int]) -> set[int]:
    """The 0-based lines inside the blocks of the ``if TYPE_CHECKING:`` lines ``headers``: those after each, up to the
    next line of code indented no deeper than it (blank and comment lines do not end a block)."""
    hidden: set[int] = set()
    for header in headers:
        depth = len(lines[header]) - len(lines[header].lstrip())
        for number in range(header + 1, len(lines)):
            text = lines[number].strip()
            if text and not text.startswith("#") and len(lines[number]) - len(lines[number].lstrip()) <= depth:
                break
            hidden.add(number)
    return hidden


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
