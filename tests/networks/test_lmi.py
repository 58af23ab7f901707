"""The LMI certificate (cvxpy + Clarabel, the `lmi` extra): the textbook sampled-data example,
the margin and eigenvalue re-check, the printed form's closed-form ceiling, bad input and a
missing cvxpy."""

import builtins

import numpy as np
import pytest

from jaxatt.networks import (
    CORRECTED,
    PRINTED,
    LMIForm,
    LMIResult,
    lmi_feasibility,
    lmi_tau_max,
    printed_form_ceiling,
)


# Zhang, Branicky & Phillips (2001, IEEE Control Systems Magazine 21(1)); Fridman, Seuret &
# Richard (2004, Automatica 40(8)); Fridman (2010, Automatica 46(2)): x' = A x + B K x(t_k).
A = np.array([[0.0, 1.0], [0.0, -0.1]])
BK = np.array([[0.0, 0.0], [-0.375, -1.15]])
EXACT_TEXTBOOK = 1.7294  # our exact periodic bound (tests/networks/test_exact style bisection)


def _exact_bound(a, b):
    import scipy.linalg as sl

    def radius(h):
        m = np.zeros((4, 4))
        m[:2, :2], m[:2, 2:] = a, b
        e = sl.expm(m * h)
        return np.max(np.abs(np.linalg.eigvals(e[:2, :2] + e[:2, 2:])))

    lo, hi = 1.0, 2.0
    assert radius(lo) < 1 < radius(hi)
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if radius(mid) < 1 else (lo, mid)
    return lo


def test_textbook_example_bound_lies_below_the_exact_one():
    """Exact periodic bound 1.7294 s (SciPy expm here, independent of the jaxatt code; the
    literature quotes 1.729); the corrected LMI certifies tau = 1.043 s, below it, and above
    the 0.869 s of Fridman, Seuret & Richard's (2004) input-delay LMI (a different,
    descriptor-based functional). Feasible just below, infeasible just above its bound."""
    exact = _exact_bound(A, BK)
    np.testing.assert_allclose(exact, EXACT_TEXTBOOK, atol=1e-4)
    tau = lmi_tau_max(A, BK, CORRECTED, tau_low=0.5, tau_high=1.5, tol=2e-3)
    assert 1.035 < tau < 1.05
    # A bracket whose upper end is still feasible gives that end, flagged as a lower bound.
    with pytest.warns(UserWarning, match="feasible at the bracket's upper end tau_high=0.9"):
        assert lmi_tau_max(A, BK, CORRECTED, tau_low=0.5, tau_high=0.9) == 0.9
    assert 0.869 < tau < exact
    inside = lmi_feasibility(A, BK, tau - 0.01)
    outside = lmi_feasibility(A, BK, tau + 0.01)
    assert inside.feasible and inside.margin > 1e-7 and inside.max_eigenvalue < 0
    assert np.linalg.eigvalsh(inside.P)[0] > 0 and np.linalg.eigvalsh(inside.S)[0] > 0
    assert not outside.feasible and outside.margin < 1e-7


def test_printed_form_is_infeasible_for_every_tau_and_each_erratum_matters():
    """Mode lambda = 3 of Duan's example: the corrected LMI is feasible at tau = 0.2 s but not
    at the paper's 0.26 s; the printed form fails even at tau = 0.01 s because its
    L1 - lambda Delta is not Hurwitz (trace 8 - 2 lambda = 2 > 0)."""
    l1 = np.array([[1, -1, 0, 0], [-1, 3, -2, 0], [0, -2, 3, -1], [0, 0, -1, 1]], float)
    delta = np.outer([2.0, 1.0, 2.0, 1.0], [1.0, 0.0, 0.0, 0.0])
    a, b = -l1, -3.0 * delta
    assert lmi_feasibility(a, b, 0.2).feasible
    assert not lmi_feasibility(a, b, 0.26).feasible
    assert not lmi_feasibility(a, b, 0.01, PRINTED).feasible
    assert lmi_feasibility(a, b, 0.01, LMIForm(tau_factor=False, e2=False)).feasible
    assert not lmi_feasibility(a, b, 0.01, LMIForm(eta_sign=False)).feasible
    ceiling = printed_form_ceiling(l1, delta, 3.0)
    assert ceiling["trace"] == 2.0 and ceiling["infeasible_for_every_tau"]
    assert printed_form_ceiling(l1, delta, 1.0)["trace"] == 6.0
    assert lmi_tau_max(a, b, PRINTED, tau_low=0.01) == 0.0


def test_bad_input_and_missing_cvxpy(monkeypatch):
    with pytest.raises(ValueError, match="`tau` must be positive"):
        lmi_feasibility(A, BK, 0.0)
    with pytest.raises(ValueError, match="`tau` must be positive"):
        lmi_tau_max(A, BK, tau_high=-1.0)
    with pytest.raises(ValueError, match="`tau_low` < `tau_high`, got tau_low=0.5, tau_high=0.5"):
        lmi_tau_max(A, BK, tau_low=0.5, tau_high=0.5)
    with pytest.raises(ValueError, match="`b` must have the shape of `a`"):
        lmi_feasibility(A, np.eye(3), 0.1)
    # a scalar delta broadcast against L1 into another matrix and a plausible verdict
    with pytest.raises(ValueError, match="printed_form_ceiling: `delta` must have the shape"):
        printed_form_ceiling(-A, 1.0, 1.0)
    with pytest.raises(ValueError, match="printed_form_ceiling: `intra_laplacian`, `delta` and"):
        printed_form_ceiling(-A, BK, float("nan"))
    real_import = builtins.__import__

    def no_cvxpy(name, *args, **kwargs):
        if name == "cvxpy" or name.startswith("cvxpy."):
            raise ImportError("No module named 'cvxpy'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_cvxpy)
    with pytest.raises(ImportError, match=r"pip install 'jaxatt\[lmi\]'"):
        lmi_feasibility(A, BK, 0.1)


def _solver(monkeypatch, answer):
    """Replace the solves by `answer(tau) -> (feasible, status)` (a feasible solve certified,
    a not-feasible one with a margin just below zero, as Clarabel gives them)."""
    from jaxatt.networks import _lmi

    def solve(a, b, tau, form=CORRECTED):
        feasible, status = answer(tau)
        margin = 1e-3 if feasible else -1e-9
        return LMIResult(feasible, margin, -margin, margin, status, None, None, None)

    monkeypatch.setattr(_lmi, "lmi_feasibility", solve)


def test_an_inconclusive_solve_is_neither_feasible_nor_infeasible(monkeypatch):
    # Regression (review): a solver error, or an inaccurate answer without a certificate, was
    # taken as "infeasible": at tau_low the bound became 0.0 ("no tau certified"), at the
    # bracket's upper end a plausible bisection value.
    def result(feasible, margin, status):
        return LMIResult(feasible, margin, -margin, margin, status, None, None, None)

    assert result(False, -1e-9, "optimal").conclusive
    assert result(True, 1e-3, "optimal_inaccurate").conclusive  # the re-check certifies
    assert not result(False, -1e-9, "optimal_inaccurate").conclusive
    assert not result(False, -np.inf, "solver_error").conclusive
    assert not result(False, 1e-3, "optimal").conclusive  # a margin the re-check refuted

    def bound():
        return lmi_tau_max(A, BK, tol=1e-3)

    _solver(monkeypatch, lambda tau: (tau < 0.8, "optimal"))
    assert 0.8 - 1e-3 <= bound() < 0.8
    # an inaccurate answer at tau_high does not matter: the final upper end was shown
    _solver(monkeypatch, lambda tau: (tau < 0.8, "optimal_inaccurate" if tau == 2 else "optimal"))
    assert 0.8 - 1e-3 <= bound() < 0.8
    # the solver fails above 0.8 s: nothing shows where the certificate stops
    _solver(monkeypatch, lambda tau: (tau < 0.8, "optimal" if tau < 0.8 else "solver_error"))
    assert np.isnan(bound())
    # inaccurate at tau_low: no bound, not "no tau"
    _solver(monkeypatch, lambda tau: (False, "optimal_inaccurate"))
    assert np.isnan(bound())
    _solver(monkeypatch, lambda tau: (False, "optimal"))
    assert bound() == 0.0
    # the printed form of Duan's mode lambda = 3 fails the closed-form necessary condition: 0.0
    # whatever the solver says (Clarabel 0.11 answers "optimal_inaccurate" at 0.001 s)
    l1 = np.array([[1, -1, 0, 0], [-1, 3, -2, 0], [0, -2, 3, -1], [0, 0, -1, 1]], float)
    delta = np.outer([2.0, 1.0, 2.0, 1.0], [1.0, 0.0, 0.0, 0.0])
    _solver(monkeypatch, lambda tau: (False, "optimal_inaccurate"))
    assert lmi_tau_max(-l1, -3.0 * delta, PRINTED) == 0.0
    assert np.isnan(lmi_tau_max(-l1, -3.0 * delta, CORRECTED))
