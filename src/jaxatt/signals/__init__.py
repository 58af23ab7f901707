"""Known functions of time: disturbances, inertia perturbations, commands, desired rates.

A signal is an `eqx.Module` called as `signal(t)`; its amplitudes, frequencies and phases are
array fields, so they can be sampled in a Monte Carlo batch or differentiated. Plants,
references and open-loop controllers take signals as fields. (`jaxatt.plants` re-exports them
for convenience.)
"""

from ._signals import (
    AbstractSignal as AbstractSignal,
    Constant as Constant,
    Pulse as Pulse,
    Sinusoid as Sinusoid,
    Sum as Sum,
    check_signal_shape as check_signal_shape,
)
