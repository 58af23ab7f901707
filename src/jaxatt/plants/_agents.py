r"""Networks of single-integrator agents, $\dot x_{n,m} = u_{n,m}$ (Duan et al. 2024, eq. 1).

The state is one array with the group and agent axes leading, `x` of shape
`(groups, agents, *features)` (scalar agents: `(q, p)`), so a network of 12 or 12 000
agents is the same code and every operation vectorises over agents.
"""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._validation import check_batched_shape, check_positive_int, check_tree_finite
from ..metrics import AbstractMetric, Effort, Peak, SettlingTime
from ..numerics import amax, amin
from ._base import AbstractPlant


class AgentsState(eqx.Module):
    """Positions (or any consensus variable) of all agents, shape `(q, p, *features)` (with
    leading batch axes for a batch of states; `SingleIntegratorAgents.check_state` checks)."""

    x: Float[Array, "..."]


class SingleIntegratorAgents(AbstractPlant):
    r"""$q$ groups of $p$ single integrators, $\dot x = u$ (shapes `(q, p, *features)`).

    **Signals:** `"x"` (the state), `"mean"` ($\bar x$, the average over all agents, per
    feature), `"disagreement"` ($x - \bar x$) and `"spread"` ($\max x - \min x$ over all
    agents, per feature).
    """

    groups: int = eqx.field(static=True)
    agents: int = eqx.field(static=True)
    features: tuple[int, ...] = eqx.field(static=True)
    measurement_type: ClassVar[type] = AgentsState

    def __init__(self, groups: int, agents: int, features: tuple[int, ...] = ()):
        where = "SingleIntegratorAgents"
        self.groups = check_positive_int(where, "groups", groups)
        self.agents = check_positive_int(where, "agents", agents)
        if not isinstance(features, (tuple, list)):
            raise ValueError(
                f"{where}: `features` must be a tuple of positive integers (the shape of one "
                f"agent's variable, () for scalar agents), got {features!r}."
            )
        self.features = tuple(
            check_positive_int(where, f"features[{i}]", f) for i, f in enumerate(features)
        )

    def vector_field(self, t, state: AgentsState, control: Float[Array, "q p *f"]) -> AgentsState:
        return AgentsState(control)

    def measure(self, t, state: AgentsState) -> AgentsState:
        return state

    def signals(self, t, state: AgentsState, reference) -> dict[str, Array]:
        x = state.x
        mean = jnp.mean(x, axis=(0, 1), keepdims=True)
        return {
            "x": x,
            "mean": mean[0, 0],
            "disagreement": x - mean,
            "spread": amax(x, axis=(0, 1)) - amin(x, axis=(0, 1)),
        }

    def default_metrics(self, tolerance: float) -> dict[str, AbstractMetric]:
        """`settling_time` of the spread (its Euclidean norm over the features) to `tolerance`,
        in the state's unit: the time after which all agents stay within `tolerance` of each
        other; `peak_control` $\\max_{t,i}|u_i|$ over all agents; `effort`
        $\\int\\|u\\|^2 dt$ summed over all agents."""
        return {
            "settling_time": SettlingTime("spread", tolerance),
            "peak_control": Peak("u"),
            "effort": Effort("u"),
        }

    def check_state(self, state, name: str = "x0", batch_shape: tuple[int, ...] = ()):
        if not isinstance(state, AgentsState):
            raise ValueError(f"SingleIntegratorAgents: `{name}` must be an AgentsState(x).")
        check_tree_finite("SingleIntegratorAgents", name, state)
        shape = (self.groups, self.agents, *self.features)
        return AgentsState(
            check_batched_shape("SingleIntegratorAgents", f"{name}.x", state.x, shape, batch_shape)
        )
