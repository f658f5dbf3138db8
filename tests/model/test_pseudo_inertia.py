"""The barycentric pseudo-inertia P(theta_d) (model/_pseudo_inertia.py, docs/robust.md section 1):
positive semidefinite for the true parameters of the shipped and random robots, the planar
kinetic-energy identity it comes from, and P >= eps I => M(q, theta_d) >= eps M(q, theta_I)
(P(theta_I) = I) positive definite at random configurations, planar and spatial alike."""

from __future__ import annotations

import numpy as np
import pytest

from ffsm_pin.model._pseudo_inertia import (
    adjoint,
    assemble,
    pseudo_inertia,
    pseudo_inertia_adjoint,
)

GEOMETRIES = ["planar", "planar5", "spatial", "random-planar", "random-spatial"]


@pytest.fixture(scope="module")
def model_of(reduced_model_of, make_chain, spatial_chain):
    from ffsm_pin.model import make_model
    from ffsm_pin.robot import load_robot

    def get(name: str):
        if name in ("planar", "spatial"):
            return reduced_model_of(name)
        if name == "planar5":
            return make_model(load_robot("ffsm_planar5.urdf"))
        if name == "random-planar":
            return make_model(make_chain(4, offaxis=True, seed=3))
        return make_model(spatial_chain(4, 2))

    return get


def _configuration(m, rng):
    q_b = rng.uniform(-np.pi, np.pi) if m.m3 == 1 else rng.uniform(-0.5, 0.5, 3)
    return q_b, rng.uniform(-np.pi, np.pi, m.n_joints)


def _theta_of(m, P):
    """theta_d with P(theta_d) = P for P in the image of the map (least squares: exact there)."""
    table = m.pseudo_inertia_table()
    basis = np.array([pseudo_inertia(table, e).ravel() for e in np.eye(m.n_d)])
    theta, *_ = np.linalg.lstsq(basis.T, P.ravel(), rcond=None)
    return theta


def _in_image(m, X):
    """The orthogonal projection of a symmetric X onto the image of theta_d -> P (the PSD
    cone maps into itself: the image's symmetries are orthogonal similarities)."""
    return pseudo_inertia(m.pseudo_inertia_table(), _theta_of(m, X))


@pytest.mark.parametrize("geometry", GEOMETRIES)
def test_true_parameters_are_physical(geometry, model_of):
    m = model_of(geometry)
    P = m.pseudo_inertia(m.theta_d)
    assert np.array_equal(P, P.T)
    lam = np.linalg.eigvalsh(P)
    assert lam[0] > 1e-9 * lam[-1], lam[:3]


@pytest.mark.parametrize("geometry", GEOMETRIES)
def test_compiled_map_and_adjoint_equal_the_numpy_reference(geometry, model_of, rng):
    m = model_of(geometry)
    t = m.pseudo_inertia_table()
    theta = rng.normal(size=m.n_d)
    v = rng.normal(size=t.size)
    P = pseudo_inertia(t, theta)
    np.testing.assert_allclose(assemble(*t, theta), P, rtol=0, atol=1e-13)
    a = pseudo_inertia_adjoint(t, v, m.n_d)
    np.testing.assert_allclose(adjoint(*t[:4], v, m.n_d), a, rtol=0, atol=1e-13)
    assert a @ theta == pytest.approx(v @ P @ v, rel=1e-12)  # the adjoint identity
    assert _theta_of(m, P) == pytest.approx(theta, abs=1e-9)  # the map is one-to-one


@pytest.mark.parametrize("geometry", ["planar", "planar5", "random-planar"])
def test_planar_kinetic_energy_is_the_hermitian_form(geometry, model_of, rng):
    """w^T M w = Re(z^H H z), z_k = dphi_k exp(i phi_k), H = Dc + i Ds (P's upper-left and
    lower-left blocks; collinear: H = P)."""
    m = model_of(geometry)
    S = m.kernel_constants().S
    P = m.pseudo_inertia(m.theta_d)
    nb = m.n_joints + 1
    H = P[:nb, :nb] + 1j * (P[nb:, :nb] if P.shape[0] > nb else 0.0)
    for _ in range(5):
        q_b, q_m = _configuration(m, rng)
        w = rng.normal(size=nb)
        z = (S @ w) * np.exp(1j * m.angles(q_b, q_m))
        lhs = w @ m.mass_matrix(m.theta_d, q_b, q_m) @ w
        assert lhs == pytest.approx((z.conj() @ H @ z).real, rel=1e-12)


@pytest.mark.parametrize("geometry", GEOMETRIES)
def test_physical_parameters_give_a_positive_definite_inertia(geometry, model_of, rng):
    """theta in C = {P >= eps I}, drawn as random PSD matrices plus eps I mapped back:
    M(q, theta) - eps M(q, theta_I) is positive semidefinite and M(q, theta) positive
    definite at random configurations."""
    m = model_of(geometry)
    size = m.pseudo_inertia_table().size
    theta_I = _theta_of(m, np.eye(size))
    for _ in range(5):
        G = rng.normal(size=(size, 2))  # rank 2: P - eps I singular, on C's boundary
        eps = rng.uniform(1e-3, 1.0)
        theta = _theta_of(m, _in_image(m, G @ G.T) + eps * np.eye(size))
        assert np.linalg.eigvalsh(m.pseudo_inertia(theta))[0] >= eps * (1 - 1e-9)
        for _ in range(5):
            q_b, q_m = _configuration(m, rng)
            M = m.mass_matrix(theta, q_b, q_m)
            M_I = m.mass_matrix(theta_I, q_b, q_m)
            assert np.linalg.eigvalsh(M_I)[0] > 0
            gap = np.linalg.eigvalsh(M - eps * M_I)[0]
            assert gap >= -1e-9 * np.abs(M).max(), gap
            assert np.linalg.eigvalsh(M)[0] > 0
