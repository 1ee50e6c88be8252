"""The symmetric 2-DOF milling benchmark (Insperger et al. 2003, Tab. 1) shared by the lobe tests.

Not a test module: helpers and constants that several test modules use (import it as
``from lobes_benchmark import ...``; pytest puts tests/ on sys.path).

One mode per direction: f_n = 922 Hz, zeta = 0.011, modal mass 0.03993 kg (k = 1.34003e6 N/m);
a 2-tooth 10 mm tool, Kt = 600 MPa, Kr = 200 MPa.
"""

import math
from pathlib import Path

from robolobes.cases.milling import Cut, CuttingLaw, MillingMode, Tool
from robolobes.lobes import LobeProblem, Mode, ModalStructure, solve
from robolobes.lobes.sdm import SDMEngine

FN, ZETA, MT = 922.0, 0.011, 0.03993
WN = 2 * math.pi * FN
K = MT * WN**2  # 1.34003e6 N/m
DIAM = 0.01
TOOL = Tool(diameter_m=DIAM, teeth=2)
LAW = CuttingLaw(ktc_pa=6e8, krc_pa=2e8)

# the same structure and tool as a ``robolobes lobes --modal`` file and its command-line options
MODAL = (Path(__file__).resolve().parent / "data" / "two_dof_benchmark_modes.toml").read_text()

TOOLARGS = ["--teeth", "2", "--diameter-mm", "10", "--ae-mm", "0.5", "--down", "--ktc-mpa", "600", "--krc-mpa", "200"]


def problem(aD, directions=((1.0, 0.0),), mode: MillingMode = "down", rpm=10000.0, depth=1e-3, tool=TOOL, law=LAW, **cutkw):
    """The benchmark at radial immersion ``aD`` (ae / D), one mode per direction (unit, cut frame)."""
    s = ModalStructure(tuple(Mode(FN, ZETA, K, d) for d in directions))
    return LobeProblem(s, tool, Cut(ae_m=aD * DIAM, ap_m=depth, spindle_rpm=rpm, mode=mode, **cutkw), law)


def radius(p, meth, rpm=10000.0, depth=1e-3):
    """Spectral radius of the monodromy at one speed (rpm) and depth (m)."""
    e = SDMEngine(p, meth, 0.01)
    return float(e.multipliers([rpm], [depth])[0][0])


def limit(p, meth, rpm, rtol=1e-10):
    """Critical depth (m) at one speed (rpm)."""
    return float(solve(p, meth, [rpm], rtol=rtol).depth_limit_m[0])
