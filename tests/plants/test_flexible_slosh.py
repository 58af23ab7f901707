"""Beam modal analysis, the slosh + appendage plant and its mass-matrix checks (Shi & Song 2024).

Oracles: the classical cantilever roots (Blevins), closed-form integrals of the cantilever
shapes (int phi^2 = l, int phi = 2 sigma / beta), the second-order equations (4)-(5) evaluated
with `jax.jvp` along the flow, and conservation of the physical energy
1/2 xi^T M xi + potentials (M the coupled mass matrix, xi = (omega, eta', n')) with no damping
and no torque, which holds only if the reading of J and the couplings is consistent.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxatt.plants import (
    CantileverBeam,
    FlexibleSloshSpacecraft,
    ModalAppendage,
    SloshPendulum,
    cantilever_modes,
    cantilever_roots,
    mode_shape,
)


PAPER_J = jnp.array([[503.0, 0, 0], [0, 385, -5], [0, -5, 420]])


def paper_beam():
    return CantileverBeam(7e10, 3e-9, 2.8e3 * 1.125e-2, 3.0, 0.65)


def paper_slosh(damping=(0.05, 0.05, 0.05)):
    return SloshPendulum(10.0, 0.228, 1.689, [0.8, 0.0, 0.0], damping)


def test_cantilever_roots_match_classical_values():
    """beta_i l to 1e-6 relative of 1.8751, 4.6941, 7.8548 (and of their 16-digit values)."""
    roots = np.array(cantilever_roots(3))
    np.testing.assert_allclose(roots, [1.8751, 4.6941, 7.8548], rtol=3e-5)
    np.testing.assert_allclose(
        roots, [1.875104068711961, 4.694091132974175, 7.854757438237613], rtol=1e-6
    )
    assert np.all(np.abs(np.cos(roots) * np.cosh(roots) + 1) < 1e-11)
    # The frequencies are beta_i^2 sqrt(EI / rho A): the dimensionless ratio recovers beta_i l.
    beam = paper_beam()
    modes = cantilever_modes(beam)
    scale = np.sqrt(210.0 / 31.5) / 3.0**2
    np.testing.assert_allclose(np.sqrt(np.asarray(modes.frequencies) / scale), roots, rtol=1e-12)
    with pytest.raises(ValueError, match="n_modes"):
        cantilever_roots(0)


def test_modal_data_against_closed_forms_and_spec():
    """int phi^2 = l, int phi = 2 sigma/beta, corrected K_s = u^2 EI int phi''^2 = omega^2; the
    paper's numbers from SPEC (1.0087, 6.321, 17.70 rad/s; b = -21.54, -5.39, -2.55)."""
    beam = paper_beam()
    modes = cantilever_modes(beam)
    length, rho_a = 3.0, 31.5
    np.testing.assert_allclose(modes.normalization, 1 / np.sqrt(rho_a * length), rtol=1e-12)
    x, w = np.polynomial.legendre.leggauss(80)
    y = 0.5 * length * (x + 1)
    for beta in np.asarray(modes.beta):
        big = beta * length
        sigma = (np.cosh(big) + np.cos(big)) / (np.sinh(big) + np.sin(big))
        naive = (
            np.cosh(beta * y) - np.cos(beta * y) - sigma * (np.sinh(beta * y) - np.sin(beta * y))
        )
        np.testing.assert_allclose(mode_shape(beam, beta, y), naive, atol=1e-9)
        integral = 0.5 * length * np.sum(w * np.asarray(mode_shape(beam, beta, y)))
        np.testing.assert_allclose(integral, 2 * sigma / beta, rtol=1e-12)
    # b_i = -u rho A (r0 int phi + int y phi), with int phi known in closed form.
    np.testing.assert_allclose(modes.frequencies, [1.0087, 6.3214, 17.700], rtol=1e-4)
    np.testing.assert_allclose(modes.coupling, [-21.536, -5.389, -2.553], atol=1e-3)
    np.testing.assert_allclose(np.sum(np.asarray(modes.coupling) ** 2), 499.37, atol=0.01)
    assert np.sum(np.asarray(modes.coupling) ** 2) < float(beam.hub_axis_inertia())
    # The printed K_s (u, not u^2) is not omega^2: sqrt gives 3.145 rad/s for mode 1.
    np.testing.assert_allclose(
        np.asarray(modes.literal_stiffness) * np.asarray(modes.normalization),
        np.asarray(modes.frequencies) ** 2,
        rtol=1e-10,
    )
    np.testing.assert_allclose(np.sqrt(modes.literal_stiffness[0]), 3.145, atol=1e-3)


def test_mass_matrix_readings():
    """Effective-J reading: M positive definite, total inertia J + B^T B + delta^T A^-1 delta;
    the total-J reading of the printed data is indefinite (-0.207) and refused."""
    appendage = ModalAppendage.from_beam(paper_beam(), [0.01, 0.007, 0.005])
    plant = FlexibleSloshSpacecraft(PAPER_J, paper_slosh(), appendage)
    eig = np.linalg.eigvalsh(np.asarray(plant.mass_matrix()))
    assert eig[0] > 0.4
    np.testing.assert_allclose(
        np.diag(plant.total_inertia()), [503.0, 385 + 6.4, 420 + 6.4 + 499.3739], atol=1e-3
    )
    literal = np.linalg.eigvalsh(np.asarray(plant.mass_matrix_for_total(PAPER_J)))
    np.testing.assert_allclose(literal[0], -0.2066, atol=1e-4)
    with pytest.raises(ValueError, match=r"(?s)`inertia`.*not positive definite"):
        FlexibleSloshSpacecraft(PAPER_J, paper_slosh(), appendage, inertia_is_total=True)
    total = plant.total_inertia()
    again = FlexibleSloshSpacecraft(total, paper_slosh(), appendage, inertia_is_total=True)
    np.testing.assert_allclose(again.inertia, PAPER_J, atol=1e-10)


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: CantileverBeam(0.0, 3e-9, 31.5, 3.0), "youngs_modulus"),
        (lambda: CantileverBeam(7e10, -1.0, 31.5, 3.0), "area_moment"),
        (lambda: CantileverBeam(7e10, 3e-9, 0.0, 3.0), "mass_per_length"),
        (lambda: CantileverBeam(7e10, 3e-9, 31.5, -3.0), "length"),
        (lambda: ModalAppendage([1.0, 0.0], [0.01, 0.01], np.zeros((2, 3))), "frequencies"),
        (lambda: ModalAppendage([1.0, 2.0], [0.01, 0.0], np.zeros((2, 3))), "damping"),
        (lambda: ModalAppendage([1.0, 2.0], [0.01, -0.1], np.zeros((2, 3))), "damping"),
        (lambda: ModalAppendage.from_beam(paper_beam(), [0.01, -0.007]), "damping"),
        (lambda: paper_slosh((0.05, 1.0, 0.05)), "damping"),
        (lambda: SloshPendulum(0.0, 0.228, 1.689, [0.8, 0, 0], [0.05] * 3), "mass"),
    ],
)
def test_bad_input_is_refused(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def _plant(damped: bool):
    xi = [0.01, 0.007, 0.005] if damped else [1e-300] * 3
    slosh = paper_slosh((0.05, 0.05, 0.05) if damped else (0.0, 0.0, 0.0))
    return FlexibleSloshSpacecraft(PAPER_J, slosh, ModalAppendage.from_beam(paper_beam(), xi))


def _state(plant):
    x = plant.rest_state(
        jnp.array([0.9, 0.3, -0.2, -0.25]) / jnp.linalg.norm(jnp.array([0.9, 0.3, -0.2, -0.25])),
        jnp.array([0.02, -0.03, 0.05]),
    )
    return type(x)(
        x.q,
        x.omega,
        jnp.array([1e-3, -2e-3]),
        x.psi + 0.01,
        jnp.array([0.1, -0.02, 0.003]),
        x.zeta - 0.05,
    )


def test_second_order_equations_hold_along_the_flow():
    """(4) A eta'' + C_f eta' + delta w' + K_f eta = 0 and (5) B w' + n'' + C_s n' + K_s n = 0,
    with eta'', n'' from `jax.jvp` of the rates along the vector field."""
    plant = _plant(True)
    x = _state(plant)
    tau = jnp.array([1.0, -2.0, 0.5])
    x_dot = plant.vector_field(0.3, x, tau)

    def rates(state):
        eta_dot, _, n_dot, _ = plant.internal_rates(state)
        return eta_dot, n_dot

    (eta_dot, n_dot), (eta_dd, n_dd) = jax.jvp(rates, (x,), (x_dot,))
    s = plant.slosh
    res4 = (
        s.mass_matrix() @ eta_dd
        + s.damping_matrix() @ eta_dot
        + s.coupling() @ x_dot.omega
        + s.stiffness_matrix() @ x.eta
    )
    a = plant.appendage
    res5 = a.coupling @ x_dot.omega + n_dd + a.damping_matrix() @ n_dot + a.stiffness_matrix() @ x.n
    assert float(jnp.max(jnp.abs(res4))) < 1e-12
    assert float(jnp.max(jnp.abs(res5))) < 1e-12
    # Lumped disturbance: J w' = -w x J w + T_bar + tau by definition, and without couplings,
    # perturbation or T_d it would vanish; here it is the reaction of slosh and modes.
    t_bar = plant.lumped_disturbance(0.3, x, tau)
    np.testing.assert_allclose(
        PAPER_J @ x_dot.omega, -jnp.cross(x.omega, PAPER_J @ x.omega) + t_bar + tau, atol=1e-12
    )


def test_energy_is_conserved_without_damping_and_dissipated_with_it():
    """E = 1/2 xi^T M xi + 1/2 eta^T K_f eta + 1/2 n^T K_s n, xi = (w, eta', n'):
    dE/dt = w^T tau - eta'^T C_f eta' - n'^T C_s n' (the gyroscopic term does no work)."""

    def energy(plant, x):
        eta_dot, _, n_dot, _ = plant.internal_rates(x)
        xi = jnp.concatenate([x.omega, eta_dot, n_dot])
        kinetic = 0.5 * xi @ plant.mass_matrix() @ xi
        return (
            kinetic
            + 0.5 * x.eta @ plant.slosh.stiffness_matrix() @ x.eta
            + 0.5 * x.n @ plant.appendage.stiffness_matrix() @ x.n
        )

    tau = jnp.array([0.3, -0.1, 0.2])
    for damped in (False, True):
        plant = _plant(damped)
        x = _state(plant)
        x_dot = plant.vector_field(0.0, x, tau)
        _, e_dot = jax.jvp(lambda s: energy(plant, s), (x,), (x_dot,))
        eta_dot, _, n_dot, _ = plant.internal_rates(x)
        expected = x.omega @ tau
        if damped:
            expected -= eta_dot @ plant.slosh.damping_matrix() @ eta_dot
            expected -= n_dot @ plant.appendage.damping_matrix() @ n_dot
        np.testing.assert_allclose(float(e_dot), float(expected), rtol=1e-9, atol=1e-13)


@pytest.mark.parametrize(
    "build, match",
    [
        # a (N,) parameter broadcast through the modal integrals (a cryptic shape error there,
        # or one modal data set per entry)
        (
            lambda: CantileverBeam([7e10, 7e10], 3e-9, 31.5, 3.0),
            "`youngs_modulus` must be a scalar",
        ),
        (lambda: CantileverBeam(7e10, 3e-9, 31.5, 3.0, [0.0, 0.65]), "`root_offset` must be a"),
        # np.int64 was refused as "not a positive integer, got 2"; True was read as 1 mode
        (lambda: cantilever_modes(paper_beam(), True), "`n_modes` must be a positive integer"),
        (lambda: cantilever_modes(paper_beam(), 2, quadrature_order=0), "`quadrature_order`"),
        # axis=2.0 passed `axis in (0, 1, 2)` and failed as a float index
        (lambda: ModalAppendage.from_beam(paper_beam(), [0.01], axis=2.0), "`axis` must be"),
        (lambda: ModalAppendage.from_beam(paper_beam(), [0.01], axis=True), "`axis` must be"),
        # a (2,) or (3,) mass gave a wrong-shaped A = m I_2 or delta
        (
            lambda: SloshPendulum([10.0, 10.0], 0.228, 1.689, [0.8, 0, 0], [0.05] * 3),
            "SloshPendulum: `mass` must be a scalar",
        ),
        (
            lambda: SloshPendulum(10.0, 0.228, [1.689] * 3, [0.8, 0, 0], [0.05] * 3),
            "SloshPendulum: `gravity` must be a scalar",
        ),
        # bool("False") is True: the string read the inertia as the total one
        (
            lambda: FlexibleSloshSpacecraft(
                PAPER_J,
                paper_slosh(),
                ModalAppendage([1.0], [0.01], [[0, 0, 1.0]]),
                inertia_is_total="False",
            ),
            "FlexibleSloshSpacecraft: `inertia_is_total` must be True or False",
        ),
    ],
)
def test_beam_and_slosh_refuse_bad_parameters(build, match, no_jaxtyping):
    with pytest.raises(ValueError, match=match):
        build()


def test_cantilever_roots_accept_numpy_integers(no_jaxtyping):
    """(the annotation says int; without the test hook a NumPy integer is an integer)"""
    assert cantilever_roots(np.int64(2)) == cantilever_roots(2)
