"""Bar charts of the section-5.5 experiments, like the thesis' Figs. 5.6-5.19 (Agg canvas, no pyplot state).

* :func:`save_bar_chart` -- mean episode reward or RPE with SD error bars, one
  bar per network, one bar group per energy level or reward area, and the
  full-information bound of each group as a dashed line.
* :func:`save_strategy_chart` -- the episode reward of each network per
  opponent strategy (ours; the thesis gives no such chart).

Both take the ``results[group][label]`` evaluation dicts of
:func:`jaxdc.dcg.analysis.experiment.run_experiment` and write a PNG atomically;
:func:`bar_chart_png` and :func:`strategy_chart_png` return the same PNG as
bytes (for a set of files written together, :func:`jaxdc.io.atomic_write_set`).
A bar whose statistic is undefined (``None``: no episode consumed energy, say)
is left out.
"""

from __future__ import annotations

import io

import matplotlib
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jaxdc.io import atomic_write

#: Height of every chart in inches; the width grows with the number of bars.
HEIGHT = 3.8
#: The bar colours, one per network in order.
COLORS = matplotlib.colormaps["tab10"].colors


def _axes(width):
    fig = Figure(figsize=(width, HEIGHT))
    FigureCanvasAgg(fig)
    return fig, fig.subplots()


def _png(fig) -> bytes:
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def save_bar_chart(path, results: dict, groups, col: str, title: str, bounds: dict | None = None,
                   group_labels=None) -> str:
    """:func:`bar_chart_png` written atomically to ``path``; returns the path."""
    return atomic_write(path, bar_chart_png(results, groups, col, title, bounds, group_labels))


def save_strategy_chart(path, results: dict, title: str) -> str | None:
    """:func:`strategy_chart_png` written atomically to ``path``; returns the path, ``None`` (nothing written)
    without networks."""
    png = strategy_chart_png(results, title)
    return None if png is None else atomic_write(path, png)


def bar_chart_png(results: dict, groups, col: str, title: str, bounds: dict | None = None,
                  group_labels=None) -> bytes:
    """A bar chart like the thesis' (mean with SD error bars, labelled) of column ``col`` (``"reward"`` or
    ``"rpe"``) of ``results[group][label]``, one bar group per value of ``groups`` (ticked ``group_labels``).

    With one group the bars are ticked by network; ``bounds[group]["total"]`` (reward only) is drawn as a
    dashed line over its group. Returns the PNG's bytes.
    """
    groups = list(groups)
    labels = []
    for g in groups:
        labels += [lb for lb in results[g] if lb not in labels]
    single = len(groups) == 1
    fig, ax = _axes(max(5.0, 1.1 * len(labels)) if single else max(6.0, 0.55 * len(labels) * len(groups) + 2))
    width = 0.7 if single else 0.8 / max(len(labels), 1)
    fmt = "%.3f" if col == "rpe" else "%.2f"
    for j, lb in enumerate(labels):
        xs, ys, es = [], [], []
        for i, g in enumerate(groups):
            r = results[g].get(lb)
            if r is not None and r[col]["mean"] is not None:
                xs.append(j if single else i + (j - (len(labels) - 1) / 2) * width)
                ys.append(r[col]["mean"])
                es.append(r[col]["sd"])
        bars = ax.bar(xs, ys, width, yerr=es, capsize=3, label=lb, color=COLORS[j % 10])
        ax.bar_label(bars, fmt=fmt, fontsize=7, padding=2)
    if col == "reward" and bounds:
        for i, g in enumerate(groups):
            if g in bounds:
                lo, hi = (-0.45, len(labels) - 0.55) if single else (i - 0.45, i + 0.45)
                ax.hlines(bounds[g]["total"], lo, hi, colors="k", linestyles="--",
                          label="full-information bound" if i == 0 else None)
                if single:
                    ax.text(hi, bounds[g]["total"], f"full-information bound {bounds[g]['total']:.2f}",
                            ha="right", va="bottom", fontsize=7)
    if single:
        ax.set_xticks(range(len(labels)), [lb.replace(" strong", "\nstrong") for lb in labels], fontsize=8)
    else:
        ax.set_xticks(range(len(groups)), list(group_labels))
        ax.legend(fontsize=7, ncol=min(len(labels) + 1, 3))
    ax.set_ylabel("episode reward" if col == "reward" else "reward per energy")
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    return _png(fig)


def strategy_chart_png(results: dict, title: str) -> bytes | None:
    """The episode reward of each network of ``results[label]`` per opponent strategy, with SD error bars, as
    PNG bytes; ``None`` without networks."""
    labels = list(results)
    if not labels:
        return None
    strategies = list(results[labels[0]]["per_strategy"])
    fig, ax = _axes(max(6.0, 0.55 * len(labels) * len(strategies) + 2))
    width = 0.8 / len(labels)
    for j, lb in enumerate(labels):
        ps = results[lb]["per_strategy"]
        shown = [i for i, s in enumerate(strategies) if s in ps and ps[s]["reward"]["mean"] is not None]
        xs = [i + (j - (len(labels) - 1) / 2) * width for i in shown]
        bars = ax.bar(xs, [ps[strategies[i]]["reward"]["mean"] for i in shown], width,
                      yerr=[ps[strategies[i]]["reward"]["sd"] for i in shown], capsize=3, label=lb,
                      color=COLORS[j % 10])
        ax.bar_label(bars, fmt="%.2f", fontsize=7, padding=2)
    ax.set_xticks(range(len(strategies)), strategies)
    ax.set_ylabel("episode reward")
    ax.set_ylim(bottom=0)
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=min(len(labels), 3))
    return _png(fig)
