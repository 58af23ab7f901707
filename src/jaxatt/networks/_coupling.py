r"""Two-layer networks: $q$ groups of $p$ agents, Kronecker-structured couplings, modes.

The state of all $N = pq$ agents is an array `x` of shape `(q, p, *features)`: group $n$ is
row `x[n]` (the paper's $X_n$), so the stacked vector $x = [X_1; \dots; X_q]$ of Duan et al.
(2024) is `x.reshape(-1)` for scalar agents. The couplings act on that array without ever
forming an $N\times N$ matrix (12 or 12 000 agents are the same code):

$$(I_q \otimes L_1)\,x \;\to\; \texttt{x}_{n} \mapsto L_1 \texttt{x}_{n},\qquad
(L_2 \otimes \Delta)\,x \;\to\; \texttt{x}_{n} \mapsto \textstyle\sum_b (L_2)_{nb}\,\Delta\,
\texttt{x}_{b},\qquad \Delta = \rho_1\rho_2^T,$$

with $L_1$ ($p\times p$) the intra-group Laplacian shared by all groups, $L_2$ ($q\times q$)
the inter-group Laplacian of the upper layer, and $\rho_1$ (weights from the upper layer down
to the agents), $\rho_2$ (from the agents up) the inter-layer interconnection.

**Modal decomposition.** With $L_2 = U\Lambda U^T$ symmetric ($U$ orthogonal, eigenvalues
$0 = \lambda_1 < \lambda_2 \le \dots \le \lambda_q$ for a connected graph), the modal
coordinates $g = (U^T \otimes I_p)\,x$ (`modal(x)`, shape `(q, p, ...)`) decouple
$\dot x = -(I_q\otimes L_1)x(t) - (L_2\otimes\Delta)x(t_i)$ into $q$ systems
$\dot g_k = -L_1 g_k(t) - \lambda_k \Delta g_k(t_i)$. Mode 1 ($\lambda_1 = 0$) obeys
$\dot g_1 = -L_1 g_1$ and carries the average $\bar x$: $\mathbf 1^T g_1 = \sqrt q\,p\,\bar x$
(with $u_1 = \mathbf 1/\sqrt q$); its disagreement part (orthogonal to $\mathbf 1$) decays at
the rate $\lambda_2(L_1)$.
"""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._validation import describe, is_traced
from ._graphs import check_laplacian
from ._types import MatrixLike, as_float


class TwoLayerNetwork(eqx.Module):
    r"""$q$ groups of $p$ agents: intra-group Laplacian $L_1$, inter-group Laplacian $L_2$,
    inter-layer interconnection $\Delta = \rho_1\rho_2^T$.

    **Arguments:**
    - `intra_laplacian`: $L_1$, $p\times p$, symmetric, zero row sums, connected graph.
    - `inter_laplacian`: $L_2$, $q\times q$, symmetric, zero row sums, connected graph.
    - `rho1`, `rho2`: $\rho_1, \rho_2 \in \mathbb R^p$.
    - `allow_non_laplacian`: skip the Laplacian rules for $L_1$ (shape still checked), to
      simulate a matrix that is not a Laplacian on purpose (e.g. Duan et al.'s printed
      $L_1$, whose row 3 sums to 2). The modal analysis then no longer describes
      consensus; use it for simulation only.

    All four matrices are array fields: traced, vmappable and differentiable (e.g. in the
    weights $\rho_1$). Checks run on concrete values only.
    """

    intra_laplacian: Float[Array, "p p"]
    inter_laplacian: Float[Array, "q q"]
    rho1: Float[Array, " p"]
    rho2: Float[Array, " p"]

    def __init__(
        self,
        intra_laplacian: MatrixLike,
        inter_laplacian: MatrixLike,
        rho1: MatrixLike,
        rho2: MatrixLike,
        *,
        allow_non_laplacian: bool = False,
    ):
        where = "TwoLayerNetwork"
        rho1 = as_float(rho1, "rho1", where)
        if rho1.ndim != 1:
            raise ValueError(f"{where}: `rho1` must be a vector, got shape {rho1.shape}.")
        p = rho1.shape[0]
        rho2 = as_float(rho2, "rho2", where)
        if rho2.shape != (p,):
            raise ValueError(
                f"{where}: `rho2` must have the shape of `rho1`, ({p},), got shape {rho2.shape}."
            )
        for name, value in (("rho1", rho1), ("rho2", rho2)):
            if not is_traced(value) and not np.all(np.isfinite(np.asarray(value))):
                raise ValueError(f"{where}: `{name}` must be finite, got {describe(value)}.")
        if allow_non_laplacian:
            l1 = as_float(intra_laplacian, "intra_laplacian", where)
            if l1.shape != (p, p):
                raise ValueError(
                    f"{where}: `intra_laplacian` must have shape ({p}, {p}) to match `rho1`, "
                    f"got shape {l1.shape}."
                )
        else:
            l1 = check_laplacian(where, "intra_laplacian", intra_laplacian, size=p)
        self.intra_laplacian = l1
        self.inter_laplacian = check_laplacian(where, "inter_laplacian", inter_laplacian)
        self.rho1 = rho1
        self.rho2 = rho2

    @property
    def groups(self) -> int:
        """$q$."""
        return self.inter_laplacian.shape[0]

    @property
    def agents_per_group(self) -> int:
        """$p$."""
        return self.rho1.shape[0]

    @property
    def delta(self) -> Float[Array, "p p"]:
        r"""$\Delta = \rho_1\rho_2^T$."""
        return jnp.outer(self.rho1, self.rho2)

    def intra(self, x: Float[Array, "q p *f"]) -> Float[Array, "q p *f"]:
        r"""$(I_q\otimes L_1)\,x$ on the `(q, p, ...)` array."""
        return jnp.einsum("ij,nj...->ni...", self.intra_laplacian, x)

    def inter(self, x: Float[Array, "q p *f"]) -> Float[Array, "q p *f"]:
        r"""$(L_2\otimes\Delta)\,x = \rho_1\,\sum_b (L_2)_{nb}\,(\rho_2^T x_b)$, in
        $O(qp + q^2)$ per feature (the rank-one $\Delta$ is never formed)."""
        up = jnp.einsum("j,bj...->b...", self.rho2, x)  # rho2^T x_b, one per group
        mixed = jnp.einsum("nb,b...->n...", self.inter_laplacian, up)
        return jnp.einsum("i,n...->ni...", self.rho1, mixed)

    def kron_intra(self) -> Float[Array, "N N"]:
        r"""$W_1 = I_q\otimes L_1$ as a dense matrix (small networks, checks)."""
        return jnp.kron(
            jnp.eye(self.groups, dtype=self.intra_laplacian.dtype), self.intra_laplacian
        )

    def kron_inter(self) -> Float[Array, "N N"]:
        r"""$W_2 = L_2\otimes\Delta$ as a dense matrix (small networks, checks)."""
        return jnp.kron(self.inter_laplacian, self.delta)

    def modes(self) -> tuple[Float[Array, " q"], Float[Array, "q q"]]:
        r"""$(\lambda, U)$ with $L_2 = U\,\mathrm{diag}(\lambda)\,U^T$, eigenvalues ascending
        ($\lambda_1 = 0$ for a Laplacian); differentiable where they are simple. Each
        eigenvector's sign makes its entries' sum non-negative, so $u_1 = \mathbf 1/\sqrt q$."""
        lam, u = jnp.linalg.eigh(self.inter_laplacian)
        return lam, u * jnp.where(jnp.sum(u, axis=0, keepdims=True) < 0, -1.0, 1.0)

    def modal(self, x: Float[Array, "q p *f"]) -> Float[Array, "q p *f"]:
        r"""Modal coordinates $g = (U^T\otimes I_p)\,x$ (row $k$: mode $k$)."""
        _, u = self.modes()
        return jnp.einsum("bk,bj...->kj...", u, x)

    def from_modal(self, g: Float[Array, "q p *f"]) -> Float[Array, "q p *f"]:
        r"""$x = (U\otimes I_p)\,g$."""
        _, u = self.modes()
        return jnp.einsum("bk,kj...->bj...", u, g)
