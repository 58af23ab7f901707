"""Reference constructors refuse arguments that gave NaN or a plausible wrong trajectory."""

import jax
import jax.numpy as jnp
import pytest

from jaxatt.references import ConstantPose, ConstantPosition, FlyAround


_NAN, _INF = float("nan"), float("inf")
_ORBIT = (7e6, 0.1, 0.5, 0.1, 0.2)
_CIRCLE = {"radius": 100.0, "rate": 1e-3, "normal": jnp.array([0.0, 0.0, 1.0])}


def _fly_around(**changes):
    return FlyAround(*_ORBIT, **{**_CIRCLE, **changes})


@pytest.mark.usefixtures("no_jaxtyping")
@pytest.mark.parametrize(
    ("build", "needle"),
    [
        # A NaN or infinite held position was the reference, so every error became NaN.
        (lambda: ConstantPosition(jnp.array([1.0, _NAN, 0.0])), "ConstantPosition: `position`"),
        (lambda: ConstantPosition(jnp.full(3, _INF)), "ConstantPosition: `position`"),
        (lambda: ConstantPose(jnp.array([_NAN, 0.0, 0.0])), "ConstantPosition: `position`"),
        # An infinite entry normalised to a NaN normal: every output NaN.
        (
            lambda: _fly_around(normal=jnp.array([0.0, 0.0, _INF])),
            "FlyAround: `normal` must be a finite non-zero vector",
        ),
        # (3,) scalars broadcast into the (3,) position: a plausible but meaningless circle.
        (lambda: _fly_around(rate=jnp.ones(3) * 1e-3), "FlyAround: `rate` must be a scalar"),
        (lambda: _fly_around(t0=jnp.ones(3)), "FlyAround: `t0` must be a scalar"),
    ],
)
def test_bad_reference_arguments_are_refused(build, needle):
    with pytest.raises(ValueError, match=needle):
        build()


def test_fly_around_normal_may_be_traced():
    """The normal's check is one predicate: a traced normal (here under `jit`) is built, where
    the host-only check called NumPy on the tracer."""
    normal = jnp.array([0.0, 0.0, 2.0])
    traced = jax.jit(lambda n: _fly_around(normal=n).normal)(normal)
    assert jnp.allclose(traced, jnp.array([0.0, 0.0, 1.0]))


def test_fly_around_phase_origin_is_the_documented_axis():
    """`phase` is measured from `basis()[0]`, documented as -y for the normal z (phase 0 on the
    negative along-track axis) and +y for the normal x."""
    for normal, a, b in (
        ([0.0, 0.0, 1.0], [0, -1, 0], [1, 0, 0]),
        ([1.0, 0, 0], [0, 1, 0], [0, 0, 1]),
    ):
        got_a, got_b = _fly_around(normal=jnp.array(normal)).basis()
        assert jnp.allclose(got_a, jnp.array(a, float)) and jnp.allclose(got_b, jnp.array(b, float))
