"""The tool tip on the robot: tool, holder and spindle modes as TCP oscillators.

One representation serves every source of tool-tip dynamics: a chain of
:class:`robolobes.linearize.tool.TcpOscillator` (a mass on two orthogonal springs in the plane
normal to the tool, or on one spring along any direction), added to the robot as elements, so the
robot's M, C, K carry the tool and the tool's mass loads the robot. It is the same class as
identify's ``tcp_mode`` and ``tcp_mode_xy`` effects add. The sources (:func:`tool_from_files`):

* ``--tool-modes FILE.toml`` with ``[[oscillators]]`` tables: the oscillators themselves (keys of
  the ``tcp_oscillator`` element; angles and directions in the TCP frame);
* ``--tool-modes FILE.toml`` with ``[[modes]]`` tables (the file of ``lobes --modal``; directions in
  the cut frame): each real mode becomes a one-axis oscillator of its modal mass ``k / w_n^2``,
  chained in file order;
* ``--tool-frf FILE|DIR`` with ``--tool-frf-axes=FEED,NORMAL``: a tool-holder FRF measured on a rigid
  base, fitted by :func:`lobes.modal_fit.fit_modal` (a fit that is not credible is refused), each
  fitted complex mode replaced by its nearest real mode (:func:`real_modes`), then as ``[[modes]]``.

A conversion is exact for real modes whose directions are mutually orthogonal (each oscillator takes
its mass from the one it sits on, so every axis carries its own mode's mass). Otherwise (parallel
or oblique modes, complex residues) it changes the rigid-base receptance; the change is computed
(:func:`conversion_loss`) and stated, and above :data:`MAX_LOSS` the file is refused.

Mode directions are in the cut frame; oscillators are fixed to the spindle (TCP frame). A set read
from modes is turned into the TCP frame at one pose (:meth:`ToolSet.in_tcp_frame`): the lobes'
pose, or a map's reference pose (the pass start), after which the holder turns with the spindle.
For an axisymmetric holder (equal modes in x and y) the frame makes no difference.

Why not the series formula ``H = H_robot + H_tool`` (:func:`lobes.structure.in_series`): it
leaves out the tool's inertia on the robot, an error of the order of the tool's mass over the
robot's apparent mass at the TCP at the tool's frequency (about 2 kg across the TX200's wrist at
200-900 Hz); see docs/guide/hammer-test.md and tests/test_tool_oscillator.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from robolobes.linearize.tool import TcpOscillator, chain_receptance

from ._errors import LobeError
from .structure import ComplexMode, ModalStructure, Mode

__all__ = ["ToolSet", "with_tool", "tool_from_files", "tool_from_modes", "oscillators_from_modes", "real_modes", "conversion_loss", "MAX_LOSS",
           "ASSUMPTION"]

#: largest conversion loss accepted (max |H_converted - H_given| / max |H_given| on the modes' band):
#: the same 5 % a modal fit may deviate from the measurement (:mod:`lobes.modal_fit`): the depth
#: limit scales with 1 / |Re G| at a lobe minimum, so the limits move by about as much
MAX_LOSS = 0.05

ASSUMPTION = ("tool as planar TCP oscillators in the robot's M, C, K (the tool's mass loads the robot; no rotational "
              "coupling; the oscillators turn with the spindle)")


@dataclass(frozen=True)
class ToolSet:
    """A chain of TCP oscillators, with the frame its angles are in.

    Attributes
    ----------
    oscillators : tuple of TcpOscillator
    frame : {"tcp", "cut"}
        ``"tcp"``: angles from TCP x; ``"cut"``: angles from the cut frame's x_c (the feed), to be
        turned into the TCP frame at a pose (:meth:`in_tcp_frame`).
    source : str
    notes : tuple of str
        What the conversion did and lost (one line each).
    """

    oscillators: tuple
    frame: str
    source: str = ""
    notes: tuple = ()

    def in_tcp_frame(self, R_tcp: np.ndarray, feed_direction) -> tuple:
        """The oscillators with TCP-frame angles at a pose: ``R_tcp`` (3, 3) the TCP axes in base
        coordinates (columns), ``feed_direction`` (3,) base frame."""
        if self.frame == "tcp":
            return self.oscillators
        from robolobes.cases.milling import cut_frame

        R = np.asarray(R_tcp, dtype=float)
        Rc = cut_frame(np.asarray(feed_direction, dtype=float), R[:, 2])
        out = []
        for o in self.oscillators:
            if o.direction is not None:     # (x_c, y_c, z_c) components to TCP ones
                out.append(replace(o, direction=tuple(R.T @ (Rc.T @ np.asarray(o.direction)))))
                continue
            u = R.T @ (math.cos(o.angle_rad) * Rc[0] + math.sin(o.angle_rad) * Rc[1])
            out.append(replace(o, angle_rad=math.atan2(u[1], u[0])))
        return tuple(out)


def real_modes(mode: ComplexMode) -> tuple:
    """The real modes nearest a complex one: the symmetric real part of its modal constants
    ``2 i w_d R`` (2, 2) written as ``sum_i d_i d_i^T / m_i`` (eigenvalues ``1 / m_i``, eigenvectors
    ``d_i``), keeping each ``i`` whose ``1 / m_i`` is at least :data:`MAX_LOSS` of the largest (a
    smaller one moves the peak by less than that; what is dropped shows in :func:`conversion_loss`).

    Raises LobeError when there is no positive eigenvalue (no mass: not a mode of a structure).
    """
    A = np.real(mode.modal_constants)
    lam, V = np.linalg.eigh(0.5 * (A + A.T))
    if lam[-1] <= 0:
        raise LobeError(f"the fitted mode at {mode.freq_hz:.5g} Hz has no positive modal constant: it is not a "
                        "mode of a mass on springs")
    w2 = (2 * math.pi * mode.freq_hz) ** 2
    return tuple(Mode(mode.freq_hz, mode.damping_ratio, w2 / lam[i], (float(V[0, i]), float(V[1, i])))
                 for i in (1, 0) if lam[i] >= MAX_LOSS * lam[-1])


def oscillators_from_modes(modes) -> tuple:
    """One-axis oscillators (cut-frame angles), one per real mode, complex modes as :func:`real_modes`."""
    out = []
    for md in modes:
        for r in (real_modes(md) if isinstance(md, ComplexMode) else (md,)):
            d = np.asarray(r.direction, dtype=float)
            out.append(TcpOscillator(r.mass_kg, r.stiffness_n_per_m, math.inf, math.atan2(d[1], d[0]),
                                     r.damping_ratio, 0.0, name=f"tool mode {r.freq_hz:.4g} Hz"))
    return tuple(out)


def _band(modes) -> np.ndarray:
    f = np.array([m.freq_hz for m in modes])
    return 2 * math.pi * np.linspace(0.5 * f.min(), 1.5 * f.max(), 4000)


def conversion_loss(modes, oscillators) -> float:
    """``max |H_osc - H_modes| / max |H_modes|`` (2 x 2 cut-plane receptances, rigid base) on
    ``0.5 f_min .. 1.5 f_max`` of the modes, 4000 lines."""
    w = _band(modes)
    H = ModalStructure(tuple(modes)).frf(w).H[:2, :2]
    return float(np.abs(chain_receptance(oscillators, w) - H).max() / np.abs(H).max())


def tool_from_modes(modes, source: str = "modes", what: str = "modes") -> ToolSet:
    """A cut-frame :class:`ToolSet` of modes (Mode / ComplexMode, cut frame), with the conversion's
    loss as its note; LobeError above :data:`MAX_LOSS`."""
    osc = oscillators_from_modes(modes)
    loss = conversion_loss(modes, osc)
    n_complex = sum(isinstance(m, ComplexMode) for m in modes)
    how = f"{len(modes)} {what} as {len(osc)} one-axis TCP oscillators" + (
        f" ({n_complex} complex, as their nearest real modes)" if n_complex else "")
    note = f"{source}: {how}; rigid-base receptance changed by {100 * loss:.2g} % of its peak"
    if loss > MAX_LOSS:
        raise LobeError(f"{note}: more than {100 * MAX_LOSS:g} % (modes that are not mutually orthogonal, or complex "
                        "residues far from a real mode); give the tool as [[oscillators]] tables")
    return ToolSet(osc, "cut", source, (note,))


def _read_toml(path: str) -> ToolSet:
    from .modal_file import load_toml, read_modal_toml

    data = load_toml(path, "tool file")
    if "oscillators" in data and "modes" in data:
        raise LobeError(f"{path}: give either [[oscillators]] or [[modes]] tables, not both")
    if "oscillators" not in data:
        return tool_from_modes(read_modal_toml(path).modes, path, "modes")
    tabs = data["oscillators"]
    if not isinstance(tabs, list) or not tabs or not all(isinstance(t, dict) for t in tabs):
        raise LobeError(f"{path}: [[oscillators]] must be tables with mass_kg, k1_n_per_m, k2_n_per_m, angle_rad, "
                        "zeta1, zeta2 (or, with k2_n_per_m = inf, a direction in the TCP frame)")
    from robolobes.cases.spec import ElementSpec
    from robolobes.core.errors import BadInput
    from robolobes.linearize.extra_elements import element_from_spec

    osc = []
    for i, t in enumerate(tabs):
        try:
            osc.append(element_from_spec(ElementSpec(type="tcp_oscillator", params=dict(t)), f"{path}: oscillators[{i}]"))
        except BadInput as e:
            raise LobeError(str(e)) from None
    return ToolSet(tuple(osc), "tcp", path, ())


def tool_from_files(tool_modes: str | None = None, tool_frf: str | None = None, tool_frf_axes: str | None = None,
                    fit_modes: int | None = None) -> ToolSet | None:
    """The tool set of ``--tool-modes`` or ``--tool-frf`` (None when neither is given).

    Raises :class:`LobeError` (exit 2 at the command line) for both files at once, an FRF without
    its axes, a bad file, a modal fit that is not credible, or a conversion loss above :data:`MAX_LOSS`.
    """
    if tool_modes is not None and tool_frf is not None:
        raise LobeError("give either --tool-modes FILE.toml or --tool-frf FILE|DIR, not both")
    if tool_frf is None:
        if tool_frf_axes is not None:
            raise LobeError("--tool-frf-axes applies only with --tool-frf FILE|DIR")
        return None if tool_modes is None else _read_toml(tool_modes)
    if tool_frf_axes is None:
        raise LobeError("--tool-frf needs --tool-frf-axes=FEED,NORMAL: which measured axis lies along the feed and "
                        "which along the cut normal (e.g. --tool-frf-axes=x,y)")
    from robolobes.linearize.frf_io import read_tool_frf

    from .measured import MeasuredStructure
    from .modal_fit import fit_modal

    tf = read_tool_frf(tool_frf, tool_frf_axes)
    fit = fit_modal(MeasuredStructure(tf.frf.omega, tf.frf.H, cross_measured=tf.cross_measured, source=str(tool_frf)),
                    fit_modes)
    if not fit.credible:
        raise LobeError(f"{tool_frf}: the modal fit of the tool FRF is not credible ({'; '.join(fit.problems)})")
    return tool_from_modes(fit.modes, str(tool_frf), "fitted modes")


def with_tool(robot, oscillators):
    """A new :class:`~robolobes.linearize.model.FlexibleRobot`: ``robot``'s elements, then ``oscillators``
    (a chain of :class:`TcpOscillator`, TCP-frame angles) at its TCP. ``robot`` itself is unchanged."""
    from robolobes.core.errors import BadInput
    from robolobes.linearize.model import assemble

    oscillators = tuple(oscillators)
    if not oscillators:
        return robot
    bad = [type(o).__name__ for o in oscillators if not isinstance(o, TcpOscillator)]
    if bad:
        raise BadInput(f"a tool is a chain of TcpOscillator, got {', '.join(bad)}")
    variant = robot.variant if robot.variant.endswith("+") else robot.variant + "+"
    return assemble(robot.spec, tuple(robot.elements) + oscillators, variant=variant)
