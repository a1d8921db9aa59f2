"""Matplotlib without a display: the pyplot module (Agg backend), a figure's tight layout and its PNG bytes."""

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


def tight_layout(fig) -> None:
    """``fig.tight_layout()``, the subplot parameters it sets then kept as they are: matplotlib leaves a placeholder
    layout engine on the figure, for which ``savefig`` first draws the whole figure once more without output (a tenth
    of a simple chart's CPU); without it the same pixels come out of one draw."""
    fig.tight_layout()
    fig.set_layout_engine(None)
