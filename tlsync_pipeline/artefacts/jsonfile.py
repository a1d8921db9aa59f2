"""JSON documents of the work folder: read one with errors that name the file, write one as every JSON artefact is
written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from tlsync_pipeline.errors import InputError


def read_document(path: str | Path, what: str) -> dict[str, Any]:
    """The JSON object in ``path``; InputError naming the file (and the line) when it is missing or not ``what``."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}:{exc.lineno}: invalid JSON: {exc.msg}") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: not {what} (expected a JSON object)")
    return data


def write_document(document: Any, path: str | Path) -> None:
    """``document`` as indented JSON with a final newline (the work folder's JSON artefacts)."""
    Path(path).write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")


def malformed(path: str | Path, what: str, exc: Exception) -> InputError:
    """The error of a JSON artefact whose fields are missing or of the wrong type."""
    return InputError(f"{path}: not {what} (missing or malformed field {exc})")
