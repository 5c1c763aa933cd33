"""A `.ctl` controller as the commands read it: its coefficients or closed loop for a model, and the replay settings
its header gives (``simulate``, ``robustness``, ``render``, ``follow``, ``crosscheck``, ``tools``)."""

from __future__ import annotations

import argparse

import numpy as np


def load_controller(ctl: str | None, model):
    """The controller of ``ctl`` for ``model`` (zeros without one) and its name: CPG coefficients [n_ctrl, 2K+1],
    or a closed-loop controller (:func:`cpgjax.episode.policy.from_control`)."""
    from cpgjax.episode.policy import from_control
    from cpgjax.io.ctl import read_ctl

    if not ctl:
        return np.zeros((model.n_ctrl, model.n_coeff)), "-"
    c = read_ctl(ctl, n_dof=model.n_ctrl, harmonics=model.episode.harmonics)
    return from_control(c, model), ctl


def header_settings(ctls: list[str], args: argparse.Namespace, takes: tuple[str, ...] = ("pipeline", "time", "terrain"),
                    model: str | None = None):
    """The :class:`~cpgjax.io.ctl.Replay` settings of the controllers ``ctls`` on ``model`` (``args.model``): the
    options ``takes`` names, given, else their headers' (a header made for another model, or a contradicted
    pipeline, is refused: :func:`cpgjax.io.ctl.replay_settings`)."""
    from cpgjax.io.ctl import read_ctl, replay_settings
    from cpgjax.io.ctl_header import OPTION

    given = {k: getattr(args, OPTION.get(k, k), None) if k in takes else None
             for k in ("pipeline", "time", "terrain", "command")}
    return replay_settings([read_ctl(c) for c in ctls], model or args.model, **given, takes=takes)
