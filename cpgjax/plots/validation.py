"""The thesis's validation figures (Ch. 6.1, Figs. 6.1-6.4) and Table A.1, from the experiments' results.

* :func:`fig_6_1` — one period of the drive and the joint's angle (ours and MuJoCo), one panel
  per amplitude, with the absolute error below (thesis Fig. 6.1);
* :func:`fig_6_2` — relative mean absolute error vs frequency, per amplitude and engine, the
  sigmoid fits, the cut-offs, the linear closed forms and the thesis robot's 0.74 Hz (Fig. 6.2);
* :func:`fig_6_3` / :func:`fig_6_4` — a controller's knee and hip angles, and its CM path, in the
  penalty simulator and in MuJoCo C (MuJoCo in the place of the real robot);
* :func:`table_a1` — Table A.1 as markdown from ``cpgjax bench --table-a1 --json``'s rows.

Every figure function returns a matplotlib ``Figure`` (Agg canvas, no global backend change).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from cpgjax.analysis.cutoff import sigmoid

COLORS = {"penalty": "C0", "mujoco": "C3"}
LABELS = {"penalty": "penalty simulator", "mujoco": "MuJoCo C"}


def _figure(nrows=1, ncols=1, size=(7.5, 4.5), **kw):
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    return fig, fig.subplots(nrows, ncols, squeeze=False, **kw)


def fig_6_2(out: dict) -> Figure:
    """Relative tracking error vs drive frequency with the sigmoid fits and cut-offs (thesis Fig. 6.2)."""
    fig, ax = _figure(size=(8, 4.8))
    ax = ax[0, 0]
    f = np.asarray(out["freqs"])
    fine = np.linspace(0.0, f.max(), 400)
    styles = ["-", "--", ":", "-."]
    for name, e in out["engines"].items():
        for i, a in enumerate(out["amps"]):
            ls = styles[i % len(styles)]
            ax.plot(f, e["rel"][i], "o", color=COLORS.get(name), ms=4, alpha=0.8)
            fit = e["fits"][i]
            ax.plot(fine, sigmoid(fine, fit["a"], fit["b"]), ls, color=COLORS.get(name), lw=1.2,
                    label=f"{LABELS.get(name, name)}, A = {a:g} rad: cut-off {fit['b']:.1f} Hz")
    cf = out["closed_form"]
    ff = np.asarray(cf["fine_freqs"])
    ax.plot(ff, cf["nominal"]["fine"], color="0.4", lw=0.8,
            label=f"linear PD on the inertia, kd = {cf['nominal']['kd']:.3g}: {cf['nominal']['cutoff_hz']:.1f} Hz")
    ax.axvline(out["summary"]["thesis_cutoff_hz"], color="k", lw=0.8, ls=":")
    ax.text(out["summary"]["thesis_cutoff_hz"], 1.02, " robot (thesis): 0.74 Hz", fontsize=8, va="bottom")
    ax.set_xlabel("drive frequency [Hz]")
    ax.set_ylabel("mean |error| / mean |target excursion|")
    ax.set_ylim(-0.02, 1.25)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right")
    ax.set_title(f"{out['joint']}: tracking error vs frequency (cf. thesis Fig. 6.2)")
    return fig


def fig_6_1(out: dict) -> Figure:
    """One period of the recorded drive: target and angle (ours, MuJoCo), and |error| (cf. thesis Fig. 6.1)."""
    amps = out["amps"]
    fig, axes = _figure(2, len(amps), size=(3.6 * len(amps), 5), sharex=True)
    first = next(iter(out["engines"].values()))["trace"]
    freq = first["freq"]
    period = 1.0 / freq
    for name, e in out["engines"].items():
        tr = e["trace"]
        t = np.asarray(tr["t"])
        m = t >= t[-1] - period
        phase = (t[m] - (t[-1] - period)) / period * 360.0
        for i, a in enumerate(amps):
            ang, tgt = np.asarray(tr["angle"][i])[m], np.asarray(tr["target"][i])[m]
            if name == "penalty":
                axes[0, i].plot(phase, tgt, "k:", lw=1, label="target")
            axes[0, i].plot(phase, ang, color=COLORS.get(name), lw=1.2, label=LABELS.get(name, name))
            axes[1, i].plot(phase, np.abs(tgt - ang), color=COLORS.get(name), lw=1.2)
            axes[0, i].set_title(f"A = {a:g} rad, {freq:g} Hz", fontsize=9)
            axes[1, i].set_xlabel("phase [deg]")
    axes[0, 0].set_ylabel(f"{out['joint']} [rad]")
    axes[1, 0].set_ylabel("|error| [rad]")
    axes[0, 0].legend(fontsize=7)
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    fig.suptitle(f"one period of a {freq:g} Hz drive (cf. thesis Fig. 6.1)")
    return fig


def fig_6_3(traces: dict, label: str = "") -> Figure:
    """Knee and hip angle of the front right leg, penalty simulator vs MuJoCo C (cf. thesis Fig. 6.3).

    ``traces``: `cpgjax.crosscheck.compare.traces`' dict.
    """
    names = traces["joint_names"]
    pick = [n for n in ("KneeAR", "HipAR") if n in names] or list(names[:2])
    fig, axes = _figure(len(pick), 1, size=(7.5, 2.5 * len(pick)), sharex=True)
    for ax, n in zip(axes[:, 0], pick, strict=True):
        j = names.index(n)
        ax.plot(traces["penalty"]["t"], traces["penalty"]["angle"][:, j], color=COLORS["penalty"],
                label=LABELS["penalty"])
        ax.plot(traces["mujoco"]["t"], traces["mujoco"]["angle"][:, j], color=COLORS["mujoco"], alpha=0.8,
                label=LABELS["mujoco"])
        if traces["target"].get(n) is not None:
            ax.plot(traces["penalty"]["t"], traces["target"][n], "k:", lw=1, label="CPG target")
        ax.set_ylabel(f"{n} [rad]")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(f"joint angles{', ' + label if label else ''} (cf. thesis Fig. 6.3)")
    return fig


def fig_6_4(traces: dict, label: str = "") -> Figure:
    """(A) Y of the CM vs time with the linear fits' speeds, (B) the CM path in X-Y (cf. thesis Fig. 6.4)."""
    fig, axes = _figure(1, 2, size=(10, 3.8))
    a, b = axes[0]
    for name in ("penalty", "mujoco"):
        t, cm = traces[name]["t"], traces[name]["cm"]
        v = np.polyfit(t, cm[:, 1], 1)[0]
        a.plot(t, cm[:, 1], color=COLORS[name], label=f"{LABELS[name]} ({v:+.3f} m/s)")
        b.plot(cm[:, 0], cm[:, 1], color=COLORS[name], label=LABELS[name])
    a.set_xlabel("time [s]")
    a.set_ylabel("Y of the CM [m]")
    a.legend(fontsize=8)
    b.set_xlabel("X [m]")
    b.set_ylabel("Y [m]")
    b.set_aspect("equal", adjustable="datalim")
    for ax in (a, b):
        ax.grid(alpha=0.3)
    fig.suptitle(f"CM path{', ' + label if label else ''} (cf. thesis Fig. 6.4)")
    return fig


def _times(x: float) -> str:
    return f"{x:.2g}×" if x < 10 else f"{x:,.0f}×"


def table_a1(rows: list[dict]) -> str:
    """Table A.1 (markdown) from `cpgjax.experiments.slowdown.table_a1`'s rows."""
    lines = ["| example | DOFs | simulated [s] | thesis slowdown (1999) | slowdown, 1 robot | "
             "speed-up vs 1999 | batch | slowdown per robot in the batch | batch gain |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['example']} | {r['dofs']} | {r['sim_time']:g} | {r['thesis_slowdown']:g} | "
                     f"{r['slowdown_one']:.3g} | {_times(r['thesis_slowdown'] / r['slowdown_one'])} | {r['batch']} | "
                     f"{r['slowdown_per_robot']:.3g} | {_times(r['slowdown_one'] / r['slowdown_per_robot'])} |")
    return "\n".join(lines)
