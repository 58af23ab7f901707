"""Test configuration: float64 first (before any array exists), strict promotion, a key fixture."""

import os


os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("JAXATT_SHORT", "1")

import jax  # noqa: E402


jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")

import jax.random as jr  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture
def key():
    return jr.key(0)
