"""What the study computes and at which resolution (:class:`StudySettings`), and its fixed inputs."""

from __future__ import annotations

from dataclasses import dataclass

from robolobes.linearize.model import VARIANTS

__all__ = ["StudySettings", "POSES", "MATERIALS", "PAPER", "LOBE_RANGES_RPM"]

#: Poses of the study as fractions of the pass travel.
POSES = {"start": 0.0, "middle": 0.5, "end": 1.0}
#: The two built-in cases of the study.
MATERIALS = {"aluminium": "tx200-aluminium", "steel": "tx200-steel"}
#: The paper's published results (Tab. 10-12, section 4).
PAPER = "tx200-paper-results"
#: Speed range of each material's lobe diagram, rpm.
LOBE_RANGES_RPM = {"aluminium": (10000.0, 25000.0), "steel": (1000.0, 6000.0)}


@dataclass(frozen=True)
class StudySettings:
    """Resolution of the study. ``quick``: coarser grids and shorter runs, same conclusions.

    Attributes
    ----------
    n_rpm : int                 speeds per lobe diagram
    lobe_variants : tuple       variants whose diagrams are drawn (operating points: all)
    lobe_poses : tuple          poses of the operating-point and diagram computations
    sdm_m : int                 SDM steps per principal period (Richardson with 2m on top)
    td_linearized : bool        time domain on the linearized fast path (else the full model)
    steel_t_end_s : float|None  simulated steel time, s (None: whole pass, 22 s; 6 s covers the
                                entry and 3.5 s of full engagement)
    al_t_end_s : float|None     simulated aluminium time, s (None: whole pass, 1.75 s)
    damping_scales : tuple      joint-damping scales tried for steel, then bisected
    damping_tol : float         width of the final [largest unstable, smallest stable] bracket of
                                the lobes' search (the time domain's is at least 0.15)
    identify_facts : tuple      the seed's facts confronted with identification
                                (:mod:`robolobes.study.force_facts`): ``"tab10"`` (a, minutes: full
                                study only) and ``"steel"`` (b, about 15 s)
    """

    quick: bool = False
    n_rpm: int = 200
    lobe_variants: tuple = VARIANTS
    lobe_poses: tuple = tuple(POSES)
    sdm_m: int = 40
    td_linearized: bool = False
    steel_t_end_s: float | None = 6.0
    al_t_end_s: float | None = None
    damping_scales: tuple = (1.0, 10.0, 20.0, 40.0)
    damping_tol: float = 0.1
    identify_facts: tuple = ("tab10", "steel")

    @property
    def td_damping_tol(self) -> float:
        """Bracket width of the time-domain damping search (each probe is a whole steel run)."""
        return max(self.damping_tol, 0.15)

    @staticmethod
    def make(quick: bool) -> "StudySettings":
        if quick:
            return StudySettings(quick=True, n_rpm=40, lobe_variants=("basic", "orthogonal"),
                                 lobe_poses=("start",), td_linearized=True, steel_t_end_s=5.5,
                                 al_t_end_s=None, damping_tol=0.15, identify_facts=("steel",))
        return StudySettings()
