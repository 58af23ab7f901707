"""SingleIntegratorAgents' sizes (its dynamics are tested with the consensus protocols in
tests/networks)."""

import numpy as np
import pytest

from jaxatt.plants import SingleIntegratorAgents


@pytest.mark.parametrize(
    "args, match",
    [
        ((True, 4), "`groups` must be a positive integer, got True"),  # read as 1 group
        ((3, 2.5), "`agents` must be a positive integer"),
        ((float("nan"), 4), "`groups` must be a positive integer"),  # int(nan): bare ValueError
        ((None, 4), "`groups` must be a positive integer"),  # int(None): bare TypeError
        ((3, 4, (0,)), r"`features\[0\]` must be a positive integer"),  # an empty state
        ((3, 4, (-2,)), r"`features\[0\]` must be a positive integer"),
        ((3, 4, 2), "`features` must be a tuple"),  # 'int' object is not iterable
    ],
)
def test_bad_sizes_are_refused(args, match, no_jaxtyping):
    with pytest.raises(ValueError, match="SingleIntegratorAgents: " + match):
        SingleIntegratorAgents(*args)


def test_numpy_sizes_are_accepted(no_jaxtyping):
    plant = SingleIntegratorAgents(np.int64(3), np.int32(4), (np.int64(2),))
    assert (plant.groups, plant.agents, plant.features) == (3, 4, (2,))
