"""Plots of the experiments, written as PNG files atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_histograms", "save_figure"]


def plot_histograms(path: Path, t: list[int], curves: dict, *, title: str) -> None:
    """The paper's error histograms: per curve (label -> (shares, colour)), the share of
    images with at most t errors, as a PNG at ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.6), dpi=110)
    for label, (values, colour) in curves.items():
        ax.step(t, np.asarray(values) * 100, where="post", label=label, color=colour, lw=2)
    ax.set_xlabel("errors t")
    ax.set_ylabel("images with ≤ t errors (%)")
    ax.set_ylim(0, 102)
    ax.set_xlim(0, max(t) if len(t) > 1 else 1)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right")
    ax.set_title(title)
    save_figure(fig, path)


def save_figure(fig, path: Path) -> None:
    """Write a matplotlib figure as PNG atomically and close it."""
    import io

    import matplotlib.pyplot as plt

    from unseeable.fileio import atomic_write_bytes

    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
