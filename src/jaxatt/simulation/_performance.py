r"""Performance options: how a simulation is compiled, never what it computes.

Options change the program XLA sees, not the closed loop's equations: results agree to a few
ulps whatever is chosen. They are static (changing them recompiles) and are passed as one
object to [`jaxatt.simulate`][], [`jaxatt.montecarlo.monte_carlo`][] and the tuning
objectives, so that a Monte Carlo study and a tuning run of the same batch compile the same
program.
"""

import math
import numbers

import equinox as eqx
import jax

from ._scalarize import Limits


SCALARIZE_FROM = 1000
"""With `Performance(scalarize=None)` (the default), batches of at least this many samples
at once (per device, or per `lax.map` chunk) are scalarized on CPU backends."""


def _check_size(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"Performance: `{name}` must be a positive integer, got {value!r}.")
    return int(value)


class Performance(eqx.Module):
    r"""How the time loop is compiled.

    **Arguments:**
    - `scalarize`: run the time loop on the scalar entries of every small array (see
      `jaxatt.simulation._scalarize`), so that a `vmap`ped batch lowers to elementwise code on
      one `(batch,)` array per state component. `True`, `False`, or `None` (default): decided
      per backend and batch by [`resolve`][]: on XLA:CPU from [`SCALARIZE_FROM`][] = 1000
      samples run at once on one device, where it was 1.5-3x faster on a 2-core CPU
      (benchmarks/README.md), at about twice the compile time. Below, the gain does not pay
      for the compile. Chen's M1 loop (default metrics, float64, 2-core CPU, 2026-12-03; 1 s
      runs of `monte_carlo` with `scalarize` forced, min of up to 5 after a warm-up): at
      10, 100 and 300 samples a step took 19, 63 and 166 µs scalarized against 22, 78 and
      194 µs plain (1.15-1.24x), but the program compiled in 3.5-3.8 s against 1.8-2.0 s,
      which a run recovers only after about 70 000 steps at 300 samples; at 1000 samples,
      282 against 579 µs (2.05x). Off for a single trajectory (13.7 against 8.3 µs a step)
      and off on GPUs and TPUs, where it has not been measured.
    - `max_scalarized_size`: arrays with more entries than this stay whole (default 64).
    - `max_unrolled_products`: matrix products needing more scalar multiplications than this
      stay one packed product (default 64; a 3x3 matrix product needs 27). Keeps the compile
      time of plants with graph Laplacians or modal matrices linear in their size.

    Forward- and reverse-mode derivatives of a scalarized loop go through the ordinary
    program (same values), so tuning can use the option a Monte Carlo study used.
    """

    scalarize: bool | None = eqx.field(default=None, static=True)
    max_scalarized_size: int = eqx.field(default=64, static=True)
    max_unrolled_products: int = eqx.field(default=64, static=True)

    def __check_init__(self):
        if self.scalarize not in (None, True, False):
            raise ValueError(
                f"Performance: `scalarize` must be True, False or None, got {self.scalarize!r}."
            )
        _check_size("max_scalarized_size", self.max_scalarized_size)
        _check_size("max_unrolled_products", self.max_unrolled_products)

    @property
    def limits(self) -> Limits:
        return Limits(self.max_scalarized_size, self.max_unrolled_products)

    def resolve(self, samples_at_once: int, backend: str | None = None) -> "Performance":
        """These options with `scalarize` decided: the default rule for `samples_at_once`
        samples run together on one device of `backend` (default: JAX's default backend)."""
        if self.scalarize is not None:
            return self
        backend = jax.default_backend() if backend is None else backend
        decided = backend == "cpu" and samples_at_once >= SCALARIZE_FROM
        return Performance(decided, self.max_scalarized_size, self.max_unrolled_products)


def samples_at_once(n: int, *, batch_size: int | None = None, devices: int = 1) -> int:
    """Samples one device runs together: its share of `n`, or the `lax.map` chunk if smaller."""
    per_device = math.ceil(n / max(1, devices))
    return per_device if batch_size is None else min(batch_size, per_device)
