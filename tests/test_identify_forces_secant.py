"""The secant (Broyden) update of the force fits' affine models (:func:`identify.forces.secant_update`)
and their finite-difference columns (:func:`identify.forces._fd_columns`), on maps with known
derivatives.

Tolerances asserted: 1e-9 relative (round-off of sums of a few terms of order 1-100) for what is
exact in exact arithmetic: the columns of an affine map, the secant condition, the columns
orthogonal to the step unchanged.
"""

import numpy as np

from robolobes.identify.forces import _fd_columns, secant_update

LO = np.array([0.0, 0.0, -1.0])
HI = np.array([1e5, 2e-4, 1.0])
SCALE = HI - LO
#: d raw / d u of the affine map, one (2, 3) array per block and coordinate (units of N per unit of u)
A = [[np.array([[1e-3, 2e-3, 0.0], [4e-3, -1e-3, 5e-4]]), np.array([[-2e-4, 1e-4, 0.0], [3e-4, 0.0, 1e-4]])],
     [np.array([[5e4, -3e4, 0.0], [1e4, 2e4, 0.0]]), np.array([[2e4, 0.0, 1e4], [0.0, -6e4, 0.0]])],
     [np.array([[3.0, 1.0, 0.0], [0.0, 2.0, 1.0]]), np.array([[1.0, 0.0, 0.0], [2.0, 1.0, 0.0]])]]
B = [np.array([[10.0, -5.0, 0.0], [20.0, 3.0, 1.0]]), np.array([[0.0, 7.0, 2.0], [-4.0, 1.0, 0.0]])]


def _affine(u):
    return [B[k] + sum(u[i] * A[i][k] for i in range(3)) for k in range(2)]


def _curved(u):   # the affine map plus a term quadratic in the first two coordinates (scaled)
    q = (u[0] / SCALE[0]) * (u[1] / SCALE[1])
    return [a + q * np.array([[30.0, -10.0, 0.0], [5.0, 8.0, 0.0]]) * (k + 1) for k, a in enumerate(_affine(u))]


def test_fd_columns_of_an_affine_map_are_its_matrix_also_at_an_upper_bound():
    c = np.array([5e4, 2e-4, 0.2])        # the second coordinate on its upper bound: stepped inwards
    cols = _fd_columns(_affine, c, LO, HI, [0, 1, 2])
    for i in range(3):
        for k in range(2):
            np.testing.assert_allclose(cols[i][k], A[i][k], rtol=1e-9, atol=1e-9 * np.abs(A[i][k]).max())


def test_secant_update_keeps_an_affine_map_exact():
    c0, c1 = np.array([3e4, 5e-5, 0.0]), np.array([3.4e4, 8e-5, -0.3])
    cols = {i: [a.copy() for a in A[i]] for i in range(3)}
    new = secant_update(cols, c0, _affine(c0), c1, _affine(c1), SCALE)
    for i in range(3):
        for k in range(2):
            np.testing.assert_allclose(new[i][k], A[i][k], rtol=1e-9, atol=1e-9 * np.abs(A[i][k]).max())


def test_secant_update_meets_the_secant_condition_and_leaves_orthogonal_directions():
    c0, c1 = np.array([3e4, 5e-5, 0.4]), np.array([4e4, 9e-5, 0.4])   # the third coordinate does not move
    cols = _fd_columns(_curved, c0, LO, HI, [0, 1, 2])
    r0, r1 = _curved(c0), _curved(c1)
    new = secant_update(cols, c0, r0, c1, r1, SCALE)
    for k in range(2):
        pred = r0[k] + sum((c1[i] - c0[i]) * new[i][k] for i in range(3))
        np.testing.assert_allclose(pred, r1[k], rtol=1e-9, atol=1e-9 * np.abs(r1[k]).max())
        np.testing.assert_allclose(new[2][k], cols[2][k], rtol=0, atol=0)      # orthogonal: unchanged
        # the direction orthogonal to the scaled step in the (0, 1) plane
        s = np.array([(c1[0] - c0[0]) / SCALE[0], (c1[1] - c0[1]) / SCALE[1]])
        w = np.array([-s[1], s[0]])
        before = w[0] * cols[0][k] * SCALE[0] + w[1] * cols[1][k] * SCALE[1]
        after = w[0] * new[0][k] * SCALE[0] + w[1] * new[1][k] * SCALE[1]
        np.testing.assert_allclose(after, before, rtol=1e-9, atol=1e-9 * np.abs(before).max())
    # the old model missed the curvature: the update changed the columns along the step
    assert not np.allclose(new[0][0], cols[0][0], rtol=1e-6)
