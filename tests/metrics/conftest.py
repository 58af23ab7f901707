"""Fixtures shared by the metrics tests."""

import jaxtyping
import pytest


@pytest.fixture
def no_jaxtyping():
    """Switch off the jaxtyping call-time checks so the library's own ValueErrors are reached.

    (Under the test suite's import hook a wrong rank is already rejected by the annotation;
    users without the hook see the ValueError tested here.)
    """
    jaxtyping.config.update("jaxtyping_disable", True)
    try:
        yield
    finally:
        jaxtyping.config.update("jaxtyping_disable", False)
