"""`jaxatt.plot.style` is local: it restores rcParams, but not a backend switch made inside."""

import matplotlib

from jaxatt import plot


def test_style_restores_rcparams():
    before = matplotlib.rcParams["font.size"]
    with plot.style():
        assert matplotlib.rcParams["font.size"] == 9
    assert matplotlib.rcParams["font.size"] == before


def test_style_keeps_an_interactive_switch_made_inside():
    # Regression: Jupyter's inline backend turns `interactive` on when the first figure is
    # made; rc_context rolled it back, and every later figure of a notebook was not shown.
    was = matplotlib.is_interactive()
    try:
        matplotlib.interactive(False)
        with plot.style():
            matplotlib.interactive(True)  # what the inline backend does on its first figure
        assert matplotlib.is_interactive()
    finally:
        matplotlib.interactive(was)
