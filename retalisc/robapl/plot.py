"""A picture of a run: one row per plan node, its state over the micro steps of the run as
coloured bars (matplotlib, as `retalisc plot` uses: retalisc/robot_io/plot.py). The x axis
counts micro steps; each macro step is labelled with its event and time."""
from __future__ import annotations

from typing import Dict, List, Tuple

from .executor import STATES

COLOURS = {"inactive": "#eeeeee", "waiting": "#9ecae1", "waiting_resource": "#fdae6b", "executing": "#31a354",
           "finishing": "#a1d99b", "failing": "#de2d26", "pausing": "#bcbddc", "paused": "#756bb1",
           "resuming": "#dadaeb", "iteration_ended": "#fee391", "finished": "#636363", "deactivating": "#252525"}
assert set(COLOURS) == set(STATES)


def state_segments(trace: List[dict]) -> Tuple[Dict[str, List[Tuple[int, int, str]]], List[Tuple[int, str]], int]:
    """Per node, its (first step, last step, state) segments; the macro steps' first step and label."""
    steps: Dict[Tuple[int, int], int] = {}
    current: Dict[str, Tuple[int, str]] = {}
    segments: Dict[str, List[Tuple[int, int, str]]] = {}
    macros: List[Tuple[int, str]] = []
    for record in trace:
        key = (record["macro"], record["micro"])
        if key not in steps:
            steps[key] = len(steps)
        step = steps[key]
        if "event" in record:
            macros.append((step, f"{record['event']} @{record['t']:g}"))
        if "to" in record:
            node = record["node"]
            if node in current:
                begin, state = current[node]
                segments[node].append((begin, step, state))
            else:
                segments.setdefault(node, [])
            current[node] = (step, record["to"])
    last = len(steps)
    for node, (begin, state) in current.items():
        # a deactivated plan leaves the plan base: its root's row ends there
        segments[node].append((begin, begin + 1 if state == "deactivating" else last, state))
    return segments, macros, last


def plot_run(trace: List[dict], output: str, title: str = "RobAPL run") -> int:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    segments, macros, last = state_segments(trace)
    nodes = list(segments)
    height = max(2.5, 0.28 * len(nodes) + 1.5)
    figure, axes = plt.subplots(figsize=(max(8, min(24, 0.12 * last + 6)), height))
    for row, node in enumerate(nodes):
        for begin, end, state in segments[node]:
            axes.barh(row, max(end - begin, 0.6), left=begin, height=0.7, color=COLOURS[state], edgecolor="none")
    axes.set_yticks(range(len(nodes)))
    axes.set_yticklabels(nodes, fontsize=7)
    axes.invert_yaxis()
    for step, label in macros:
        axes.axvline(step, color="#bbbbbb", linewidth=0.5)
        axes.text(step, -0.8, label, rotation=60, fontsize=6, ha="left", va="bottom")
    axes.set_xlim(0, max(last, 1))
    axes.set_xlabel("micro steps (grey lines: macro steps, labelled with their event and time)")
    axes.set_title(title, pad=60)
    used = [s for s in STATES if any(seg[2] == s for segs in segments.values() for seg in segs)]
    axes.legend(handles=[Patch(color=COLOURS[s], label=s) for s in used], fontsize=7, loc="upper left",
                bbox_to_anchor=(1.01, 1))
    figure.tight_layout()
    figure.savefig(output, dpi=120)
    plt.close(figure)
    return len(nodes)
