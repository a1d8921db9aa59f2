"""Where the real flight lies: ``../shared/real`` beside the checkout, or ``$TLSYNC_REAL_DATA``."""

from __future__ import annotations

import os
from pathlib import Path

REAL_DATA = Path(os.environ.get("TLSYNC_REAL_DATA", Path(__file__).resolve().parents[2] / "shared" / "real"))
