"""Matplotlib without a display: the pyplot module (Agg backend) and a figure's PNG bytes."""

from __future__ import annotations

import io


def png(fig) -> bytes:
    """The figure as PNG bytes (90 dpi); the figure is closed."""
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90)
    plt.close(fig)
    return buffer.getvalue()


def pyplot():
    """matplotlib.pyplot on the Agg backend (imported here: a command that draws nothing loads no matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
