"""Laplacians, their checks, the two-layer couplings against explicit Kronecker products, and
the modal decomposition."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.networks import (
    TwoLayerNetwork,
    algebraic_connectivity,
    check_laplacian,
    is_connected,
    laplacian_from_adjacency,
    laplacian_from_edges,
)


L1 = np.array([[1, -1, 0, 0], [-1, 3, -2, 0], [0, -2, 3, -1], [0, 0, -1, 1]], float)
L1_PRINTED = np.array([[1, -1, 0, 0], [-1, 3, -2, 0], [0, -2, 3, 1], [0, 0, -1, 1]], float)
L2 = np.array([[1, -1, 0], [-1, 2, -1], [0, -1, 1]], float)
RHO1, RHO2 = np.array([2.0, 1.0, 2.0, 1.0]), np.array([1.0, 0.0, 0.0, 0.0])


def test_builders_give_the_weighted_path_and_its_spectrum():
    """Path 0-1-2-3 with weights 1, 2, 1 is the corrected L1; its eigenvalues are 0,
    3 -+ sqrt(5) and 2 (characteristic polynomial s (s - 2)(s^2 - 6 s + 4))."""
    lap = laplacian_from_edges(4, [(0, 1), (1, 2), (2, 3)], [1.0, 2.0, 1.0])
    np.testing.assert_array_equal(np.asarray(lap), L1)
    adjacency = np.diag([1.0, 2.0, 1.0], 1) + np.diag([1.0, 2.0, 1.0], -1)
    np.testing.assert_array_equal(np.asarray(laplacian_from_adjacency(adjacency)), L1)
    eig = np.sort(np.linalg.eigvalsh(L1))
    np.testing.assert_allclose(eig, [0, 3 - np.sqrt(5), 2, 3 + np.sqrt(5)], atol=1e-14)
    np.testing.assert_allclose(float(algebraic_connectivity(jnp.asarray(L1))), 3 - np.sqrt(5))
    directed = np.asarray(laplacian_from_edges(3, [(0, 1), (1, 2)], directed=True))
    np.testing.assert_array_equal(directed, [[1, -1, 0], [0, 1, -1], [0, 0, 0]])
    # differentiable in the edge weights: d lambda_2 / d w for the middle edge
    grad = jax.grad(
        lambda w: algebraic_connectivity(laplacian_from_edges(4, [(0, 1), (1, 2), (2, 3)], w))
    )(jnp.array([1.0, 2.0, 1.0]))
    eps = 1e-6
    fd = [
        (
            np.linalg.eigvalsh(
                np.asarray(laplacian_from_edges(4, [(0, 1), (1, 2), (2, 3)], w + eps * e))
            )[1]
            - np.linalg.eigvalsh(
                np.asarray(laplacian_from_edges(4, [(0, 1), (1, 2), (2, 3)], w - eps * e))
            )[1]
        )
        / (2 * eps)
        for w in [np.array([1.0, 2.0, 1.0])]
        for e in np.eye(3)
    ]
    np.testing.assert_allclose(np.asarray(grad), fd, rtol=1e-7)


def test_laplacian_checks_name_the_argument_and_the_rule():
    with pytest.raises(ValueError, match=r"`L`.*zero row sums.*\[0\., 0\., 2\., 0\.\]"):
        check_laplacian("here", "L", L1_PRINTED)
    nonsym = np.array([[1.0, -1.0, 0.0], [0.0, 1.0, -1.0], [0.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="`L`.*symmetric"):
        check_laplacian("here", "L", nonsym)
    check_laplacian("here", "L", nonsym, symmetric=False)  # a directed graph may pass
    two_parts = laplacian_from_edges(4, [(0, 1), (2, 3)])
    assert not is_connected(two_parts) and is_connected(L1)
    with pytest.raises(ValueError, match="`L`.*connected"):
        check_laplacian("here", "L", two_parts)
    with pytest.raises(ValueError, match="`L`.*non-positive off-diagonal"):
        check_laplacian("here", "L", np.array([[-1.0, 1.0], [1.0, -1.0]]))
    with pytest.raises(ValueError, match="`L`.*square"):
        check_laplacian("here", "L", np.zeros((2, 3)))
    with pytest.raises(ValueError, match="`weights`.*one entry per edge"):
        laplacian_from_edges(3, [(0, 1)], [1.0, 2.0])
    with pytest.raises(ValueError, match="`adjacency`.*non-negative"):
        laplacian_from_adjacency(-np.ones((2, 2)))


def test_algebraic_connectivity_refuses_what_is_not_a_symmetric_laplacian(no_jaxtyping):
    # eigvalsh reads one triangle: a directed path gave 0.656, the eigenvalue of another matrix
    directed = laplacian_from_edges(3, [(0, 1), (1, 2)], directed=True)
    with pytest.raises(ValueError, match="algebraic_connectivity: `laplacian` must be symmetric"):
        algebraic_connectivity(directed)
    with pytest.raises(ValueError, match="algebraic_connectivity: `laplacian`.*zero row sums"):
        algebraic_connectivity(np.eye(3))
    with pytest.raises(ValueError, match="algebraic_connectivity: `laplacian` must have at least"):
        algebraic_connectivity(np.zeros((1, 1)))
    # a disconnected graph is a Laplacian: its lambda_2 is 0
    two_parts = laplacian_from_edges(4, [(0, 1), (2, 3)])
    assert float(algebraic_connectivity(two_parts)) == pytest.approx(0.0, abs=1e-14)


@pytest.mark.parametrize("n", [True, 2.0, 0])
def test_a_node_count_that_is_not_a_positive_integer_is_refused(n, no_jaxtyping):
    # True and 2.0 were read as networks of 1 and 2 nodes.
    with pytest.raises(ValueError, match="laplacian_from_edges: `n` must be a positive integer"):
        laplacian_from_edges(n, [])


def test_network_checks_sizes_and_laplacians():
    with pytest.raises(ValueError, match="`intra_laplacian`.*zero row sums"):
        TwoLayerNetwork(L1_PRINTED, L2, RHO1, RHO2)
    TwoLayerNetwork(L1_PRINTED, L2, RHO1, RHO2, allow_non_laplacian=True)
    with pytest.raises(ValueError, match=r"`intra_laplacian`.*shape \(3, 3\)"):
        TwoLayerNetwork(L2, L2, RHO1, RHO2)
    with pytest.raises(ValueError, match="`rho2`.*shape of `rho1`"):
        TwoLayerNetwork(L1, L2, RHO1, RHO2[:3])
    with pytest.raises(ValueError, match="`inter_laplacian`.*connected"):
        TwoLayerNetwork(L1, np.diag([1.0, 1.0, 0.0]) * 0, RHO1, RHO2)
    with pytest.raises(ValueError, match="`inter_laplacian`.*symmetric"):
        TwoLayerNetwork(L1, [[1.0, -1.0, 0.0], [0.0, 1.0, -1.0], [-1.0, 0.0, 1.0]], RHO1, RHO2)


def test_structured_couplings_equal_the_kronecker_products_and_modes_decouple():
    net = TwoLayerNetwork(L1, L2, RHO1, RHO2)
    x = jnp.asarray(np.random.default_rng(0).normal(size=(3, 4)))
    w1 = np.kron(np.eye(3), L1)
    w2 = np.kron(L2, np.outer(RHO1, RHO2))
    np.testing.assert_allclose(np.asarray(net.kron_intra()), w1)
    np.testing.assert_allclose(np.asarray(net.kron_inter()), w2)
    np.testing.assert_allclose(np.asarray(net.intra(x)).ravel(), w1 @ np.asarray(x).ravel())
    np.testing.assert_allclose(
        np.asarray(net.inter(x)).ravel(), w2 @ np.asarray(x).ravel(), atol=1e-13
    )
    # trailing feature axes (e.g. 3-D positions) vectorise the same way
    x3 = jnp.asarray(np.random.default_rng(1).normal(size=(3, 4, 3)))
    for i in range(3):
        np.testing.assert_allclose(np.asarray(net.inter(x3))[..., i], net.inter(x3[..., i]))
    lam, u = net.modes()
    np.testing.assert_allclose(np.asarray(lam), [0.0, 1.0, 3.0], atol=1e-14)
    g = net.modal(x)
    np.testing.assert_allclose(np.asarray(net.from_modal(g)), np.asarray(x), atol=1e-14)
    # mode k of the coupled field is -L1 g_k - lambda_k Delta g_k
    field = -(net.intra(x) + net.inter(x))
    expected = -(g @ L1.T) - np.asarray(lam)[:, None] * (np.asarray(g) @ net.delta.T)
    np.testing.assert_allclose(np.asarray(net.modal(field)), expected, atol=1e-12)
    # the lambda_1 = 0 mode carries the average: 1^T g_1 = sqrt(q) p mean(x)
    np.testing.assert_allclose(float(jnp.sum(g[0])), np.sqrt(3) * 4 * float(jnp.mean(x)))
