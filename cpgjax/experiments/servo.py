"""`cpgjax servo`: the servo's frequency response and cut-off (thesis Ch. 6.1.1, Figs. 6.1-6.2).

One joint of a model (the quadruped's front right knee by default) on its rig
(`cpgjax.episode.tracking.servo_rig`: the first body welded to the world, the leg attached as in
the robot) follows ``A sin(2 pi f t)`` for every frequency x amplitude at once, one robot per pair
in one batch; the same drive runs in MuJoCo C on the exported rig.  Per amplitude and engine:
the relative mean absolute error vs frequency, the thesis's sigmoid fit and the cut-off at its
steepest slope (`cpgjax.analysis.cutoff`), beside the robot's 0.74 Hz.  A linear closed form
(``kp``, ``kd``, the inertia the joint moves, no gravity or saturation) is drawn beside them; the
penalty simulator's servo delivers the nominal ``kd`` (its derivative is backward Euler over the
step, `cpgjax.sim.servo.servo_torques`), up to a first-order error in ``dt``.
"""

from __future__ import annotations

import time as _time
from dataclasses import asdict, dataclass

import numpy as np

THESIS_CUTOFF_HZ = 0.74  # Fig. 6.2
MAX_TIME = 120.0         # s: the longest episode the experiment runs (its lowest frequency sets it)


@dataclass(frozen=True)
class ServoConfig:
    """The experiment's settings (defaults: the knee of the quadruped, 0.5-64 Hz, three amplitudes)."""

    joint: str = "KneeAR"
    freqs: tuple[float, ...] = (0.5, 1.0, 2.0, 4.0, 8.0, 12.0, 16.0, 20.0, 24.0, 32.0, 40.0, 48.0, 64.0)
    amps: tuple[float, ...] = (0.1, 0.2, 0.4)   # rad
    settle: float = 0.5                          # s before the error window
    periods: int = 2                             # whole periods of the lowest frequency in the window
    lift: float = 1.0                            # m: the rig's height above its robot pose
    mujoco: bool = True
    gravity: float | None = None                 # None: the file's
    tau_max: float | None = None                 # None: the file's
    pipeline: str | None = None                  # the physics pipeline; None: the file's Pipeline, else springs

    @property
    def time(self) -> float:
        return self.settle + self.periods / min(self.freqs)


def rig_model(model_path: str, cfg: ServoConfig):
    from cpgjax.episode.tracking import servo_rig
    from cpgjax.io.wl import load_wl
    from cpgjax.sim.model import build_model

    return build_model(servo_rig(load_wl(model_path), cfg.joint, lift=cfg.lift, gravity=cfg.gravity,
                                 tau_max=cfg.tau_max), pipeline=cfg.pipeline)


def run_servo(model_path: str, cfg: ServoConfig = ServoConfig(), *, record_freq: float | None = None,
              progress: bool = False) -> dict:
    """Run the experiment; returns a JSON-able dict (``summary`` holds the headline figures).

    ``record_freq``: also return the angle and target traces of that frequency (one per amplitude;
    Fig. 6.1), ``None``: none.
    """
    import jax
    from tqdm.auto import tqdm

    from cpgjax.analysis.cutoff import fit_sigmoid, linear_servo_error
    from cpgjax.episode.tracking import axis_inertia, tracking_rollout, window_start

    if len(cfg.freqs) < 3 or min(cfg.freqs) <= 0 or min(cfg.amps) <= 0:
        raise ValueError("the servo experiment needs at least 3 frequencies > 0 and amplitudes > 0")
    if cfg.time > MAX_TIME:
        raise ValueError(f"the lowest frequency {min(cfg.freqs):g} Hz needs a {cfg.time:g} s episode "
                         f"(settle + {cfg.periods} periods), more than {MAX_TIME:g} s; raise it or use fewer periods")
    rig = rig_model(model_path, cfg)
    window_start(np.asarray(cfg.freqs), cfg.time, cfg.settle)       # raises early on a bad window
    freqs, amps = np.asarray(cfg.freqs, float), np.asarray(cfg.amps, float)
    F, A = np.meshgrid(freqs, amps)                                   # [amps, freqs]
    rec = record_freq is not None
    run = jax.jit(lambda f, a: tracking_rollout(rig, f, a, time=cfg.time, settle=cfg.settle, record=rec))
    bar = tqdm(total=2 + cfg.mujoco, desc="servo", unit="stage", disable=not progress)
    bar.set_postfix_str(f"penalty simulator, {F.size} drives x {cfg.time:g} s")
    t0 = _time.perf_counter()
    ours = jax.device_get(run(F.ravel(), A.ravel()))
    wall = _time.perf_counter() - t0
    bar.update()
    engines = {"penalty": ours}
    if cfg.mujoco:
        from cpgjax.crosscheck.engines import mujoco_track

        bar.set_postfix_str("MuJoCo C")
        engines["mujoco"] = mujoco_track(rig, F.ravel(), A.ravel(), time=cfg.time, settle=cfg.settle, record=rec)
        bar.update()
    bar.set_postfix_str("sigmoid fits")

    j = int(rig.ctrl_joint[0])
    inertia = axis_inertia(rig)
    kp, kd, tmax = float(rig.j_kp[j]), float(rig.j_kd[j]), float(rig.j_taumax[j])
    out = {"config": {**asdict(cfg), "time": cfg.time}, "model": model_path, "joint": cfg.joint,
           "freqs": freqs.tolist(), "amps": amps.tolist(),
           "servo": {"kp": kp, "kd": kd, "tau_max": tmax, "inertia": inertia,
                     "dt": rig.dt, "natural_hz": float(np.sqrt(kp / inertia) / (2 * np.pi)),
                     "damping_ratio": kd / (2 * np.sqrt(kp * inertia))},
           "closed_form": {}, "engines": {}, "wall_s": wall}
    fine = np.linspace(freqs.min(), freqs.max(), 400)
    for name, k in (("nominal", kd),):
        y = linear_servo_error(freqs, inertia, kp, k)
        out["closed_form"][name] = {"kd": k, "rel": y.tolist(), "cutoff_hz": fit_sigmoid(freqs, y)["b"],
                                    "fine": linear_servo_error(fine, inertia, kp, k).tolist()}
    out["closed_form"]["fine_freqs"] = fine.tolist()
    for name, res in engines.items():
        rel = np.asarray(res["rel"], float).reshape(A.shape)
        err = np.asarray(res["err"], float).reshape(A.shape)
        fits = [fit_sigmoid(freqs, r) for r in rel]
        e = {"rel": rel.tolist(), "err": err.tolist(), "fits": fits, "cutoff_hz": [f["b"] for f in fits]}
        if rec:
            k = int(np.argmin(np.abs(freqs - record_freq)))
            idx = np.ravel_multi_index((np.arange(len(amps)), np.full(len(amps), k)), A.shape)
            e["trace"] = {"freq": float(freqs[k]), "t": np.asarray(res["t"]).tolist(),
                          "angle": np.asarray(res["angle"])[:, idx].T.tolist(),
                          "target": np.asarray(res["target"])[:, idx].T.tolist()}
        out["engines"][name] = e
    out["summary"] = summary(out)
    bar.update()
    bar.close()
    return out


def summary(out: dict) -> dict:
    """The headline figures: cut-off per amplitude and engine, the closed forms, the thesis's robot."""
    s = {"joint": out["joint"], "thesis_cutoff_hz": THESIS_CUTOFF_HZ, "amps": out["amps"]}
    for name, e in out["engines"].items():
        s[f"{name}_cutoff_hz"] = [round(b, 3) for b in e["cutoff_hz"]]
    for name in ("nominal",):
        s[f"linear_{name}_cutoff_hz"] = round(out["closed_form"][name]["cutoff_hz"], 3)
    sv = out["servo"]
    s.update({k: round(v, 6) for k, v in sv.items()})
    return s


def table(out: dict) -> str:
    """Markdown: cut-off per amplitude and engine, the closed forms and the thesis's robot."""
    eng = list(out["engines"])
    lines = ["| amplitude [rad] | " + " | ".join(f"{e} cut-off [Hz]" for e in eng) + " |",
             "|---:|" + "---:|" * len(eng)]
    for i, a in enumerate(out["amps"]):
        lines.append(f"| {a:g} | " + " | ".join(f"{out['engines'][e]['cutoff_hz'][i]:.1f}" for e in eng) + " |")
    sv = out["servo"]
    cf = out["closed_form"]
    lines += ["", f"linear closed form (I = {sv['inertia']:.3g} kg m², kp = {sv['kp']:g} N m/rad, no gravity, "
                  f"no saturation): cut-off {cf['nominal']['cutoff_hz']:.1f} Hz with kd = {sv['kd']:g} N m s/rad; "
                  f"the thesis's robot: {THESIS_CUTOFF_HZ} Hz"]
    return "\n".join(lines)
