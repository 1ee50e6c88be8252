"""Force-side effects: what the cutting model or the measurement chain may lack.

Each effect is a parametrized extension with physical bounds, added where the model composes:

==================  =====================  =========================================================
effect              enters as              parameters (SI), bounds, detection threshold
==================  =====================  =========================================================
edge_coefficients   cutting law            Kte, Kre in N/m, [0, 1e5] (0-100 N/mm); 5e3 N/m (5 N/mm)
runout              tool (tooth radii)     amplitude_m e [0, 3e-5], phase_rad phi; 2 e cos phi >= 3e-6 m
dynamometer         measurement chain      fn_hz [500, 8000], zeta [0.005, 0.3]; fn <= 6 kHz
lowpass             measurement chain      cutoff_hz [300, 20000] (4th-order Butterworth); <= 5 kHz
backlash            robot (motion axes)    half_width_rad [0, 3e-4]; 3e-5 rad (:class:`Backlash`)
joint_damping       robot (motion axes)    scale [0.2, 50] on every joint damper (stability data)
process_damping     tool tip (cut plane)   Ksp L^2 [0, 9e6] N/m (stability data, :class:`ProcessDamping`)
==================  =====================  =========================================================

The detection thresholds are for a cutting-force set of the TX200 aluminium pass (0.15 s of steady
cut, 1-3 N noise), estimated from the physics, not tuned on identification outcomes: a few times
the noise floor of the held-out average (~1 % of the force RMS). Example from the slow tests: a
runout of 3.4 um changes the average by 3.8 times the noise floor, and was found.

* **Edge coefficients** (Altintas, *Manufacturing Automation*, ch. 2): ``dFt = Ktc h db + Kte db``,
  ``dFr = Krc h db + Kre db``: a force independent of the chip while a tooth is engaged. Forces are
  linear in (Kte, Kre) for a given motion, so the fit is a linear regression on two basis runs
  (Altintas' average-force method is the same regression on mean forces only).
* **Runout**: an axis offset ``e`` at angle ``phi`` puts tooth tips at radii ``R + e cos(theta_j - phi)``
  (:func:`cases.milling.eccentric_runout`); the chip of tooth j grows by ``r_j - r_(j-1)``
  (:func:`cases.milling.regeneration`), giving once-per-revolution lines. For an equal-pitch
  two-tooth cutter only ``e cos phi`` (half of ``r_1 - r_2``) changes the forces: the phase is then
  not identifiable (see :class:`Runout`).
* **Dynamometer**: one lightly damped mode per axis, ``H = 1 / (1 - (f/fn)^2 + 2 i zeta f/fn)``, unit
  static gain: it leaves the mean force and rings after each tooth entry.
* **Low-pass**: the acquisition's anti-aliasing filter, 4th-order Butterworth at ``cutoff_hz``: it
  rounds the entry and exit edges; its delay is absorbed by the phase alignment.
* **Backlash**: the paper's dead zone on the motion axes, the element ``backlash`` in any variant
  (``basic`` included: the dead zone is in the gearboxes, not in the orthogonal compliance);
  observable in forces only (amplitude-dependent, linearization takes the gears as engaged).
* **Joint damping** and **process damping**: observed by stability observations
  (:mod:`identify.force_stability`); process damping is :class:`ProcessDamping` (parameter
  ``Ksp L^2``, the ``tip_damper`` element per cut), joint damping a scale on every joint damper.

Each effect says which measurement kinds observe it (``observed_by``); measurement-chain effects
are not part of the cut model and are written as a comment block (the case TOML keeps loading
under the strict key check).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .effects import Effect, ModelState, Parameter, check_params, register

__all__ = ["ForceEffect", "FitCoordinates", "EdgeCoefficients", "Runout", "Dynamometer", "Lowpass", "Backlash",
           "FORCE_EFFECTS", "chain_transfer", "process_damping_c", "DampingEffect", "JointDamping", "ProcessDamping",
           "KSP_RANGE_N_PER_M3", "FLANK_RANGE_M", "JOINT_DAMPING_CREDIBLE"]


@dataclass(frozen=True)
class FitCoordinates:
    """The coordinates ``u`` (Q,) a force fit searches, and the effect's values (P,) they stand for.

    ``lower``, ``upper`` : (Q,) bounds of ``u``;  ``to_values(u)`` -> (P,) values;  ``from_values(v)``
    -> (Q,) ``u``;  ``jacobian(u)`` -> (P, Q), d values / d u;  ``unresolved_sd`` : (P,) standard
    deviation of what ``u`` leaves open (0 where the values follow from ``u``), added to the values'
    covariance. The identity (Q = P, nothing open) for every effect but those that say otherwise.
    """

    lower: np.ndarray
    upper: np.ndarray
    to_values: Callable[[np.ndarray], np.ndarray]
    from_values: Callable[[np.ndarray], np.ndarray]
    jacobian: Callable[[np.ndarray], np.ndarray]
    unresolved_sd: np.ndarray


def _identity_coordinates(lower, upper) -> FitCoordinates:
    n = len(lower)
    return FitCoordinates(np.array(lower, float), np.array(upper, float), lambda u: np.asarray(u, float),
                          lambda v: np.asarray(v, float), lambda u: np.eye(n), np.zeros(n))


class ForceEffect(Effect):
    """An effect on forces (the framework's :class:`identify.effects.Effect`, registered in its
    REGISTRY) plus what the force pipelines need to fit it fast: :meth:`family` (the model's
    synchronous averages as a function of the parameter values) and :meth:`apply_values`.

    ``parameters`` carry the physical bounds and the detection threshold (``detect``) for a
    cutting-force set; ``observed_by`` names the kinds that observe the effect, with the threshold
    in words.

    ``family_exact``: whether :meth:`family` equals the simulated model at every value. When False
    (a superposition or an interpolation between runs), the force fit re-centres it on simulated
    runs at the fitted values (:func:`identify.forces._fit_effect`).
    """

    family_exact: bool = True

    @property
    def chain(self) -> bool:
        return self.stage == "chain"

    @property
    def params(self) -> tuple:
        return self.names

    @property
    def lower(self) -> tuple:
        return tuple(p.lower for p in self.parameters)

    @property
    def upper(self) -> tuple:
        return tuple(p.upper for p in self.parameters)

    @property
    def threshold(self) -> dict:
        return {p.name: p.detect for p in self.parameters if p.detect is not None}

    def reason_not_applicable(self, state: ModelState) -> str | None:
        """None if the effect can be added to ``state``, else why not."""
        return None

    def applicable(self, model: ModelState) -> bool:
        return self.reason_not_applicable(model) is None

    def apply(self, model: ModelState, params) -> ModelState:
        p = check_params(self, params)
        return self.apply_values(model, [p[n] for n in self.names])

    def apply_values(self, state: ModelState, values) -> ModelState:
        raise NotImplementedError

    def starts(self) -> list:
        """Initial values for the nonlinear fit (inside the bounds)."""
        lo, hi = np.array(self.lower), np.array(self.upper)
        return [lo + 0.3 * (hi - lo)]

    def starts_for(self, cost) -> list:
        """Initial values given the training cost ``cost(values) -> float`` of the fit (default:
        :meth:`starts`, which does not need it). An effect whose response is rough in its
        parameters scans the cost here."""
        return self.starts()

    def family(self, ctx, state: ModelState):
        """A callable ``values -> list of raw (bins, 3) averages`` for the context's blocks, before the
        state's chain (the context applies the chain). Default: re-simulate the applied state."""
        return lambda v: ctx.raw_averages(self.apply_values(state, v))

    def fit_coordinates(self, tool) -> FitCoordinates:
        """The coordinates the force fit searches for this tool (default: the parameters themselves)."""
        return _identity_coordinates(self.lower, self.upper)

    def as_dict(self, values) -> dict:
        return {k: float(v) for k, v in zip(self.params, values)}


class EdgeCoefficients(ForceEffect):
    name = "edge_coefficients"
    stage = "cutting_law"
    parameters = (Parameter("kte_n_per_m", 0.0, 1e5, neutral=0.0, detect=5e3, doc="tangential edge coefficient"),
                  Parameter("kre_n_per_m", 0.0, 1e5, neutral=0.0, detect=5e3, doc="radial edge coefficient"))
    observed_by = {"forces": "mean offsets and entry/exit steps: Kte or Kre >= 5 N/mm (8 N per tooth at ap 1.6 mm)",
                   "force_stats": "means and RMS shifted (fitted with at most 3 parameters in all)"}
    signatures = ("mean_offset",)
    doc = "edge (ploughing) forces Kte db, Kre db of an engaged edge element (Altintas)"
    #: Edge coefficients of the basis runs, N/m. The superposition is exact for the rigid tool; on the
    #: flexible robot the edge forces deflect the tool and move its engagement, so it is first order
    #: only (draws with Kte, Kre ~ 6e4 N/m fitted to twice the noise error): the fit re-centres it.
    BASIS = 2e4
    family_exact = False

    def apply_values(self, state, values):
        kte, kre = (float(v) for v in values)
        law = state.case.law
        new = replace(law, kte_n_per_m=law.kte_n_per_m + kte, kre_n_per_m=law.kre_n_per_m + kre)
        case = replace(state.case, law=new)
        st = state.with_override("material", "kte_n_per_mm", new.kte_n_per_m * 1e-3, case)
        return st.with_override("material", "kre_n_per_mm", new.kre_n_per_m * 1e-3, case)

    def family(self, ctx, state):
        # forces are linear in (Kte, Kre) for the engaged elements: F = F0 + Kte G_te + Kre G_re
        base = ctx.raw_averages(state)
        gte = [(a - b) / self.BASIS for a, b in zip(ctx.raw_averages(self.apply_values(state, (self.BASIS, 0.0))), base)]
        gre = [(a - b) / self.BASIS for a, b in zip(ctx.raw_averages(self.apply_values(state, (0.0, self.BASIS))), base)]
        return lambda v: [b + v[0] * x + v[1] * y for b, x, y in zip(base, gte, gre)]

    def starts(self):
        return [np.array([1e4, 1e4])]


class Runout(ForceEffect):
    """Runout as an axis offset: amplitude ``e`` and phase ``phi`` (:func:`cases.milling.eccentric_runout`,
    ``r_j = e cos(theta_j - phi)``, any tooth count and pitch).

    The forces depend on ``(a, b) = (e cos phi, e sin phi)`` through ``r_j = a cos theta_j + b sin theta_j``;
    the family is a cubic spline in ``a`` (5 runs) plus the change ``b`` makes at ``a = 0`` (quadratic,
    2 more runs): separable, exact without cross terms in ``(a, b)``, which are small while ``b`` only
    moves the teeth's common radius.
    For a two-tooth tool the fit has one coordinate, the one the radius difference depends on
    (:meth:`fit_coordinates`, :meth:`identifiable`): ``e cos phi`` at equal pitch (phase reported as 0
    or pi), ``e sin(p - phi)`` otherwise (``p`` half the pitch from tooth 0 to 1), with the mean radius
    set to zero.

    The phase is relative to tooth 0 of the model, whose angle at the start of the measured block is
    fixed by the force data's alignment (the fitted circular shift, ``phase_shift_rev``): the measured
    spindle angle at t = 0 is unknown, so ``phi`` is only defined relative to the aligned model, and,
    for an equal-pitch tool, only modulo the pitch (shifting the alignment by one tooth and ``phi`` by
    one pitch gives the same forces).
    """

    name = "runout"
    stage = "cutting_law"
    parameters = (Parameter("amplitude_m", 0.0, 3e-5, neutral=0.0, detect=1.5e-6,
                            doc="axis offset e: tooth j radius offset e cos(theta_j - phi)"),
                  Parameter("phase_rad", -2 * np.pi, 2 * np.pi, periodic=True,
                            doc="direction phi of the offset from tooth 0 of the aligned model"))
    observed_by = {"forces": "once-per-revolution lines: |r1 - r2| = 2 e |cos phi| >= 3 um (3 % of the 0.1 mm "
                             "chip) for two teeth",
                   "force_stats": "extremes of one tooth raised, of the other lowered"}
    signatures = ("once_per_rev",)
    doc = "tool axis offset e at angle phi: tooth-tip radii R + e cos(theta_j - phi)"
    #: Grid of a = e cos phi, m, for the family of a tool where only a shows (cubic spline).
    GRID = tuple(np.linspace(-3e-5, 3e-5, 5))
    #: Grid of b = e sin phi, m, for tools where it enters: the change b makes is added to the cubic
    #: in a (separable, quadratic in b; b moves the teeth's common radius, a weak effect).
    GRID_B = (-3e-5, 0.0, 3e-5)
    #: The spline through 5 runs 15 um apart interpolates; the fit re-centres it on simulated runs.
    family_exact = False

    @staticmethod
    def identifiable(tool) -> str:
        """``"amplitude and phase"`` (three or more teeth); for two teeth the one coordinate fitted
        (:meth:`fit_coordinates`): ``"e cos(phi) only"`` at equal pitch, else ``"e sin(p - phi) only"``."""
        if tool.teeth == 2 and abs(tool.pitch_rad[0] - np.pi) < 1e-9:
            return "e cos(phi) only"
        if tool.teeth == 2:
            return "e sin(p - phi) only"
        return "amplitude and phase"

    def apply_values(self, state, values):
        from robolobes.cases.milling import eccentric_runout

        e, phi = float(values[0]), float(values[1])
        tool = state.case.tool
        r = np.asarray(tool.runout_m, float) + eccentric_runout(tool, e, phi)
        case = replace(state.case, tool=replace(tool, runout_m=tuple(r.tolist())))
        return state.with_override("tool", "runout_um", [float(x) * 1e6 for x in r], case)

    def _apply_ab(self, state, a, b):
        return self.apply_values(state, (float(np.hypot(a, b)), float(np.arctan2(b, a))))

    def family(self, ctx, state):
        from scipy.interpolate import CubicSpline

        g = np.array(self.GRID)
        tool = state.case.tool
        if tool.teeth == 2:  # one coordinate (fit_coordinates): a spline through 5 runs of it
            fc = self.fit_coordinates(tool)
            runs = [ctx.raw_averages(self.apply_values(state, fc.to_values(np.array([u])))) for u in g]
            splines = [CubicSpline(g, np.stack([r[k] for r in runs]), axis=0) for k in range(len(runs[0]))]
            return lambda v: [s(float(fc.from_values(v)[0])) for s in splines]
        runs = [ctx.raw_averages(self._apply_ab(state, a, 0.0)) for a in g]
        splines = [CubicSpline(g, np.stack([r[k] for r in runs]), axis=0) for k in range(len(runs[0]))]
        # separable: cubic in a (5 runs, b = 0) plus the change b makes at a = 0 (quadratic, 2 more runs)
        b3 = np.array(self.GRID_B)
        base = runs[len(g) // 2]
        side = [ctx.raw_averages(self._apply_ab(state, 0.0, b)) for b in (b3[0], b3[2])]

        def db(b, k):  # quadratic Lagrange through (b3, [side0, base, side1]) minus base
            w = [np.prod([(b - b3[m]) / (b3[i] - b3[m]) for m in range(3) if m != i]) for i in range(3)]
            return w[0] * side[0][k] + w[1] * base[k] + w[2] * side[1][k] - base[k]

        def f(v):
            a, b = float(v[0]) * np.cos(float(v[1])), float(v[0]) * np.sin(float(v[1]))
            return [s(a) + db(b, k) for k, s in enumerate(splines)]
        return f

    @staticmethod
    def _half_pitch(tool) -> float:
        """Half the angle from tooth 0 to tooth 1 of a two-tooth tool, rad."""
        return 0.5 * float(np.asarray(tool.tooth_angle_rad)[1] - np.asarray(tool.tooth_angle_rad)[0])

    def fit_coordinates(self, tool) -> FitCoordinates:
        """For a two-tooth tool, the one coordinate the forces determine: ``s = e sin(p - phi)`` (``p``
        half the pitch from tooth 0 to 1), with ``r_1 - r_0 = -2 s sin p`` (:func:`cases.milling.eccentric_runout`:
        ``cos(theta_1 - phi) - cos(phi) = -2 sin(p) sin(p - phi)``). The fit's values are the offset of
        smallest amplitude with that difference, ``e = |s|``, ``phi = p - pi/2`` (``p + pi/2`` for
        ``s < 0``): the one whose mean radius ``e cos(p) cos(phi - p)`` is zero. The mean radius is a
        tool-diameter change that the forces hardly see (on the 170/190 deg aluminium tool the fit slid
        along it to the amplitude bound); the phase is then left open (standard deviation of a uniform
        phase, ``pi / sqrt(3)``). Three or more teeth: the amplitude and the phase."""
        if tool.teeth != 2:
            return super().fit_coordinates(tool)
        p = self._half_pitch(tool)
        emax = float(self.upper[0])

        def to_values(u):
            s = float(np.asarray(u, float)[0])
            return np.array([abs(s), p - math.pi / 2 if s >= 0 else p + math.pi / 2])

        def from_values(v):
            return np.array([float(v[0]) * math.sin(p - float(v[1]))])

        def jacobian(u):
            return np.array([[1.0 if float(np.asarray(u, float)[0]) >= 0 else -1.0], [0.0]])

        return FitCoordinates(np.array([-emax]), np.array([emax]), to_values, from_values, jacobian,
                              np.array([0.0, math.pi / math.sqrt(3.0)]))

    def identified(self, tool, values) -> dict:
        """What the fit determines: the tooth-radius offsets it implies (m) and which parameters show."""
        from robolobes.cases.milling import eccentric_runout

        return {"identifiable": self.identifiable(tool),
                "tooth_radius_offsets_m": eccentric_runout(tool, float(values[0]), float(values[1])).tolist()}

    def as_dict(self, values):
        e, phi = float(values[0]), float(values[1])
        return {"amplitude_m": e, "phase_rad": float(np.angle(np.exp(1j * phi)))}

    def starts(self):
        return [np.array([1e-5, 0.3]), np.array([1e-5, np.pi - 0.3])]


def _dynamometer_h(fn_hz: float, zeta: float):
    def h(f):
        r = np.asarray(f, float) / fn_hz
        return 1.0 / (1.0 - r ** 2 + 2j * zeta * r)
    return h


def _butterworth_h(cutoff_hz: float, order: int = 4):
    # analog Butterworth: poles s_k = wc exp(i pi (2k + n - 1) / (2n)), k = 1..n; H(0) = 1
    poles = np.exp(1j * np.pi * (2 * np.arange(1, order + 1) + order - 1) / (2 * order))

    def h(f):
        s = 1j * np.asarray(f, float) / cutoff_hz
        out = np.ones_like(s, dtype=complex)
        for p in poles:
            out = out * (-p) / (s - p)
        return out
    return h


class ChainEffect(ForceEffect):
    """A measurement-chain stage: a linear filter ``transfer(values) -> h(f_hz)`` on the measured forces."""

    stage = "chain"

    def transfer(self, values):
        raise NotImplementedError

    def apply_values(self, state, values):
        return state.with_chain(self.name, self.as_dict(values))

    def family(self, ctx, state):
        base = ctx.raw_averages(state)
        return lambda v: [ctx.filtered(a, self.transfer(v)) for a in base]


class Dynamometer(ChainEffect):
    name = "dynamometer"
    stage = "chain"
    parameters = (Parameter("fn_hz", 500.0, 8000.0, detect=6000.0, log=True, doc="dynamometer mode frequency"),
                  Parameter("zeta", 0.005, 0.3, doc="its damping ratio"))
    observed_by = {"forces": "ringing after each tooth entry: fn <= 6 kHz (within the first 10 tooth harmonics "
                             "at 18 700 rpm)",
                   "force_stats": "extremes overshoot (min below, max above the model), mean unchanged"}
    signatures = ("entry_ringing",)
    doc = "one lightly damped sensor mode per axis, unit static gain"
    def transfer(self, values):
        return _dynamometer_h(*values)


    def starts(self):
        return [np.array([f, 0.05]) for f in (800.0, 1500.0, 3000.0, 6000.0)]


class Lowpass(ChainEffect):
    name = "lowpass"
    stage = "chain"
    parameters = (Parameter("cutoff_hz", 300.0, 20000.0, detect=5000.0, log=True,
                            doc="-3 dB frequency of a 4th-order Butterworth"),)
    observed_by = {"forces": "tooth harmonics rolled off: cutoff <= 5 kHz",
                   "force_stats": "extremes reduced, mean unchanged"}
    signatures = ("harmonic_rolloff",)
    doc = "acquisition anti-aliasing filter"
    def transfer(self, values):
        return _butterworth_h(float(values[0]))


    def starts(self):
        return [np.array([f]) for f in (700.0, 2000.0, 6000.0)]


#: Detection threshold of the dead-zone half-width on the aluminium pass, rad. Derived (not tuned on
#: identification outcomes) from the linearized path's synchronous averages of the held-out block
#: (0.325-0.40 s, 23 revolutions) at half-widths 0, 1e-5, ..., 3e-4 rad (basic variant): the RMS change
#: of the x, y average exceeds the noise of that average at the worst noise of a set, 3 N / sqrt(23) =
#: 0.63 N, from 3e-5 rad on (0.42 N at 1e-5, 0.58 N at 2e-5, 0.87 N at 3e-5, >= 1.0 N above); the
#: numbers are in the README ("Backlash").
BACKLASH_DETECT_RAD = 3e-5


class Backlash(ForceEffect):
    """The motion axes' dead zone (eq. 12) as the ``backlash`` element
    (:class:`linearize.extra_elements.GearBacklash`): offered from every variant, ``basic`` included
    (the dead zone is in the gearboxes, i.e. in the motion springs every variant has; it needs
    neither gravity nor the orthogonal compliance). From ``orthogonal`` it gives the paper's
    ``backlash`` variant; from ``backlash`` it re-fits the width.

    The forces are piecewise smooth in the width, with jumps where an axis starts or stops
    separating during a block (adjacent runs 1e-5 rad apart differ by 0.3-2 N in the average, runs
    1e-6 apart by ~0.1 N). So the family is linear interpolation between runs on a ``RESOLUTION``
    grid, computed when first needed, and the fit starts from the ``TOP`` best widths of a scan at
    ``SCAN_STEP`` (:meth:`starts_for`).
    """

    name = "backlash"
    stage = "element"
    parameters = (Parameter("half_width_rad", 0.0, 3e-4, neutral=0.0, detect=BACKLASH_DETECT_RAD,
                            doc="dead-zone half-width on every motion axis"),)
    observed_by = {"forces": "tooth-harmonic and mean-force changes that depend on the force amplitude: half-width "
                             ">= 3e-5 rad (6 arcsec) on the aluminium pass"}
    signatures = ("harmonic_rolloff",)
    doc = "the paper's eq. 12 dead zone on every motion axis (element 'backlash', any variant)"
    RESOLUTION = 2e-6
    SCAN_STEP = 2e-5
    TOP = 2

    def apply_values(self, state, values):
        from robolobes.cases.spec import ElementSpec

        kept = tuple(e for e in state.elements if e.type != self.name)  # one dead zone: the new width replaces
        return replace(state, elements=kept + (ElementSpec(self.name, {"half_width_rad": float(values[0])}),))

    def family(self, ctx, state):
        """Width (rad, (1,)) -> raw averages (list of (bins, 3) arrays, N): linear interpolation between
        the simulated runs at the nodes ``k RESOLUTION`` (class docstring). Two runs are reused rather
        than simulated again, both the same numbers (:meth:`node_state`): a value on a node reads that
        node's run alone (the weight of its neighbour is 0), and the node at width 0 is ``state``
        without a dead zone, whose run the search has already made."""
        runs: dict = {}
        n_max = int(round(self.upper[0] / self.RESOLUTION))

        def run(k):
            if k not in runs:
                runs[k] = ctx.raw_averages(self.node_state(state, k * self.RESOLUTION))
            return runs[k]

        def f(v):
            x = float(np.clip(v[0], 0.0, self.upper[0])) / self.RESOLUTION
            k = int(min(np.floor(x), n_max - 1))
            w = x - k
            if w < 1e-9:
                return run(k)
            if w > 1 - 1e-9:
                return run(k + 1)
            return [(1 - w) * a + w * b for a, b in zip(run(k), run(k + 1))]
        return f

    def node_state(self, state, half_width_rad: float):
        """The state simulated for the width ``half_width_rad`` (rad). Width 0 is no dead zone: where
        the variant has none of its own (every variant but ``backlash``; the robot file's width is read
        by that variant only, :func:`linearize.model.build_model`), that is ``state`` with its ``backlash`` element removed, the same equations (the compiled pass
        takes the linear springs when the width is 0, :mod:`timedomain.fastpath`) under the key of a
        run already memoised."""
        if half_width_rad == 0.0 and state.variant != "backlash":
            return replace(state, elements=tuple(e for e in state.elements if e.type != self.name))
        return self.apply_values(state, (half_width_rad,))

    def starts_for(self, cost):
        grid = np.arange(0.0, self.upper[0] + 0.5 * self.SCAN_STEP, self.SCAN_STEP)
        c = np.array([cost(np.array([g])) for g in grid])
        return [np.array([grid[i]]) for i in np.argsort(c)[:self.TOP]]

    def starts(self):
        return [np.array([5e-5]), np.array([1.5e-4])]


#: The force-side library, in the order candidates are tried (registered in identify.effects.REGISTRY).
FORCE_EFFECTS: tuple[ForceEffect, ...] = (EdgeCoefficients(), Runout(), Dynamometer(), Lowpass(), Backlash())
for _e in FORCE_EFFECTS:
    register(_e)


def chain_transfer(chain: tuple):
    """The product of the transfer functions of a measurement chain ``((name, params), ...)``."""
    by_name = {e.name: e for e in FORCE_EFFECTS if isinstance(e, ChainEffect)}
    return transfer_product([by_name[n].transfer(tuple(p[k] for k in by_name[n].params)) for n, p in chain])


def transfer_product(hs):
    """``f -> prod_g g(f)`` of transfer functions ``hs`` (each of the frequency ``f``, Hz, complex)."""
    def h(f):
        out = np.ones(np.shape(f), dtype=complex)
        for g in hs:
            out = out * g(f)
        return out
    return h


def process_damping_c(ksp_n_per_m3: float, flank_m: float, depth_m: float, speed_m_per_s: float) -> float:
    """Equivalent viscous process damping ``c = Ksp b L^2 / (2 V)`` in N s/m (Altintas, Eynian & Onozuka
    2008; Budak & Tunc 2010): the volume the flank of length ``L`` indents under a surface wave,
    ``b L^2 ydot / (2 V)``, times the indentation coefficient ``Ksp`` (N/m^3)."""
    return ksp_n_per_m3 * depth_m * flank_m ** 2 / (2.0 * speed_m_per_s)


#: Indentation (ploughing) coefficient range for steels, N/m^3 (order of magnitude of published
#: process-damping identifications, e.g. 4e13 N/m^3 in Altintas, Eynian & Onozuka 2008).
KSP_RANGE_N_PER_M3 = (1e13, 1e14)
#: Flank-contact (wear land) length of an end mill, m: 0.02 mm (sharp) to 0.3 mm (ISO 8688 end of life, VB).
FLANK_RANGE_M = (2e-5, 3e-4)


def _engaged_nn(tool, cut) -> np.ndarray:
    """``(N / 2 pi) * integral over the engagement of n n^T dphi`` (2, 2), ``n = (sin phi, cos phi)``:
    the time average of ``sum_j g_j n_j n_j^T`` over a revolution (dimensionless)."""
    from robolobes.cases.milling import engagement_rad

    a, b = engagement_rad(tool, cut)
    s2 = lambda p: np.sin(2 * p)
    ss = 0.5 * (b - a) - 0.25 * (s2(b) - s2(a))           # int sin^2
    cc = 0.5 * (b - a) + 0.25 * (s2(b) - s2(a))           # int cos^2
    sc = 0.5 * (np.sin(b) ** 2 - np.sin(a) ** 2)           # int sin cos
    return tool.teeth / (2 * np.pi) * np.array([[ss, sc], [sc, cc]])


class DampingEffect(Effect):
    """An effect stability observations can fit (:mod:`identify.force_stability`): one parameter
    ``theta`` (more damping = larger ``theta``) that enters only the damping, linearly,
    ``C(theta) = C_a + theta C_b`` at each observation's pose, speed and depth.

    Subclasses set ``verdict_key`` (the key of an observation's critical value in the result's
    ``verdicts_before``) and implement :meth:`damping_line`.
    """

    verdict_key: str = ""

    def damping_line(self, state: ModelState, theta_rad, s1, tool, cut) -> tuple:
        """``(C_a, C_b)`` (n, n) N s/m (generalized): the damping at ``theta = 0`` and per unit ``theta``.

        ``state``: the model (its case the observation's); ``theta_rad`` (n_joints,) the pose; ``s1``
        the :class:`lobes.PhysicalStructure` there; ``tool``, ``cut`` the observation's (speed, depth)."""
        raise NotImplementedError(f"effect {self.name}: a DampingEffect implements damping_line()")


#: Joint-damping scales within this factor of 1 are credible: the paper's damping values come from
#: a guess (eq. 8), usually off by a factor of a few; a servo loop adds damping, not tenfold on every axis.
JOINT_DAMPING_CREDIBLE = 3.0


class JointDamping(DampingEffect):
    """A scale on every motion-axis damper of the robot (the paper's eq. 8 damping is a guess).

    ``C(s) = C_other + s C_joints``: ``C_joints`` is the motion-axis dampers' share of the
    linearized damping, taken from a second linearization at damping scale 2 (``C_2 - C_1``), so it
    is exact for dampers linear in the scale. In a case TOML it is one ``joint_correction`` element
    per joint with ``damping_scale = s`` (:meth:`element_specs`); :meth:`table` is the effect's own record.
    Bounds [0.2, 50]: a fit on the upper bound says no credible joint damping explains the data.
    """

    name = "joint_damping"
    stage = "element"
    parameters = (Parameter("scale", 0.2, 50.0, neutral=1.0, log=True,
                            doc="factor on every motion-axis damper (eq. 8 of the paper)",
                            plausible=(1 / JOINT_DAMPING_CREDIBLE, JOINT_DAMPING_CREDIBLE)),)
    observed_by = {"stability": "an observation whose margin to the lobes' limit the scaled damping closes"}
    signatures = ("stability_shift",)
    doc = "joint damping: a scale on every motion-axis damper (stability observations)"
    verdict_key = "critical_joint_damping_scale"

    def damping_line(self, state, theta_rad, s1, tool, cut) -> tuple:
        from robolobes.linearize import linearize
        from robolobes.lobes import PhysicalStructure

        s2 = PhysicalStructure.from_linear(linearize(state.robot(damping_scale=2.0), theta_rad),
                                           state.case.cut.feed_direction)
        c_joint = np.asarray(s2.C) - np.asarray(s1.C)
        return np.asarray(s1.C) - c_joint, c_joint

    def element_specs(self, model: ModelState, params) -> tuple:
        """``damping_scale = scale`` on every joint of ``model``: one ``joint_correction`` element each."""
        from robolobes.cases.spec import ElementSpec

        s = float(params["scale"])
        return tuple(ElementSpec(type="joint_correction", params={"joint": j, "damping_scale": s})
                     for j in range(1, model.case.robot.n_joints + 1))


class ProcessDamping(DampingEffect):
    """Process damping: the flank of each engaged tooth indents the wavy surface it cuts.

    Law (Altintas, Eynian & Onozuka 2008; Budak & Tunc 2010): a tooth whose flank of length ``L``
    rubs a surface of slope ``y'/V`` indents the volume ``b L^2 y' / (2 V)`` and feels the force
    ``Ksp`` times it, along its own chip normal ``n = (sin phi, cos phi)``: a viscous damper
    ``c = Ksp L^2 b / (2 V)`` per engaged tooth, ``b`` the axial depth and ``V = pi D n / 60`` the
    cutting speed (:func:`process_damping_c`). The law only sees ``Ksp L^2``: that product
    (``ksp_l2_n_per_m``, N/m) is the parameter; ``L`` is reported at the published ``Ksp`` range.

    Time-invariant form (what the lobes and the time domain both build, :class:`TipDamper`): the
    damper averaged over the revolution, ``Cc = c * (N / 2 pi) int_engagement n n^T dphi`` (2 x 2 in
    ``x_c, y_c``); the periodic part is dropped as the zeroth-order approximation drops it for the
    cutting force. So the damping falls as ``1 / V`` and grows with the depth: at a fixed
    ``Ksp L^2`` it is strongest at low spindle speed, which is what tells it from a joint-damping
    scale in observations over several speeds. Valid while ``L`` is much shorter than the surface
    wavelength ``V / f`` (small slope under the flank).

    Bounds: ``0 <= Ksp L^2 <= 1e14 * (0.3 mm)^2 = 9e6 N/m`` (:data:`KSP_RANGE_N_PER_M3`,
    :data:`FLANK_RANGE_M`). Detection: an observation's verdict flips when the damper closes its
    margin to the lobes' limit; :meth:`detection_threshold` gives the ``Ksp L^2`` that adds a given
    fraction of the chatter mode's own damping at a speed and depth.
    """

    name = "process_damping"
    stage = "element"
    parameters = (Parameter("ksp_l2_n_per_m", 0.0, KSP_RANGE_N_PER_M3[1] * FLANK_RANGE_M[1] ** 2, neutral=0.0,
                            doc="indentation coefficient times flank contact squared, Ksp L^2 (N/m)"),)
    observed_by = {"stability": "an observation whose margin to the lobes' limit the damper closes "
                                "(see ProcessDamping.detection_threshold)"}
    signatures = ("stability_shift",)
    doc = "process damping: flank indentation, c = Ksp L^2 b / (2 V) per engaged tooth, averaged in the cut plane"
    verdict_key = "critical_ksp_l2_n_per_m"

    @staticmethod
    def speed_m_per_s(tool, cut) -> float:
        """Cutting speed ``V = pi D n / 60`` at the tool's periphery, m/s."""
        return math.pi * tool.diameter_m * cut.spindle_rpm / 60.0

    def matrix_cut(self, ksp_l2_n_per_m: float, tool, cut) -> np.ndarray:
        """Averaged damper ``Cc`` (2, 2) in N s/m, cut frame ``(x_c, y_c)``, at the cut's depth and speed."""
        c = ksp_l2_n_per_m * cut.ap_m / (2.0 * self.speed_m_per_s(tool, cut))
        return c * _engaged_nn(tool, cut)

    def table(self, params) -> dict:
        """The effect's TOML table ``{"type": "process_damping", "ksp_l2_n_per_m": ...}``, as the other
        cutting-law effects write theirs (read back with :meth:`Effect.from_table`). The damper it
        puts into a case depends on the cut (depth, speed): :meth:`element_table` gives that
        ``tip_damper`` table, and :meth:`element_specs` gives it for the model's own cut."""
        return {"type": self.name, "ksp_l2_n_per_m": check_params(self, params)["ksp_l2_n_per_m"]}

    def damping_line(self, state, theta_rad, s1, tool, cut) -> tuple:
        t2 = np.asarray(s1.tcp)[:2]
        return np.asarray(s1.C), t2.T @ self.matrix_cut(1.0, tool, cut) @ t2

    def element_table(self, ksp_l2_n_per_m: float, tool, cut, feed_direction) -> dict:
        """The ``[[elements]]`` table (``tip_damper``) of the damper for this cut."""
        C = self.matrix_cut(ksp_l2_n_per_m, tool, cut)
        return {"type": "tip_damper", "cxx_n_s_per_m": float(C[0, 0]), "cyy_n_s_per_m": float(C[1, 1]),
                "cxy_n_s_per_m": float(C[0, 1]), "feed_direction": [float(x) for x in feed_direction]}

    def element_specs(self, model: ModelState, params) -> tuple:
        """The ``tip_damper`` of ``model``'s own cut (the damper depends on depth and speed)."""
        from robolobes.cases.spec import ElementSpec

        c = model.case
        t = self.element_table(float(params["ksp_l2_n_per_m"]), c.tool, c.cut, c.cut.feed_direction)
        return (ElementSpec(type=t.pop("type"), params=t),)

    def flank_m(self, ksp_l2_n_per_m: float) -> tuple[float, float]:
        """Flank contact ``L`` (m) the value needs at ``Ksp`` = the upper and the lower end of its range."""
        hi, lo = KSP_RANGE_N_PER_M3[1], KSP_RANGE_N_PER_M3[0]
        return math.sqrt(ksp_l2_n_per_m / hi), math.sqrt(ksp_l2_n_per_m / lo)

    def detection_threshold(self, structure, tool, cut, fraction: float = 0.3) -> float:
        """``Ksp L^2`` (N/m) whose damper adds ``fraction`` of the structure's own damping to its
        tool-tip-dominant mode in the cut plane, at the cut's depth and speed.

        For one mode the stability limit is proportional to its damping (``b_lim = 2 k zeta (1 + zeta)
        / (N Kt alpha)`` at the lobes' minimum, Altintas ch. 3), so an observation at ``1 + fraction``
        times the limit flips when the damping grows by about that fraction. Undamped real modes of
        ``structure`` (a :class:`lobes.PhysicalStructure`): mode ``k`` with mass-normalized shape
        ``psi`` has damping ``psi^T C psi`` and gains ``u^T Cc u`` with ``u = tcp[:2] psi``; the mode
        taken is the one with the largest tool-tip compliance ``|u|^2 / omega^2``.
        """
        M, C, K, T = (np.asarray(x, float) for x in (structure.M, structure.C, structure.K, structure.tcp))
        import scipy.linalg as sl

        w2, psi = sl.eigh(K, M)
        u = T[:2] @ psi
        k = int(np.argmax(np.sum(u ** 2, axis=0) / w2))
        own = float(psi[:, k] @ C @ psi[:, k])
        D = self.matrix_cut(1.0, tool, cut)
        per_unit = float(u[:, k] @ D @ u[:, k])
        return fraction * own / per_unit


register(JointDamping())
register(ProcessDamping())
