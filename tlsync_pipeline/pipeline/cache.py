"""Cache keys and manifests: when is a stage's artefact fresh?

A stage run is described by its inputs (files, hashed by content), its
parameters (JSON values from the project file) and its code (the source of
the modules it runs, see codehash.py). Their hash is the stage's cache key;
paths in it are relative (see Workspace.portable), so a moved project keeps
its keys. After the stage has written its artefacts, a manifest
(JSON, written atomically and last) records the key, what went into it and the
hash of every artefact. An artefact is fresh when its manifest exists, the key
it records equals the key of the current inputs, and every artefact still has
the hash the manifest records; so a run killed between writing an artefact and
its manifest, or an artefact edited by hand, is never taken as fresh.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tlsync_pipeline.atomic import atomic_path

MANIFEST_FORMAT = "tlsync-manifest"
_CHUNK = 1 << 20
_RACY_NS = 2_000_000_000
SAMPLE_BLOCKS = 16  # blocks of a file read on every freshness check ...
SAMPLE_BYTES = 64 << 10  # ... of this many bytes (1 MiB in all; a smaller file is read whole)


def content_sample(path: Path, size: int) -> str:
    """SHA-256 (hex) of SAMPLE_BLOCKS blocks of SAMPLE_BYTES evenly spread from the file's start to its end."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        if size <= SAMPLE_BLOCKS * SAMPLE_BYTES:
            digest.update(handle.read())
        else:
            for k in range(SAMPLE_BLOCKS):
                handle.seek(k * (size - SAMPLE_BYTES) // (SAMPLE_BLOCKS - 1))
                digest.update(handle.read(SAMPLE_BYTES))
    return digest.hexdigest()


def file_sha256(path: Path) -> str:
    """SHA-256 of a file's contents (hex)."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        while chunk := handle.read(_CHUNK):
            digest.update(chunk)
    return digest.hexdigest()


class HashMemo:
    """File hashes remembered by what can be checked without reading the whole file, so big videos are read once.

    Stored as JSON in the work folder. A file is hashed again when its size,
    modification time, inode or status-change time (ctime: set by the system
    on every write or rename, never by ``cp -p`` or ``rsync -t``) differs, or
    its content sample does: SAMPLE_BLOCKS blocks of SAMPLE_BYTES spread over
    the file from its first to its last byte (the whole of a file up to
    SAMPLE_BLOCKS x SAMPLE_BYTES), read on the first check of each memo (one run, one
    ``status``) and again whenever the status changed. That sample sees an
    edit that keeps size and times on file systems whose inode and ctime do
    not move (FAT and exFAT cards), unless it touches none of the blocks.
    A run checks a video for every task that reads it: the sample is read
    once.
    """

    def __init__(self, path: Path | None = None):
        self.path = path
        self.entries: dict[str, list] = {}
        self.dirty = False
        self._sampled: set[tuple] = set()  # (path, size, mtime, inode, ctime) whose content this memo has read
        if path is not None and path.exists():
            try:
                self.entries = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                self.entries = {}

    def sha256(self, path: Path) -> str | None:
        """The file's hash, or None when it does not exist."""
        try:
            stat = os.stat(path)
        except FileNotFoundError:
            return None
        key = str(Path(path).resolve())
        known = self.entries.get(key)
        seen = [stat.st_size, stat.st_mtime_ns, stat.st_ino, stat.st_ctime_ns]
        status = (key, *seen)
        if (
            known
            and len(known) == 6
            and known[:4] == seen
            and (status in self._sampled or known[4] == content_sample(path, stat.st_size))
        ):
            self._sampled.add(status)
            return known[5]
        digest = file_sha256(path)
        # A file modified within the last seconds could change again without
        # a visible change of mtime (coarse timestamps): do not remember it.
        if time.time_ns() - max(stat.st_mtime_ns, stat.st_ctime_ns) > _RACY_NS:
            self.entries[key] = [*seen, content_sample(path, stat.st_size), digest]
            self.dirty = True
            self._sampled.add(status)
        return digest

    def save(self) -> None:
        if self.path is not None and self.dirty:
            with atomic_path(self.path) as tmp:
                tmp.write_text(json.dumps(self.entries), encoding="utf-8")
            self.dirty = False


def cache_key(stage: str, code: dict[str, str], input_hashes: dict[str, str | None], params: dict[str, Any]) -> str:
    """SHA-256 over the stage name, its code (module -> source hash), its inputs' hashes and its parameters."""
    blob = json.dumps(
        {"stage": stage, "code": code, "inputs": input_hashes, "params": params}, sort_keys=True, default=str
    )
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()


@dataclass
class Manifest:
    """What one stage run used and made; lives beside the stage's main artefact."""

    stage: str
    camera: str | None
    code: dict[str, str]  # module -> SHA-256 of its source
    key: str
    inputs: dict[str, dict]  # label -> {"path": str (relative, see Workspace.portable), "sha256": str}
    params: dict[str, Any]
    outputs: dict[str, str]  # path relative to the work folder -> sha256
    seconds: float = 0.0  # the task's own run time, where it ran (not its wait in a queue)
    cpu_seconds: float | None = None  # CPU time of the process that ran it, its threads included (None: not recorded)
    created: str = ""
    summary: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"format": MANIFEST_FORMAT, **self.__dict__}


def write_manifest(manifest: Manifest, path: Path) -> None:
    """Write the manifest atomically (after the artefacts it describes)."""
    manifest.created = manifest.created or time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(manifest.to_dict(), indent=1, sort_keys=True, default=str) + "\n", encoding="utf-8")


def read_manifest(path: Path) -> Manifest | None:
    """The manifest at ``path``, or None when it is absent or unreadable (then the stage is missing)."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        if data.pop("format", None) != MANIFEST_FORMAT:
            return None
        return Manifest(**data)
    except (OSError, ValueError, TypeError):
        return None


FAILURE_FORMAT = "tlsync-failure"


def failure_path(manifest: Path) -> Path:
    """Where a task's last failure is recorded: ``<stage>.failure.json`` beside its manifest."""
    return manifest.with_name(manifest.name.replace(".manifest.json", ".failure.json"))


def write_failure(path: Path, key: str, reason: str) -> None:
    """Record that the task with cache key ``key`` failed, and why (one line); best effort (the disk may be full)."""
    record = {
        "format": FAILURE_FORMAT,
        "key": key,
        "reason": reason,
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    try:
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
    except OSError:
        pass


def read_failure(path: Path) -> dict | None:
    """The failure record at ``path`` ({"key", "reason", "created"}), or None."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("format") == FAILURE_FORMAT else None


NOT_MADE = "not made yet"  # why a task without a manifest runs


def staleness(
    manifest: Manifest | None,
    key: str,
    code: dict[str, str],
    inputs: dict[str, dict],
    params: dict,
    memo: HashMemo,
    work: Path,
) -> list[str]:
    """Why an artefact is not fresh (empty list: fresh).

    Names the modules whose code changed, the input files and parameters that
    changed since the manifest was written, and artefacts that are gone or
    were changed.
    """
    if manifest is None:
        return [NOT_MADE]
    reasons = []
    for module in sorted(set(code) | set(manifest.code)):
        old, new = manifest.code.get(module), code.get(module)
        if old != new:
            reasons.append(
                f"code of {module} " + ("is new" if old is None else "is no longer used" if new is None else "changed")
            )
    for label in sorted(set(inputs) | set(manifest.inputs)):
        was, now = manifest.inputs.get(label), inputs.get(label)  # {"path", "sha256"} or None
        if was is None:
            reasons.append(f"new input {label}")
        elif now is None:
            reasons.append(f"input {label} no longer used")
        elif was.get("path") != now["path"]:
            reasons.append(f"input {label} is now {now['path']} (was {was.get('path')})")
        elif was.get("sha256") != now["sha256"]:
            reasons.append(
                f"input {label} changed ({now['path']})"
                if now["sha256"]
                else f"input {label} is missing ({now['path']})"
            )
    reasons += [f"parameter {name}: {old!r} -> {new!r}" for name, old, new in _changes(manifest.params, params)]
    if not reasons and manifest.key != key:
        reasons.append("cache key changed")
    for rel, digest in sorted(manifest.outputs.items()):
        actual = memo.sha256(work / rel)
        if actual is None:
            reasons.append(f"artefact {rel} is missing")
        elif actual != digest:
            reasons.append(f"artefact {rel} was modified after it was made")
    return reasons


def _changes(old: Any, new: Any, name: str = "") -> list[tuple[str, Any, Any]]:
    """(dotted name, old, new) of each parameter that differs, tables compared key by key (``sync.eps_px``)."""
    if isinstance(old, dict) and isinstance(new, dict):
        return [
            change
            for key in sorted(set(old) | set(new))
            for change in _changes(old.get(key), new.get(key), f"{name}.{key}" if name else key)
        ]
    return [] if _normal(old) == _normal(new) else [(name, old, new)]


def _normal(value: Any) -> str:
    return json.dumps(value, sort_keys=True, default=str)
