"""The walks of ``cpgjax follow --ctl``, drawn: one panel per controller and path, the path's waypoints and each
engine's walk of it (``follow --plot WALKS.png``).

Each walk is a dict of :func:`cpgjax.experiments.steer.walks` (the records ``follow --out`` writes): its CM's
``trajectory`` [S, 2] up to its end (the last waypoint passed, the fall, or the walk's time), the path's
``waypoint_xy`` [n, 2], and ``finished`` / ``fell``.  The path starts at the origin, as the robot does.  A walk that
fell ends in a cross, one that finished in a dot, one that ran out of time in nothing.

The figure function returns a matplotlib ``Figure`` (Agg canvas, no global backend change).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

STYLE = {"ours": dict(color="C0", ls="-", label="ours"), "mujoco": dict(color="C3", ls="--", label="MuJoCo C")}


def _outcome(w: dict) -> str:
    return ("finished" if w["finished"] else f"fell at {w['fell']:.0f} s" if w["fell"] is not None
            else "did not finish")


def walks_figure(walks: list[dict], panel: float = 2.6) -> Figure:
    """The figure of ``walks``: a row per controller, a column per path, each engine's walk in its panel."""
    if not walks:
        raise ValueError("no walks to draw")
    ctls = list(dict.fromkeys(w["ctl"] for w in walks))
    paths = list(dict.fromkeys(w["path"] for w in walks))
    fig = Figure(figsize=(panel * len(paths) + 0.4, panel * len(ctls) + 0.6), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(ctls), len(paths), squeeze=False)
    for i, c in enumerate(ctls):
        for j, p in enumerate(paths):
            ax = axes[i, j]
            here = [w for w in walks if w["ctl"] == c and w["path"] == p]
            if not here:
                ax.set_axis_off()
                continue
            pts = np.concatenate([[[0.0, 0.0]], np.asarray(here[0]["waypoint_xy"], float)])
            ax.plot(pts[:, 0], pts[:, 1], color="0.6", lw=1, marker="o", ms=3, zorder=1)
            notes = []
            for w in here:
                e = w.get("engine", "ours")
                xy = np.asarray(w["trajectory"], float).reshape(-1, 2)
                style = STYLE[e]
                ax.plot(xy[:, 0], xy[:, 1], color=style["color"], ls=style["ls"], lw=1.3, label=style["label"],
                        zorder=2)
                if len(xy) and (w["finished"] or w["fell"] is not None):
                    ax.plot(*xy[-1], marker="o" if w["finished"] else "x", color=style["color"], ms=6, mew=2,
                            zorder=3)
                notes.append(f"{style['label']}: {_outcome(w)}")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_title(f"{p}\n" + "\n".join(notes), fontsize=8)
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_ylabel(f"{c.rsplit('/', 1)[-1]}\ny [m]", fontsize=8)
            if i == len(ctls) - 1:
                ax.set_xlabel("x [m]", fontsize=8)
            if i == 0 and j == len(paths) - 1 and len(here) > 1:
                ax.legend(fontsize=7, loc="best")
    return fig
