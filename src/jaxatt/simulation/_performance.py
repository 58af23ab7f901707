r"""Performance options: how a simulation is compiled, never what it computes.

Options change the program XLA sees, not the closed loop's equations: results agree to a few
ulps whatever is chosen. They are static (changing them recompiles) and are passed as one
object to [`jaxatt.simulate`][], [`jaxatt.montecarlo.monte_carlo`][] and the tuning
objectives, so that a Monte Carlo study and a tuning run of the same batch compile the same
program.
"""

import dataclasses
import functools
import math
import numbers

import equinox as eqx
import jax
import numpy as np

from .._validation import check_positive_int
from ._scalarize import Limits


SCALARIZE_FROM = 1000
"""With `Performance(scalarize=None)` (the default), batches of at least this many samples
at once (per device, or per `lax.map` chunk) are scalarized on CPU backends."""

VECTOR_WIDTHS = (128, 256, 512)
"""Accepted values of `Performance(vector_width=...)` [bits]."""

SCALARIZED_VECTOR_WIDTH = 512
"""With `Performance(vector_width=None)` (the default), the SIMD width [bits] XLA:CPU is asked
to prefer for a scalarized loop."""

NO_LIBRARY_FUSIONS = {"xla_cpu_experimental_ynn_fusion_type": ""}
"""The XLA:CPU compiler option that keeps small dot products in XLA's own generated code
instead of handing them to its YNNPACK library (`Performance(library_fusions=False)`)."""


class Performance(eqx.Module):
    r"""How the time loop is compiled.

    **Arguments:**
    - `scalarize`: run the time loop on the scalar entries of every small array (see
      `jaxatt.simulation._scalarize`), so that a `vmap`ped batch lowers to elementwise code on
      one `(batch,)` array per state component. `True`, `False`, or `None` (default): decided
      per backend and batch by [`resolve`][]: on XLA:CPU from [`SCALARIZE_FROM`][] = 1000
      samples run at once on one device, at about twice the compile time. On every
      reproduced family (benchmarks/README.md, `bench_scalarize_families.py`, 2026-12-05,
      2-core AVX-512 Xeon, float64): 1.02-3.9x faster at 1000 and 4000 samples (Chen M1 3.1x
      and 3.9x), except the cheapest loop, the rigid-body MRP PD law, at 1000 (0.71x; 2.37x
      at 4000); Wu 2018's safe approach gains 1.04-1.12x for 38 s of compile against 18 s,
      so `scalarize=False` suits it unless the run is long. Below 1000 samples Chen M1's
      step is 1.7-2.0x faster scalarized (32-512 samples), but the program compiles 2.1-2.4 s
      longer, which a run recovers only after 4-8 x 10^6 state-steps, and gradients do not
      gain ("Below the threshold"). Off for a single trajectory (13.7 against 8.3 µs a step,
      2026-12-03) and off on GPUs and TPUs, where it has not been measured.
    - `max_scalarized_size`: arrays with more entries than this stay whole (default 64).
    - `max_unrolled_products`: matrix products needing more scalar multiplications than this
      stay one packed product (default 64; a 3x3 matrix product needs 27). Keeps the compile
      time of plants with graph Laplacians or modal matrices linear in their size.
    - `library_fusions`: let XLA:CPU hand the loop's small dot products (the batched 3x3
      products of a plain, vmapped loop) to its YNNPACK library, XLA's own default. `False`
      (jaxatt's default) compiles them with the rest of the loop (the compiler option
      [`NO_LIBRARY_FUSIONS`][]): a library call per product costs more than the product at
      these sizes. Measured on Chen 2022 M1 (2-core AVX-512 Xeon, float64, 2026-12-06,
      benchmarks/README.md, "Small products without the library"): the tuning gradient of 32
      samples 1.21x faster (0.337 -> 0.278 s), of 256 samples 1.07x; a 32-sample Monte Carlo
      1.3x; no change from 512 samples on and for the scalarized loop (it has no products
      left); the same values to 1e-15. CPU only, and only where this jaxlib knows the option
      (checked once per process by compiling an empty program with it).
    - `vector_width`: the SIMD width in bits that XLA:CPU should prefer when it generates the
      loop's code (XLA's `xla_cpu_prefer_vector_width` compiler option, passed to the `jax.jit`
      of the program [`simulate`][jaxatt.simulate] or
      [`monte_carlo`][jaxatt.montecarlo.monte_carlo] compiles): 128, 256 or 512, or `None`
      (default): [`SCALARIZED_VECTOR_WIDTH`][] = 512 for a scalarized loop, no option (XLA's
      own choice, 256) otherwise. A scalarized batch is elementwise code on `(batch,)`
      arrays, which fills 512-bit registers: on this project's 2-core AVX-512 Xeon, Chen's M1
      Monte Carlo (default call, float64, 1 s, round robin in one process, 2026-12-04) ran
      1.13x, 1.07x and 1.09x faster at 1000, 3000 and 10 000 samples with 512 than without
      (benchmarks/README.md, "The 512-bit default restored"); the plain program, a single
      trajectory and a tuning gradient did not change (within 1 %, 2026-12-03). On a CPU
      without AVX-512 the option changes nothing (measured with XLA's
      `--xla_cpu_max_isa=AVX2`). The metrics agree to an ulp (bit for bit at 1000 samples;
      at 3000, 12 metric values differ, by at most 3.1e-16 relative). CPU only: ignored on
      other backends. Applies where jaxatt compiles the program; inside your own `jax.jit`,
      pass [`compiler_options`][jaxatt.simulation.Performance.compiler_options] to it. It
      was withdrawn as the default for a day after test processes crashed in XLA; the
      crashes turned out to be processes that had compiled about a thousand programs running
      out of memory mappings (Linux's `vm.max_map_count`), with or without the option
      (docs/performance.md, "Long processes and the memory-map limit").

    Forward- and reverse-mode derivatives of a scalarized loop go through the ordinary
    program (same values), so tuning can use the option a Monte Carlo study used.
    """

    scalarize: bool | None = eqx.field(default=None, static=True)
    max_scalarized_size: int = eqx.field(default=64, static=True)
    max_unrolled_products: int = eqx.field(default=64, static=True)
    vector_width: int | None = eqx.field(default=None, static=True)
    library_fusions: bool = eqx.field(default=False, static=True)

    def __check_init__(self):
        # `1 in (True, False)` holds: without the type check 1, 0 and 1.0 passed.
        if not (self.scalarize is None or isinstance(self.scalarize, (bool, np.bool_))):
            raise ValueError(
                f"Performance: `scalarize` must be True, False or None, got {self.scalarize!r}."
            )
        check_positive_int("Performance", "max_scalarized_size", self.max_scalarized_size)
        check_positive_int("Performance", "max_unrolled_products", self.max_unrolled_products)
        if not isinstance(self.library_fusions, (bool, np.bool_)):
            raise ValueError(
                "Performance: `library_fusions` must be True or False, "
                f"got {self.library_fusions!r}."
            )
        width = self.vector_width
        if width is not None and (
            isinstance(width, bool)
            or not isinstance(width, numbers.Integral)
            or width not in VECTOR_WIDTHS
        ):
            raise ValueError(
                "Performance: `vector_width` must be None or one of 128, 256, 512 (bits), "
                f"got {self.vector_width!r}."
            )

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
        return dataclasses.replace(self, scalarize=decided)

    def compiler_options(self, backend: str | None = None) -> dict[str, int | str]:
        """XLA compiler options for the program that runs a loop with these (resolved)
        options on `backend` (default: JAX's default backend), as `jax.jit(...,
        compiler_options=...)` takes them; empty when XLA's defaults apply."""
        backend = jax.default_backend() if backend is None else backend
        if backend != "cpu":
            return {}
        width = self.vector_width
        if width is None and self.scalarize:
            width = SCALARIZED_VECTOR_WIDTH
        options = {} if width is None else {"xla_cpu_prefer_vector_width": width}
        if not self.library_fusions and _xla_knows_no_library_fusions():
            options.update(NO_LIBRARY_FUSIONS)
        return options


@functools.cache
def _xla_knows_no_library_fusions() -> bool:
    """Whether this jaxlib's XLA compiles an empty program with [`NO_LIBRARY_FUSIONS`][] (an
    option that an older or newer XLA does not know is refused there)."""
    try:
        jax.jit(lambda x: x).lower(np.float32(0)).compile(NO_LIBRARY_FUSIONS)
    except Exception:  # XLA's error types differ between jaxlib versions
        return False
    return True


def samples_at_once(n: int, *, batch_size: int | None = None, devices: int = 1) -> int:
    """Samples one device runs together: its share of `n`, or the `lax.map` chunk if smaller."""
    per_device = math.ceil(n / max(1, devices))
    return per_device if batch_size is None else min(batch_size, per_device)
