r"""Two-layer consensus with intermittent inter-layer communication (Duan et al. 2024).

The protocol, corrected to match the closed loop (5) the paper analyses (SPEC seed 002(a)):
$$u_{n,m}(t) = -\sum_a (L_1)_{ma}\,x_{n,a}(t) - \sum_b (L_2)_{nb}\sum_a \Delta_{ma}\,
x_{b,a}(t_i),\qquad t\in[t_i, t_{i+1}),$$
i.e. $\dot x = -(I_q\otimes L_1)\,x(t) - (L_2\otimes\Delta)\,x(t_i)$: the intra-group coupling
is continuous, the inter-layer coupling reads samples held by a
[`jaxatt.networks.SampledLink`][]. The printed protocol (2) has the opposite sign and samples
both terms; it is inconsistent with (4)-(5).
"""

from typing import ClassVar

from .._validation import check_instance
from ..networks import LinkState, SampledLink, TwoLayerNetwork
from ..plants._agents import AgentsState
from ._base import AbstractController


class TwoLayerConsensus(AbstractController):
    r"""$u = -(I_q\otimes L_1)\,x(t) - (L_2\otimes\Delta)\,x(t_i)$ on `(q, p, ...)` arrays.

    **Arguments:**
    - `network`: a [`jaxatt.networks.TwoLayerNetwork`][] ($L_1$, $L_2$, $\rho_1$, $\rho_2$).
    - `link`: the [`jaxatt.networks.SampledLink`][] carrying $x(t_i)$ (periodic or random
      intervals); simulate with `dt = link.schedule.step` and continuous control, so the
      intra-group term acts continuously and the link samples after completed steps.

    The controller state is the link's [`jaxatt.networks.LinkState`][]; signals: `"held"`
    (the held samples) and `"samples"` (the number taken so far).
    """

    network: TwoLayerNetwork
    link: SampledLink
    measurement_type: ClassVar[type] = AgentsState

    def __init__(self, network: TwoLayerNetwork, link: SampledLink):
        where = "TwoLayerConsensus"
        check_instance(
            where, "network", network, TwoLayerNetwork, "a jaxatt.networks.TwoLayerNetwork"
        )
        check_instance(where, "link", link, SampledLink, "a jaxatt.networks.SampledLink")
        self.network = network
        self.link = link

    def init(self, t0, measurement: AgentsState, reference) -> LinkState:
        # shapes are static: this check also holds (at trace time) inside a compiled run
        expected = (self.network.groups, self.network.agents_per_group)
        shape = tuple(measurement.x.shape)
        if shape[:2] != expected:
            raise ValueError(
                f"TwoLayerConsensus: the network couples {expected[0]} groups of {expected[1]} "
                f"agents, but the plant's state x has shape {shape}; build the plant as "
                f"SingleIntegratorAgents({expected[0]}, {expected[1]}, features)."
            )
        return self.link.init(t0, measurement.x)

    def __call__(self, t, measurement: AgentsState, reference, state: LinkState):
        u = -self.network.intra(measurement.x) - self.network.inter(state.held)
        return u, SampledLink.zero_derivative(state)

    def update(self, t, measurement: AgentsState, reference, state: LinkState) -> LinkState:
        return self.link.update(t, measurement.x, state)

    def signals(self, t, measurement, reference, state: LinkState):
        return {"held": state.held, "samples": state.count}
