"""Numerical inverse kinematics for any 6-axis chain: damped least squares on SE(3) (pinocchio).

As pinocchio's ``examples/inverse-kinematics.py``: the error of the TCP frame ``oMf`` from the
target ``oMdes`` is the twist ``e = log6(oMf^-1 oMdes)`` (TCP axes, m and rad); its Jacobian is
``Je = -Jlog6(oMdes^-1 oMf) J_local``; each step is ``dq = -Je^T (Je Je^T + lambda^2 I)^-1 e`` with
``lambda = DAMPING`` and its largest joint step limited to ``MAX_STEP_RAD``. The iteration stops when
``|e| < RESIDUAL_TOL`` (then FK(IK) is within 1e-12 m and 1e-12 rad of the target) or after
``MAX_ITER`` steps (then the target is reported unreachable from that start: a target out of reach
and a start too far from it cannot be told apart; the message says so).

Start points: the previous pose along a path (continuation), or, for a branch without a previous
pose, the closed-form solution of that branch for the OPW arm nearest to the chain (the projected
parameters of :func:`linearize.ik_opw.opw_geometry`). The branch of the converged pose is named by
:func:`linearize.ik_opw.branch_indicators`; the caller refuses a pose on another branch.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .chain import KinematicChain

__all__ = ["DAMPING", "MAX_STEP_RAD", "MAX_ITER", "RESIDUAL_TOL", "dls_solve"]

#: Damping lambda of the least-squares step (m or rad): small against the singular values of a
#: machining arm's Jacobian away from its singularities (0.1-3 m), so the steps near the solution are
#: Newton steps (quadratic convergence), and it bounds the step at a singularity.
DAMPING = 1e-6
#: Largest joint change per step, rad: keeps the iteration on the branch of its start.
MAX_STEP_RAD = 0.2
MAX_ITER = 200
#: Convergence on |log6| (m and rad).
RESIDUAL_TOL = 1e-13


def dls_solve(chain: KinematicChain, p: np.ndarray, R: np.ndarray, q0: np.ndarray,
              data: pin.Data | None = None) -> tuple[np.ndarray, float, int]:
    """Damped least squares from controller angles ``q0`` (6,) rad to the TCP target (p (3,) m, R (3, 3)).

    Returns
    -------
    q : array (6,)
        Controller angles, rad (continuous from ``q0``: no 2 pi wrapping).
    residual : float
        ``|log6|`` at ``q`` (m and rad).
    iterations : int
    """
    model, fid = chain.model, chain.tcp_frame_id
    work = model.createData() if data is None else data
    target = pin.SE3(np.asarray(R, dtype=float), np.asarray(p, dtype=float))
    qj = chain.joint_positions(q0).astype(float)
    eye = np.eye(6) * DAMPING ** 2
    residual = np.inf
    it = 0
    for it in range(MAX_ITER + 1):
        pin.framesForwardKinematics(model, work, qj)
        iMd = work.oMf[fid].actInv(target)
        err = np.asarray(pin.log6(iMd).vector)
        residual = float(np.linalg.norm(err))
        if residual < RESIDUAL_TOL or it == MAX_ITER:
            break
        J = pin.computeFrameJacobian(model, work, qj, fid, pin.LOCAL)
        Je = -np.asarray(pin.Jlog6(iMd.inverse())) @ np.asarray(J)
        dq = -Je.T @ np.linalg.solve(Je @ Je.T + eye, err)
        big = np.abs(dq).max()
        if big > MAX_STEP_RAD:
            dq *= MAX_STEP_RAD / big
        qj = qj + dq
    return chain.controller_angles(qj), residual, it
