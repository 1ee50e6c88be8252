"""Seeded draws of FRF sets from the independent generator, run through ``robolobes identify``, and the
rule that says whether an answer is right (stated here once, before any draw was run).

Cases (``CASES``): ``mode_xy+joint``, ``mode_xy+payload``, ``joint+servo`` (pairs of library effects a
user meets together; the tool-holder mode is in both radial directions, the usual case),
``load_k`` and ``load_k+payload`` (axis 3's gear stiffening with its static gravity torque,
``k = k0 (1 + c min(|tau| / T, 1))``, slope ``kappa = c / T`` drawn in 0.8-1.8 per kN m, twice the
library's 0.40 detection threshold or more, ``T`` in 600-1500 N m with ``c <= 2``; alone and with the
payload mass off), ``sensor_gain`` (the hammer's calibration: since issue 20 the library's ``channel_scale``),
``base_z`` (a vertical floor compliance under the base, 40-80 Hz for the whole robot: the library's
``mount_z`` since 2026-12-06) and ``base_z+joint`` (with a joint's stiffness off), ``base_rock`` (the base
rocking about base x and y on one stiffness, the rigid robot's rocking at 25-60 Hz on ~815 kg m^2, damping
ratio 5 % there: the library's ``mount_rock``) and ``base_rock+joint``, ``highpass`` and
``arm_bend`` (effects no library element represents: the DAQ's first-order AC coupling at 0.5-2 Hz
on the response channels; the arm bending sideways halfway between axes 2 and 3, 1.5e6-4e6 N m/rad,
a mode at 35-55 Hz), ``null`` (nothing added).
6 poses x 4 pairs (xx, yy, zz, xy), 400 lines 2-300 Hz, relative noise drawn in 1-3 %.

What "right" means (:func:`judge`):

* a library pair: every added effect is matched by an identified effect (``identified`` in the
  JSON: credible, not a surrogate), and nothing else is identified:
  - the tool mode: every identified ``tcp_mode`` within 3 % of a generated mode's frequency, and at
    least one identified; a ``tcp_mode_xy`` (the planar oscillator, a default candidate since
    2026-12-06) counts as its two modes, ``freq1_hz`` and ``freq2_hz``, each judged the same way;
  - a joint's stiffness x s: ``joint_correction_aN`` or ``servo_aN`` of that axis whose static stiffness
    scale (``stiffness_scale``; ``kp_scale / (1 + kp_scale)`` for a servo) is within 2 sigma of s or 3 %;
  - the servo (J, kp, kd) of axis N: ``servo_aN`` or ``joint_correction_aN``, the same static
    stiffness scale covering ``kp / (k + kp)`` (the combination the data determine below the rotor
    resonance);
  - the payload mass x f: ``payload_mass`` with ``mass_scale`` within 2 sigma of f or 3 %;
  - the load law of axis 3 (``load_k``): ``load_k_a3`` with ``stiffening_per_knm`` within 2 sigma or 3 %
    of ``kappa = c / T`` (per kN m). Every pose of the set loads axis 3 below 0.3 kN m < ``T``, so the
    data determine the slope only, never ``c`` and ``T`` apart: the slope is what is judged. Over the
    set's torque span (18-265 N m) the drawn slopes change the stiffness by 20-44 % from pose to pose,
    beyond what a constant scale (``joint_correction_a3``) fits, so a joint correction in its place is
    not right;
  - the floor compliance k (``base_z``): ``mount_z`` with ``stiffness_n_per_m`` within 2 sigma of k or 3 %;
  - the rocking k (``base_rock``): ``mount_rock`` with ``stiffness_n_m_per_rad`` within 2 sigma of k or 3 %;
  - the hammer's gain g (``sensor_gain``): ``channel_scale`` with every response channel's scale
    within 3 of its standard deviations (or its 3 % detection threshold, when wider) of ``1 / g`` (the
    hammer is the gauge, identify/chain_effects.py);
* an effect outside the library: nothing identified (the residual called unexplained, or every
  effect kept labelled a surrogate);
* a null: nothing identified and the residual not called unexplained.

The noise-floor check (``floor_ok``): the reported noise floor within 20 % of the generating model's
error on the data (``noise_error``).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import time
from pathlib import Path

import numpy as np

from .tx200 import K_JOINT, Effects, write_frf_set

__all__ = ["CASES", "draw", "run_identify", "judge", "run_case"]

CASES = ("mode_xy+joint", "mode_xy+payload", "joint+servo", "sensor_gain", "base_z", "base_z+joint", "base_rock",
         "base_rock+joint", "highpass",
         "arm_bend", "load_k", "load_k+payload", "null")
OUTSIDE = ("highpass", "arm_bend")     # effects no library element represents
# detection thresholds of the chain effects (identify/chain_effects.py), typed here: the floor of the
# interval a chain parameter is judged with
CHAIN_DETECT = {"scale_x": 0.01, "scale_y": 0.01, "scale_z": 0.01, "delay_s": 5e-6, "mass_kg": 0.005}
N_POSES, N_LINES = 6, 400
ROBOT_MASS_KG = 226 + 364 + 256 + 99 + 41 + 14 + 0.6 + 44.4
# the robot's inertia about base x and y through the base origin, kg m^2: 728-927 over the six poses of a
# set (the generator's mass matrix on its rocking coordinates), a round middle value sets the drawn
# rocking frequency (the truth judged is the stiffness, not the frequency)
ROCK_INERTIA_KG_M2 = 815.0


def _either(rng, lo_hi_low, lo_hi_high) -> float:
    return float(rng.uniform(*lo_hi_low) if rng.random() < 0.5 else rng.uniform(*lo_hi_high))


def _modes_xy(rng) -> tuple:
    f = float(rng.uniform(150.0, 260.0))
    m = float(rng.uniform(0.15, 0.4))            # modal mass, kg: a holder mode well above the noise
    zeta = float(rng.uniform(0.02, 0.05))
    fy = f * float(rng.uniform(1.02, 1.06))      # nearly symmetric holder
    return ((f, zeta, m * (2 * math.pi * f) ** 2, (1.0, 0.0, 0.0)),
            (fy, zeta * float(rng.uniform(0.9, 1.1)), m * (2 * math.pi * fy) ** 2, (0.0, 1.0, 0.0)))


def draw(case: str, seed: int) -> tuple[Effects, dict, float]:
    """``(effects, truth, rel_noise)`` of draw ``seed`` of ``case`` (parameters beyond the effects'
    detection thresholds)."""
    rng = np.random.default_rng(seed)
    noise = float(rng.uniform(0.01, 0.03))
    truth: dict = {}
    if case in ("mode_xy+joint", "mode_xy+payload"):
        modes = _modes_xy(rng)
        truth["tool_modes_hz"] = [m[0] for m in modes]
        if case == "mode_xy+joint":
            j = int(rng.integers(1, 4))
            s = _either(rng, (0.6, 0.85), (1.2, 1.6))
            truth["axes"] = {j: s}
            return Effects(tool_modes=modes, joint_scale={j: (s, 1.0)}), truth, noise
        f = _either(rng, (0.75, 0.88), (1.12, 1.3))
        truth["payload_factor"] = f
        return Effects(tool_modes=modes, payload_factor=f), truth, noise
    if case == "joint+servo":
        j = int(rng.choice([1, 3]))
        s = _either(rng, (0.6, 0.85), (1.2, 1.6))
        kp_scale = float(rng.uniform(1.5, 4.0))
        k = K_JOINT[1]
        f_rotor = float(rng.uniform(60.0, 150.0))
        J = (k + kp_scale * k) / (2 * math.pi * f_rotor) ** 2
        kd = 2 * float(rng.uniform(0.1, 0.3)) * math.sqrt((k + kp_scale * k) * J)
        truth["axes"] = {j: s, 2: kp_scale / (1 + kp_scale)}
        return Effects(joint_scale={j: (s, 1.0)}, servo=(2, J, kp_scale * k, kd)), truth, noise
    if case == "sensor_gain":
        gain = _either(rng, (0.93, 0.96), (1.04, 1.07))
        truth["channel_scale"] = {f"scale_{c}": 1.0 / gain for c in "xyz"}
        return Effects(sensor_gain=gain), truth, noise
    if case == "highpass":
        return Effects(highpass_hz=float(rng.uniform(0.5, 2.0))), truth, noise
    if case in ("base_z", "base_z+joint"):
        f = float(rng.uniform(40.0, 80.0))
        k = ROBOT_MASS_KG * (2 * math.pi * f) ** 2
        truth["mount_z"] = k
        base = (k, 2 * 0.05 * math.sqrt(k * ROBOT_MASS_KG))
        if case == "base_z":
            return Effects(base_z=base), truth, noise
        j = int(rng.integers(1, 4))
        s = _either(rng, (0.6, 0.85), (1.2, 1.6))
        truth["axes"] = {j: s}
        return Effects(base_z=base, joint_scale={j: (s, 1.0)}), truth, noise
    if case in ("base_rock", "base_rock+joint"):
        w = 2 * math.pi * float(rng.uniform(25.0, 60.0))
        k = ROCK_INERTIA_KG_M2 * w ** 2
        truth["mount_rock"] = k
        c = 2 * 0.05 * k / w                                # damping ratio 5 % at the rocking frequency
        rock = (k, k, c, c)
        if case == "base_rock":
            return Effects(base_rock=rock), truth, noise
        j = int(rng.integers(1, 4))
        s = _either(rng, (0.6, 0.85), (1.2, 1.6))
        truth["axes"] = {j: s}
        return Effects(base_rock=rock, joint_scale={j: (s, 1.0)}), truth, noise
    if case in ("load_k", "load_k+payload"):
        kappa = float(rng.uniform(0.8, 1.8))              # per kN m
        T = float(rng.uniform(600.0, min(1500.0, 2000.0 / kappa)))
        truth["load_k"] = kappa
        pf = 1.0
        if case == "load_k+payload":
            pf = _either(rng, (0.75, 0.88), (1.12, 1.3))
            truth["payload_factor"] = pf
        return Effects(load_k=(3, kappa * T / 1000.0, T), payload_factor=pf), truth, noise
    if case == "arm_bend":
        return Effects(arm_bend=(float(rng.uniform(1.5e6, 4e6)), float(rng.uniform(300.0, 900.0)))), truth, noise
    if case == "null":
        return Effects(), truth, noise
    raise ValueError(f"case {case!r}; valid: {', '.join(CASES)}")


def run_identify(directory, extra_args=()) -> tuple[dict, float]:
    """``robolobes identify --measured DIR --json --quiet --no-poles`` in this process: (JSON, CPU s)."""
    from robolobes.main import main

    buf, err = io.StringIO(), io.StringIO()
    t0 = time.process_time()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(err):
        rc = main(["identify", "--measured", str(directory), "--json", "--quiet", "--no-poles", *extra_args])
    cpu = time.process_time() - t0
    if rc != 0:
        raise RuntimeError(f"robolobes identify exited {rc}: {err.getvalue()[-2000:]}")
    return json.loads(buf.getvalue()), cpu


def _static_scale(e: dict) -> tuple[float, float] | None:
    p, u = e["params"], e["uncertainty"]
    if e["name"].startswith("joint_correction_a"):
        return p["stiffness_scale"], u["stiffness_scale"]
    if e["name"].startswith("servo_a"):
        kp, skp = p["kp_scale"], u["kp_scale"]
        return kp / (1 + kp), skp / (1 + kp) ** 2
    return None


def _covers(est: float, sd: float, true: float) -> bool:
    return abs(est - true) <= max(2 * sd, 0.03 * abs(true))


def chain_covered(name: str, true: dict, hit: list) -> str:
    """'' when some identified effect of ``hit`` (JSON) has each parameter of ``true`` within 3 of its
    standard deviations or its detection threshold (:data:`CHAIN_DETECT`), else why not."""
    for e in hit:
        if all(abs(e["params"][k] - v) <= max(3 * e["uncertainty"][k], CHAIN_DETECT[k]) for k, v in true.items()):
            return ""
    return f"{name} {true} not covered by {[(e['params'], e['uncertainty']) for e in hit]}"


def judge_axes(truth: dict, ident: list, why: list) -> set:
    """The ids of the joint and servo effects of ``ident`` (JSON); appends to ``why`` each axis of
    ``truth["axes"]`` whose static stiffness scale none of them covers (within 2 sigma or 3 %, `_covers`)."""
    used = set()
    for axis, s in truth.get("axes", {}).items():
        hit = [e for e in ident if e["name"] in (f"joint_correction_a{axis}", f"servo_a{axis}")]
        ok = [e for e in hit if (sc := _static_scale(e)) is not None and _covers(*sc, s)]
        if not ok:
            why.append(f"axis {axis} static scale {s:.3f} not covered by {[(e['name'], _static_scale(e)) for e in hit]}")
        used |= {id(e) for e in hit}
    return used


def verdict(ident: list, used: set, res: dict, why: list) -> tuple[bool, str]:
    """Right when ``why`` is empty, no effect of ``ident`` is left outside ``used`` and the residual is
    explained; else the reasons."""
    extra = [e["name"] for e in ident if id(e) not in used]
    if extra:
        why.append(f"also named {extra}")
    if res["unexplained"]["unexplained"]:
        why.append(f"residual unexplained ({res['unexplained']['ratio_to_noise_floor']:.3g}x the noise floor)")
    return (not why), "; ".join(why)


def judge(case: str, truth: dict, res: dict) -> tuple[bool, str]:
    """Whether ``res`` (the identify JSON) is right for a draw of ``case`` (module doc), and why not."""
    ident = [e for e in res["effects"] if e["name"] in res["identified"]]
    if case == "sensor_gain":
        hit = [e for e in ident if e["name"] == "channel_scale"]
        why = [w for w in (chain_covered("channel_scale", truth["channel_scale"], hit),) if w]
        why += [f"also named {[e['name'] for e in ident if e not in hit]}"] if len(hit) < len(ident) else []
        why += ["residual unexplained"] if res["unexplained"]["unexplained"] else []
        return (not why), "; ".join(why)
    if case in OUTSIDE:
        return (not ident), ("" if not ident else f"named {[e['name'] for e in ident]} as findings")
    if case == "null":
        ok = not ident and not res["unexplained"]["unexplained"]
        return ok, "" if ok else f"named {[e['name'] for e in ident]}, unexplained {res['unexplained']['unexplained']}"
    used, why = set(), []
    modes = [e for e in ident if e["name"] in ("tcp_mode", "tcp_mode_xy")]
    if "tool_modes_hz" in truth:
        freqs = [e["params"][k] for e in modes for k in ("freq_hz", "freq1_hz", "freq2_hz") if k in e["params"]]
        good = [f for f in freqs if min(abs(f / g - 1) for g in truth["tool_modes_hz"]) <= 0.03]
        if not good or len(good) < len(freqs):
            why.append(f"tool modes {[round(f, 1) for f in freqs]} vs {truth['tool_modes_hz']}")
        used |= {id(e) for e in modes}
    used |= judge_axes(truth, ident, why)
    for truth_key, name, key, label in (("payload_factor", "payload_mass", "mass_scale", "payload scale"),
                                        ("mount_z", "mount_z", "stiffness_n_per_m", "mount k (N/m)"),
                                        ("mount_rock", "mount_rock", "stiffness_n_m_per_rad", "rocking k (N m/rad)"),
                                        ("load_k", "load_k_a3", "stiffening_per_knm", "load_k kappa (per kN m)")):
        if truth_key in truth:
            used |= _judge_one(ident, name, key, truth[truth_key], label, why)
    return verdict(ident, used, res, why)


def _judge_one(ident: list, name: str, key: str, true: float, label: str, why: list) -> set:
    """The ids of the effects ``name`` in ``ident``; a reason appended to ``why`` unless one of them
    covers ``true`` with its parameter ``key`` (:func:`_covers`)."""
    hit = [e for e in ident if e["name"] == name]
    if not any(_covers(e["params"][key], e["uncertainty"][key], true) for e in hit):
        why.append(f"{label} {true:.4g} not covered by {[(e['params'][key], e['uncertainty'][key]) for e in hit]}")
    return {id(e) for e in hit}


def run_case(case: str, seed: int, tmp: Path, n_poses: int = N_POSES, n_lines: int = N_LINES) -> dict:
    """Write draw ``seed`` of ``case`` under ``tmp``, identify it, judge it. Returns a summary dict."""
    effects, truth, noise = draw(case, seed)
    d = Path(tmp) / f"{case}_{seed}"
    t = write_frf_set(d, effects, n_poses=n_poses, f_hz=np.linspace(2.0, 300.0, n_lines), rel_noise=noise,
                      seed=seed)
    res, cpu = run_identify(d)
    ok, why = judge(case, truth, res)
    floor_ratio = res["noise_floor"] / t["noise_error"]
    return {"case": case, "seed": seed, "right": ok, "why": why, "cpu_s": cpu, "rel_noise": noise,
            "identified": res["identified"], "effects": [e["name"] for e in res["effects"]],
            "unexplained": res["unexplained"]["unexplained"], "ratio": res["unexplained"]["ratio_to_noise_floor"],
            "noise_floor": res["noise_floor"], "noise_error": t["noise_error"], "floor_ratio": floor_ratio,
            "floor_ok": abs(floor_ratio - 1) <= 0.2, "error_before": res["error_before"],
            "error_after": res["error_after"], "truth": truth}
