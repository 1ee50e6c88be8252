"""The tool tip on the robot: tool-holder modes in series with the robot at the TCP.

One representation serves every source of tool-tip dynamics: a tuple of modes
(:class:`lobes.structure.Mode` or :class:`lobes.structure.ComplexMode`), i.e. a
:class:`ModalStructure` in the cut frame, from

* ``--tool-modes FILE.toml``: the ``[[modes]]`` file of ``lobes --modal`` (real or complex modes);
* ``--tool-frf FILE|DIR`` with ``--tool-frf-axes=FEED,NORMAL``: a tool-holder FRF measured on a
  rigid base (UFF58 or CSV, as ``lobes --frf``), fitted by :func:`lobes.modal_fit.fit_modal`; a
  fit that is not credible is refused.

Coupling (:func:`lobes.structure.in_series`): the robot at the TCP and the tool on its rigid base
carry the same force and their displacements add, ``H = H_robot + H_tool`` (series receptance).
Assumed: no rotational coupling (the robot's rotation at the TCP times the tool length, and the
tool's rotational receptances, are left out), and the measured axes keep their orientation to
the feed at every pose (exact for an axisymmetric holder, ``H_xx = H_yy``, ``H_xy = 0``).
"""

from __future__ import annotations

from ._errors import LobeError

__all__ = ["tool_modes_from_files", "ASSUMPTION"]

ASSUMPTION = ("tool in series with the robot at the TCP (receptances added, no rotational coupling; the tool's "
              "measured axes keep their orientation to the feed)")


def tool_modes_from_files(tool_modes: str | None = None, tool_frf: str | None = None,
                          tool_frf_axes: str | None = None, fit_modes: int | None = None) -> tuple:
    """The tool-tip modes (tuple of Mode / ComplexMode; empty when neither file is given).

    Raises :class:`LobeError` (exit 2 at the command line) for both files at once, an FRF without
    its axes, a bad file, or a modal fit of the FRF that is not credible.
    """
    if tool_modes is not None and tool_frf is not None:
        raise LobeError("give either --tool-modes FILE.toml or --tool-frf FILE|DIR, not both")
    if tool_frf is None:
        if tool_frf_axes is not None:
            raise LobeError("--tool-frf-axes applies only with --tool-frf FILE|DIR")
        if tool_modes is None:
            return ()
        from .modal_file import read_modal_toml

        return read_modal_toml(tool_modes).modes
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
    return fit.modes
