r"""The LMI certificate of Duan et al. (2024), Theorem 1, per mode, with cvxpy + Clarabel.

For $\dot g = A\,g(t) + B\,g(t - \tau(t))$, $0 \le \tau(t) < \tau$ (a sampled-data loop
written as a time-varying delay; mode $k$ of the consensus loop has $A = -L_1$,
$B = -\lambda_k\Delta$), the Lyapunov-Krasovskii functional
$$V = g^TPg + \int_{t-\tau}^t g^TQg\,ds + \int_{-\tau}^0\!\!\int_{t+\theta}^t \dot g^TS\dot g
\,ds\,d\theta$$
and the free-weighting bound on $-\int \dot g^TS\dot g$ over $[t-\tau, t-\tau(t)]$ and
$[t-\tau(t), t]$ (matrices $Z_1, Z_2 \in \mathbb R^{p\times 3p}$) give, with
$\xi = [g(t); g(t-\tau(t)); g(t-\tau)]$, $e_i$ the block selectors,
$\eta = A e_1 + B e_2$ (so $\dot g = \eta\xi$), $E_1 = e_2 - e_3$, $E_2 = e_1 - e_2$:
$$\Phi = \mathrm{He}(e_1^TP\eta) + e_1^TQe_1 - e_3^TQe_3 + \tau\,\eta^TS\eta
- \mathrm{He}(E_1^TZ_1) - \mathrm{He}(E_2^TZ_2),\qquad
\begin{bmatrix}\Phi & \tau Z_j^T\\ \tau Z_j & -\tau S\end{bmatrix} \prec 0,\ j = 1, 2,$$
(the two vertices of the bound, affine in $\tau(t)$), with $P, Q, S \succ 0$.

**Errata (SPEC seed 002(a))**, each a switch of [`LMIForm`][]: the paper prints
$\eta = L_1e_1 - \lambda_k\Delta e_2$ (the sign of the $L_1$ term is wrong, since
$\dot g = -L_1g - \lambda_k\Delta g(t-\tau(t))$), omits the $\tau$ in front of
$\eta^TS\eta$ (the derivative of the double integral is $\tau\dot g^TS\dot g - \int\dots$),
and writes $E_2 = e_1 - e_3$ where $\int_{t-\tau(t)}^t\dot g = (e_1 - e_2)\xi$.

**Strict feasibility, honestly.** Strict inequalities are replaced by a margin $t$:
maximise $t$ subject to $P, Q, S \succeq tI$, $P, Q, S \preceq I$ (the problem is
homogeneous, so this normalises it) and both LMIs $\preceq -tI$. The answer is "feasible"
only if $t > 10^{-7}$ **and** the eigenvalues of the returned matrices, recomputed in NumPy,
confirm $P, Q, S \succ 0$ and both LMIs $\prec 0$ (a solver's "optimal" with $t \approx 0$ is
not a certificate). "Not feasible" is *shown* only by a solve that ended "optimal" with
$t \le 10^{-7}$; a solver error or another status leaves the question open
([`conclusive`][jaxatt.networks.LMIResult.conclusive]). Where the LMIs are not strictly
feasible the optimum is $t = 0$ at the degenerate $P = Q = S = 0$, and Clarabel may stop there
with "optimal_inaccurate" (Duan's example: $\tau$ = 2 s, and the printed form at 0.001 s).
[`lmi_tau_max`][] bisects on $\tau$.

**Necessary condition (a closed-form ceiling).** Take $\xi = (v, v, v)$: then
$E_1\xi = 0$ and, for either $E_2$, $E_2\xi = 0$, so $\xi^T\Phi\xi = 2v^TP\bar Av +
c\,(\bar Av)^TS(\bar Av)$ with $\bar A$ = the matrix $\eta$ applies to $(v, v, v)$
($c \ge 0$). $\Phi \prec 0$ therefore needs $\mathrm{He}(P\bar A) \prec 0$ with $P \succ 0$,
i.e. $\bar A$ Hurwitz, for every $\tau$. In the corrected form $\bar A = A + B$ (the loop
without delay); in the printed form $\bar A = L_1 - \lambda_k\Delta$, whose trace is
$\mathrm{tr}\,L_1 - \lambda_k\,\rho_2^T\rho_1$: when that is $\ge 0$ the printed LMI is
infeasible for **every** $\tau > 0$ ([`printed_form_ceiling`][]).

Requires the `lmi` extra: `pip install 'jaxatt[lmi]'` (cvxpy and clarabel).
"""

import dataclasses
import math
import warnings

import numpy as np

from ._coupling import TwoLayerNetwork
from ._types import MatrixLike


MARGIN_THRESHOLD = 1e-7
"""Smallest margin $t$ accepted as strict feasibility."""


def _cvxpy():
    try:
        import cvxpy  # noqa: PLC0415
    except ImportError as error:  # pragma: no cover - exercised by a monkeypatched import
        raise ImportError(
            "jaxatt.networks: the LMI certificate needs cvxpy and clarabel; install the "
            "`lmi` extra: pip install 'jaxatt[lmi]'"
        ) from error
    return cvxpy


@dataclasses.dataclass(frozen=True)
class LMIForm:
    """Which reading of Theorem 1: each field True is the corrected erratum.

    - `eta_sign`: $\\eta = A e_1 + B e_2 = -L_1e_1 - \\lambda_k\\Delta e_2$ (printed:
      $+L_1e_1$);
    - `tau_factor`: $\\tau\\,\\eta^TS\\eta$ in $\\Phi$ (printed: no $\\tau$);
    - `e2`: $E_2 = e_1 - e_2$ (printed: $e_1 - e_3$).
    """

    eta_sign: bool = True
    tau_factor: bool = True
    e2: bool = True


CORRECTED = LMIForm()
"""Theorem 1 with the three errata corrected (SPEC seed 002(a))."""

PRINTED = LMIForm(eta_sign=False, tau_factor=False, e2=False)
"""Theorem 1 as printed."""


@dataclasses.dataclass(frozen=True)
class LMIResult:
    """The outcome of one LMI solve: `feasible` (margin above the threshold and confirmed by
    the eigenvalue re-check), the `margin` $t$, the re-checked `max_eigenvalue` of the two
    LMIs and `min_eigenvalue` of $P, Q, S$, the solver `status`, and the matrices.

    `feasible` False is a finding only when [`conclusive`][jaxatt.networks.LMIResult.conclusive]
    is True; otherwise the solve neither certified nor ruled out feasibility."""

    feasible: bool
    margin: float
    max_eigenvalue: float
    min_eigenvalue: float
    status: str
    P: np.ndarray | None
    Q: np.ndarray | None
    S: np.ndarray | None

    @property
    def conclusive(self) -> bool:
        """Whether `feasible` settles the question at this $\\tau$: True when feasible (the
        eigenvalue re-check is the certificate) or when the solver ended "optimal" with a
        margin at or below the threshold; False after a solver error, an inaccurate or other
        status without a certificate, or an "optimal" margin the re-check did not confirm."""
        return self.feasible or (self.status == "optimal" and self.margin <= MARGIN_THRESHOLD)


def _check_system(where: str, a: MatrixLike, b: MatrixLike) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{where}: `a` must be a square matrix, got shape {a.shape}.")
    if b.shape != a.shape:
        raise ValueError(f"{where}: `b` must have the shape of `a`, {a.shape}, got {b.shape}.")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError(f"{where}: `a` and `b` must be finite.")
    return a, b


def _check_tau(where: str, tau: float) -> float:
    tau = float(tau)
    if not (math.isfinite(tau) and tau > 0):
        raise ValueError(f"{where}: `tau` must be positive (a sampling bound in s), got {tau!r}.")
    return tau


def lmi_blocks(a: np.ndarray, b: np.ndarray, form: LMIForm = CORRECTED):
    """The constant matrices of $\\Phi$: $(\\eta, E_1, E_2, e_1, e_3)$ for `form`."""
    p = a.shape[0]
    eye, zero = np.eye(p), np.zeros((p, p))
    e1 = np.hstack([eye, zero, zero])
    e2 = np.hstack([zero, eye, zero])
    e3 = np.hstack([zero, zero, eye])
    eta = (a if form.eta_sign else -a) @ e1 + b @ e2
    return eta, e2 - e3, (e1 - e2) if form.e2 else (e1 - e3), e1, e3


def _delay_free_matrix(a: np.ndarray, b: np.ndarray, form: LMIForm) -> np.ndarray:
    """$\\bar A$, the matrix $\\eta$ applies to $\\xi = (v, v, v)$: $\\Phi \\prec 0$ needs it
    Hurwitz (the module's necessary condition)."""
    return (a if form.eta_sign else -a) + b


def lmi_feasibility(
    a: MatrixLike, b: MatrixLike, tau: float, form: LMIForm = CORRECTED
) -> LMIResult:
    """Solve Theorem 1's LMIs for $\\dot g = Ag + Bg(t-\\tau(t))$ at `tau` (maximal margin)."""
    where = "lmi_feasibility"
    a, b = _check_system(where, a, b)
    tau = _check_tau(where, tau)
    cp = _cvxpy()
    p = a.shape[0]
    eta, big_e1, big_e2, e1, e3 = lmi_blocks(a, b, form)
    P = cp.Variable((p, p), symmetric=True)
    Q = cp.Variable((p, p), symmetric=True)
    S = cp.Variable((p, p), symmetric=True)
    Z1 = cp.Variable((p, 3 * p))
    Z2 = cp.Variable((p, 3 * p))
    t = cp.Variable()

    def he(m):
        return m + m.T

    c = tau if form.tau_factor else 1.0
    phi = (
        he(e1.T @ P @ eta)
        + e1.T @ Q @ e1
        - e3.T @ Q @ e3
        + c * (eta.T @ S @ eta)
        - he(big_e1.T @ Z1)
        - he(big_e2.T @ Z2)
    )
    eye = np.eye(p)
    constraints = []
    for m in (P, Q, S):
        constraints += [m >> t * eye, m << eye]
    blocks = []
    for z in (Z1, Z2):
        block = cp.bmat([[phi, tau * z.T], [tau * z, -tau * S]])
        block = 0.5 * (block + block.T)  # symmetric by construction; cvxpy wants it explicit
        blocks.append(block)
        constraints.append(block << -t * np.eye(4 * p))
    problem = cp.Problem(cp.Maximize(t), constraints)
    with warnings.catch_warnings():
        # cvxpy warns about the solver's accuracy or recommends another solver; the
        # eigenvalue re-check below decides.
        warnings.simplefilter("ignore")
        try:
            problem.solve(solver=cp.CLARABEL)
        except cp.error.SolverError:
            return LMIResult(
                False, -math.inf, math.inf, -math.inf, "solver_error", None, None, None
            )
    if t.value is None or P.value is None:
        return LMIResult(
            False, -math.inf, math.inf, -math.inf, str(problem.status), None, None, None
        )
    margin = float(t.value)
    mats = [np.asarray(m.value, dtype=float) for m in (P, Q, S)]
    sym = [0.5 * (m + m.T) for m in mats]
    min_eig = min(float(np.linalg.eigvalsh(m)[0]) for m in sym)
    max_eig = max(
        float(np.linalg.eigvalsh(np.asarray(blk.value, dtype=float))[-1]) for blk in blocks
    )
    feasible = margin > MARGIN_THRESHOLD and min_eig > 0 and max_eig < 0
    return LMIResult(feasible, margin, max_eig, min_eig, str(problem.status), *sym)


def lmi_tau_max(
    a: MatrixLike,
    b: MatrixLike,
    form: LMIForm = CORRECTED,
    *,
    tau_low: float = 1e-3,
    tau_high: float = 2.0,
    tol: float = 1e-3,
) -> float:
    """The largest $\\tau$ at which Theorem 1's LMIs are (strictly) feasible, by bisection.

    Starts from `[tau_low, tau_high]`. Returns 0.0 when no $\\tau$ is certified: the
    closed-form necessary condition fails ($\\bar A$ not Hurwitz, see the module: no $\\tau$ can
    be feasible; a proof, no solve), or a conclusive solve at `tau_low` finds the LMIs not
    feasible there; `tau_high` if they are certified there, with a `UserWarning`: the largest
    $\\tau$ is then only known to be at least `tau_high` (widen the bracket). Bisection assumes
    feasibility is monotone in $\\tau$ (not guaranteed for this functional); the answer is a
    $\\tau$ certified feasible, within `tol` [s] of one shown not feasible by a conclusive solve
    ([`conclusive`][jaxatt.networks.LMIResult.conclusive]). **NaN** when the answer would rest
    on an inconclusive solve (a solver error, or an inaccurate status without a certificate)
    at `tau_low` or at the bracket's final upper end: the bound is then not known.
    """
    where = "lmi_tau_max"
    a, b = _check_system(where, a, b)
    tau_low, tau_high = _check_tau(where, tau_low), _check_tau(where, tau_high)
    tol = _check_tau(where, tol)
    if tau_low >= tau_high:
        raise ValueError(
            f"{where}: the bracket must have `tau_low` < `tau_high`, got tau_low={tau_low}, "
            f"tau_high={tau_high}."
        )
    if np.max(np.linalg.eigvals(_delay_free_matrix(a, b, form)).real) >= 0:
        return 0.0
    low = lmi_feasibility(a, b, tau_low, form)
    if not low.feasible:
        return 0.0 if low.conclusive else math.nan
    high = lmi_feasibility(a, b, tau_high, form)
    if high.feasible:
        warnings.warn(
            f"{where}: the LMIs are feasible at the bracket's upper end tau_high={tau_high}, so "
            "the largest tau is at least that, not known; widen the bracket (larger tau_high).",
            stacklevel=2,
        )
        return tau_high
    lo, hi, shown = tau_low, tau_high, high.conclusive
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        result = lmi_feasibility(a, b, mid, form)
        if result.feasible:
            lo = mid
        else:
            hi, shown = mid, result.conclusive
    return lo if shown else math.nan


def printed_form_ceiling(intra_laplacian: MatrixLike, delta: MatrixLike, lam: float) -> dict:
    r"""The necessary condition of the printed form: $L_1 - \lambda\Delta$ must be Hurwitz.

    Returns its `trace` ($\mathrm{tr}L_1 - \lambda\,\mathrm{tr}\Delta$), its eigenvalues'
    largest real part `max_real_part`, and `infeasible_for_every_tau` (True when it is not
    Hurwitz: no $\tau > 0$ can make the printed LMIs feasible).
    """
    where = "printed_form_ceiling"
    l1 = np.asarray(intra_laplacian, dtype=float)
    if l1.ndim != 2 or l1.shape[0] != l1.shape[1]:
        raise ValueError(
            f"{where}: `intra_laplacian` must be a square matrix, got shape {l1.shape}."
        )
    delta = np.asarray(delta, dtype=float)
    if delta.shape != l1.shape:
        # A scalar or a row broadcast against L1 into another matrix, and a plausible answer.
        raise ValueError(
            f"{where}: `delta` must have the shape of `intra_laplacian`, {l1.shape}, got "
            f"shape {delta.shape}."
        )
    lam = float(lam)
    if not (np.all(np.isfinite(l1)) and np.all(np.isfinite(delta)) and math.isfinite(lam)):
        raise ValueError(f"{where}: `intra_laplacian`, `delta` and `lam` must be finite.")
    m = l1 - lam * delta
    max_real = float(np.max(np.linalg.eigvals(m).real))
    return {
        "trace": float(np.trace(m)),
        "max_real_part": max_real,
        "infeasible_for_every_tau": max_real >= 0,
    }


def network_lmi_tau_max(
    network: TwoLayerNetwork, form: LMIForm = CORRECTED, **bisection
) -> list[float]:
    r"""[`lmi_tau_max`][] for each inter-group mode $k = 2..q$ of a
    [`TwoLayerNetwork`][jaxatt.networks.TwoLayerNetwork] ($A = -L_1$,
    $B = -\lambda_k\Delta$); the network's certified bound is the smallest (NaN if a mode's
    is NaN: take it with `np.min`, which keeps the NaN, not Python's `min`)."""
    lam = np.linalg.eigvalsh(np.asarray(network.inter_laplacian, dtype=float))
    a = -np.asarray(network.intra_laplacian, dtype=float)
    delta = np.asarray(network.delta, dtype=float)
    return [lmi_tau_max(a, -lk * delta, form, **bisection) for lk in lam[1:]]
