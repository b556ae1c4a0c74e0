"""Plots for docs/accuracy.md (matplotlib, no display needed)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402


def line_plot(path, series, xlabel, ylabel, title, log=()):
    """``series``: label -> (xs, ys), one line with markers each; ``log`` names the axes ("x",
    "y") drawn on a log scale.  Written to ``path`` as a PNG."""
    figure, axes = plt.subplots(figsize=(6.0, 3.6), dpi=100)
    for label, (xs, ys) in series.items():
        axes.plot(xs, ys, marker="o", label=label)
    if "x" in log:
        axes.set_xscale("log")
    if "y" in log:
        axes.set_yscale("log")
    axes.set_xlabel(xlabel)
    axes.set_ylabel(ylabel)
    axes.set_title(title)
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize="small")
    figure.tight_layout()
    figure.savefig(path)
    plt.close(figure)
