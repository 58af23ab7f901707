r"""Graph Laplacians: built from edge lists or adjacency matrices, and checked.

For a weighted graph with adjacency $A$ ($a_{ij} \ge 0$ the weight of the edge that lets
agent $i$ read agent $j$), the Laplacian is $L = D - A$ with $D = \mathrm{diag}(A\mathbf 1)$:
zero row sums ($L\mathbf 1 = 0$), non-positive off-diagonal entries. Undirected graphs give
symmetric $L$, whose column sums vanish too, so $\mathbf 1^T L = 0$ and a consensus protocol
$\dot x = -Lx$ conserves the average. A connected undirected graph has exactly one zero
eigenvalue; the second smallest, $\lambda_2(L)$ (the algebraic connectivity), is the
consensus rate of $\dot x = -Lx$.

The checks are host-side (NumPy) on concrete matrices and are skipped for traced ones (a
Laplacian built inside `jit`/`grad` from weights is a Laplacian by construction).
"""

from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._validation import check_positive_int, describe, is_traced
from ._types import MatrixLike, as_float


LAPLACIAN_TOLERANCE = 1e-9
"""Relative tolerance of the Laplacian checks (row sums, symmetry), times 1 + max |L_ij|."""


def laplacian_from_adjacency(adjacency: MatrixLike) -> Float[Array, "n n"]:
    r"""$L = \mathrm{diag}(A\mathbf 1) - A$ for a weighted adjacency $A$ (any float array,
    differentiable in its entries; the diagonal of $A$ is ignored)."""
    a = as_float(adjacency, "adjacency", "laplacian_from_adjacency")
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(
            f"laplacian_from_adjacency: `adjacency` must be a square matrix, got shape {a.shape}."
        )
    if not is_traced(a):
        host = np.asarray(a)
        if not np.all(np.isfinite(host)) or np.any(host < 0):
            raise ValueError(
                "laplacian_from_adjacency: `adjacency` must hold finite non-negative weights, "
                f"got {describe(host)}."
            )
    a = a - jnp.diag(jnp.diag(a))
    return jnp.diag(jnp.sum(a, axis=1)) - a


def laplacian_from_edges(
    n: int,
    edges: Sequence[tuple[int, int]],
    weights: MatrixLike | None = None,
    *,
    directed: bool = False,
) -> Float[Array, "n n"]:
    r"""The Laplacian of `n` nodes joined by `edges` (pairs `(i, j)`, 0-based).

    Undirected (default): each edge adds its weight to $a_{ij}$ and $a_{ji}$. Directed: edge
    `(i, j)` means "i reads j" and adds to $a_{ij}$ only. `weights` (one per edge, default 1)
    may be traced, so the Laplacian is differentiable in them.
    """
    where = "laplacian_from_edges"
    n = check_positive_int(where, "n", n)
    pairs = np.asarray(edges, dtype=int).reshape(-1, 2) if len(edges) else np.zeros((0, 2), int)
    if pairs.size and (pairs.min() < 0 or pairs.max() >= n):
        raise ValueError(f"{where}: `edges` must index nodes 0..{n - 1}, got {pairs.tolist()}.")
    if np.any(pairs[:, 0] == pairs[:, 1]):
        raise ValueError(f"{where}: `edges` must not hold self-loops, got {pairs.tolist()}.")
    if weights is None:
        w = jnp.ones(len(pairs), dtype=jnp.result_type(float))
    else:
        w = as_float(weights, "weights", where)
        if w.shape != (len(pairs),):
            raise ValueError(
                f"{where}: `weights` must have one entry per edge, shape ({len(pairs)},), "
                f"got shape {w.shape}."
            )
        if not is_traced(w) and not np.all(np.asarray(w) >= 0):
            raise ValueError(f"{where}: `weights` must be non-negative, got {describe(w)}.")
    a = jnp.zeros((n, n), dtype=w.dtype).at[pairs[:, 0], pairs[:, 1]].add(w)
    if not directed:
        a = a.at[pairs[:, 1], pairs[:, 0]].add(w)
    return laplacian_from_adjacency(a)


def is_connected(laplacian: MatrixLike) -> bool:
    """Whether the graph of a concrete Laplacian is connected (directed graphs: weakly
    connected, i.e. connected when edge directions are ignored). Host-side."""
    host = np.asarray(laplacian)
    n = host.shape[0]
    linked = (np.abs(host) + np.abs(host.T)) > 0
    seen, frontier = {0}, [0]
    while frontier:
        i = frontier.pop()
        for j in np.flatnonzero(linked[i]):
            if int(j) not in seen:
                seen.add(int(j))
                frontier.append(int(j))
    return len(seen) == n


def check_laplacian(
    where: str,
    name: str,
    value: MatrixLike,
    *,
    size: int | None = None,
    symmetric: bool = True,
    connected: bool = True,
) -> Float[Array, "n n"]:
    """Convert `value` to a float matrix and check that it is a graph Laplacian.

    Rules (each violation is a `ValueError` naming `where`, `name`, the value and the rule):
    square (of side `size` when given), finite, zero row sums, non-positive off-diagonal
    entries, symmetric when `symmetric`, connected graph when `connected`. Traced values are
    checked for shape only.
    """
    arr = as_float(value, name, where)
    if arr.ndim != 2 or arr.shape[0] != arr.shape[1]:
        raise ValueError(f"{where}: `{name}` must be a square matrix, got shape {arr.shape}.")
    if size is not None and arr.shape != (size, size):
        raise ValueError(
            f"{where}: `{name}` must have shape ({size}, {size}) to match the other "
            f"arguments, got shape {arr.shape}."
        )
    if is_traced(arr):
        return arr
    host = np.asarray(arr)
    shown = describe(host)
    if not np.all(np.isfinite(host)):
        raise ValueError(f"{where}: `{name}` must be finite, got {shown}.")
    tol = LAPLACIAN_TOLERANCE * (1.0 + np.max(np.abs(host)))
    rows = host.sum(axis=1)
    if np.any(np.abs(rows) > tol):
        raise ValueError(
            f"{where}: `{name}` must be a graph Laplacian with zero row sums, got row sums "
            f"{describe(rows)} for {name}={shown}."
        )
    off = host - np.diag(np.diag(host))
    if np.any(off > tol):
        raise ValueError(
            f"{where}: `{name}` must be a graph Laplacian with non-positive off-diagonal "
            f"entries (non-negative edge weights), got {name}={shown}."
        )
    if symmetric and np.any(np.abs(host - host.T) > tol):
        raise ValueError(
            f"{where}: `{name}` must be symmetric (an undirected graph), got {name}={shown}."
        )
    if connected and not is_connected(host):
        raise ValueError(
            f"{where}: `{name}` must be the Laplacian of a connected graph, got {name}={shown}."
        )
    return arr


def algebraic_connectivity(laplacian: Float[Array, "n n"]) -> Float[Array, ""]:
    r"""$\lambda_2(L)$, the second smallest eigenvalue of a symmetric Laplacian (the decay
    rate of disagreement under $\dot x = -Lx$); differentiable where it is simple.

    **Raises:** `ValueError` for a concrete matrix that is not a symmetric Laplacian of at
    least two nodes ([`check_laplacian`][] without the connectivity rule: a disconnected
    graph has $\lambda_2 = 0$). `eigvalsh` reads one triangle only, so a directed Laplacian
    gave the eigenvalue of another, symmetric, matrix; a single node gave its $\lambda_1$.
    A traced matrix is checked for shape only.
    """
    where = "algebraic_connectivity"
    laplacian = check_laplacian(where, "laplacian", laplacian, connected=False)
    if laplacian.shape[0] < 2:
        raise ValueError(
            f"{where}: `laplacian` must have at least two nodes, got shape {laplacian.shape}."
        )
    return jnp.linalg.eigvalsh(laplacian)[1]
