"""The layers of docs/architecture.md hold: who may import whom, and no import cycle.

trackers, calibration <- artefacts <- sync, ingest <- outputs <- pipeline <- cli, over a
base of shared types (errors, atomic, csvtable, geodesy, inputs, trajectory). Every import is
counted, also those inside functions.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("tlsync_pipeline", "trackers", "calibration", "data_fixtures")
BASE = {
    "tlsync_pipeline",
    "tlsync_pipeline.errors",
    "tlsync_pipeline.atomic",
    "tlsync_pipeline.csvtable",
    "tlsync_pipeline.geodesy",
    "tlsync_pipeline.inputs",
    "tlsync_pipeline.trajectory",
}

# Layer of a module -> layers it may import (besides its own).
ALLOWED = {
    "trackers": set(),
    "calibration": set(),
    "base": {"trackers", "calibration"},
    "artefacts": {"base", "trackers", "calibration"},
    "sync": {"base", "artefacts", "trackers", "calibration"},
    "ingest": {"base", "artefacts", "trackers", "calibration"},
    "outputs": {"base", "artefacts", "sync", "ingest", "trackers", "calibration"},
    "pipeline": {"base", "artefacts", "sync", "ingest", "outputs", "trackers", "calibration"},
    "cli": {"base", "artefacts", "sync", "ingest", "outputs", "pipeline", "trackers", "calibration"},
    "data_fixtures": {"base", "artefacts", "sync", "ingest", "outputs", "pipeline", "trackers", "calibration"},
}
# The demo command is the one package module that may make fixtures.
FIXTURE_USERS = {"tlsync_pipeline.cli.demo"}


def layer(module: str) -> str:
    top, _, rest = module.partition(".")
    if top != "tlsync_pipeline":
        return top
    if module in BASE:
        return "base"
    return rest.split(".")[0]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imports(path: Path) -> set[str]:
    """Project modules imported anywhere in the file (absolute names)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{a.name}" for a in node.names)
    return {m for m in found if m.split(".")[0] in PACKAGES}


def project_modules() -> dict[str, set[str]]:
    modules = {module_name(p): p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        graph[name] = {m for m in imports(path) if m in modules and m != name}
    return graph


def test_every_import_respects_the_layers():
    wrong = []
    for module, targets in project_modules().items():
        own = layer(module)
        for target in targets:
            other = layer(target)
            if other == own:
                continue
            if other == "data_fixtures" and module not in FIXTURE_USERS:
                wrong.append(f"{module} -> {target} (only tests, bench and the demo use fixtures)")
            elif other != "data_fixtures" and other not in ALLOWED[own]:
                wrong.append(f"{module} ({own}) -> {target} ({other})")
    assert not wrong, "imports against the layers:\n" + "\n".join(sorted(wrong))


# Inside sync, the parts in the order of the data flow (docs/architecture.md, "The sync packages"): each imports
# only the parts before it.
SYNC_ORDER = ("kernels", "model", "vote", "identify", "pose", "clock_prior", "timeline", "solve")


def sync_part(module: str) -> str | None:
    """A sync module's part (its package under sync/, or its own name at sync/'s top), or None outside sync."""
    if not module.startswith("tlsync_pipeline.sync."):
        return None
    return module.removeprefix("tlsync_pipeline.sync.").split(".")[0]


def test_the_sync_packages_follow_the_data_flow():
    wrong = []
    for module, targets in project_modules().items():
        own = sync_part(module)
        if own is None:
            continue
        assert own in SYNC_ORDER, f"{module}: place its part in SYNC_ORDER"
        for target in targets:
            other = sync_part(target)
            if other is not None and SYNC_ORDER.index(other) > SYNC_ORDER.index(own):
                wrong.append(f"{module} ({own}) -> {target} ({other})")
    assert not wrong, "sync imports against the data flow:\n" + "\n".join(sorted(wrong))


def test_no_import_cycles():
    graph = project_modules()
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(node: str) -> None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join(stack[stack.index(nxt) :] + [nxt]))
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node)
    assert not cycles, "import cycles:\n" + "\n".join(cycles)


def test_the_layer_check_sees_a_violation(tmp_path):
    """The checker itself: a sync module importing the pipeline is reported."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from tlsync_pipeline.pipeline.project import load_project\n", encoding="utf-8")
    targets = imports(bad)
    assert "tlsync_pipeline.pipeline.project" in targets
    assert layer("tlsync_pipeline.pipeline.project") not in ALLOWED[layer("tlsync_pipeline.sync.vote.votes")]
