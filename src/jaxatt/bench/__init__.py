"""A quick, self-checking throughput benchmark: what `jaxatt bench` runs.

[`quick_table`][] simulates Chen 2022's M1 closed loop over a batch of random initial
attitudes with jaxatt (`monte_carlo`), with a minimal hand-written `lax.scan` RK4 kernel of the
same equations (the floor of what XLA does with them) and with a NumPy vectorised RK4, checks
that all three agree, and reports state-steps per second and the ratios. The full suite
(SciPy and Basilisk baselines, float32, gradients, scaling, compile times, roofline) is in the
repository's `benchmarks/`, with its recorded results.

!!! example
    ```python
    import jax
    jax.config.update("jax_enable_x64", True)
    from jaxatt import bench
    print(bench.format_table(bench.quick_table(batches=(1, 100, 1000), horizon=1.0)))
    ```
"""

from ._quick import format_table as format_table, quick_table as quick_table
