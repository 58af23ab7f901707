"""Networks of agents: graph Laplacians, two-layer (Kronecker) couplings and their modes,
intermittent (sampled, zero-order-held) links, exact sampled-data bounds, and LMI
certificates (the `lmi` extra: `pip install 'jaxatt[lmi]'`, imported on first use).
"""

from ._coupling import TwoLayerNetwork as TwoLayerNetwork
from ._exact import (
    decay_rate as decay_rate,
    disagreement_spectral_radius as disagreement_spectral_radius,
    largest_stable_interval as largest_stable_interval,
    mode_spectral_radii as mode_spectral_radii,
    mode_transitions as mode_transitions,
    network_transition as network_transition,
    sampled_response as sampled_response,
    sampled_transition as sampled_transition,
    spectral_radius as spectral_radius,
)
from ._expm import expm as expm
from ._graphs import (
    algebraic_connectivity as algebraic_connectivity,
    check_laplacian as check_laplacian,
    is_connected as is_connected,
    laplacian_from_adjacency as laplacian_from_adjacency,
    laplacian_from_edges as laplacian_from_edges,
)
from ._lmi import (
    CORRECTED as CORRECTED,
    PRINTED as PRINTED,
    LMIForm as LMIForm,
    LMIResult as LMIResult,
    lmi_feasibility as lmi_feasibility,
    lmi_tau_max as lmi_tau_max,
    network_lmi_tau_max as network_lmi_tau_max,
    printed_form_ceiling as printed_form_ceiling,
)
from ._sampled import (
    LinkState as LinkState,
    SampledLink as SampledLink,
    SampleSchedule as SampleSchedule,
)
