r"""Safety sets for proximity operations and a collision-avoidance function (Wu et al. 2018).

The sets are surfaces of revolution about the target's docking axis $x$ (target body frame,
$P = (x, y, z)$, $r^2 = y^2 + z^2$), each given by an $r^2$-profile:

- [`KeepOutSphere`][]: $r^2 + x^2 - a_3^2$ (negative inside the sphere of radius $a_3$);
- [`ConeCorridor`][]: $F(x) = \tan^2\theta\,x|x|$, a cone of half angle $\theta$ about $+x$;
- [`CissoidCorridor`][]: $F(x) = \tan^2\theta\,x^3/(2a - x)$, the "ellipse cissoid";
- [`CubicBlend`][]: the C$^1$ cubic $p(x) = c_4 + c_1x + c_2x^2 + c_3x^3$ on $[a_1, a_2]$ joining
  the sphere to the corridor; coefficients recomputed in float64 from the continuity
  conditions (SPEC 001(c) finding 3), never from the printed four-digit values;
- [`CollisionAvoidance`][]: the product-form function $h(P)$, $h > 0$ on the safe set,
  with its gradient by autodiff.
"""

from ._sets import (
    CissoidCorridor as CissoidCorridor,
    CollisionAvoidance as CollisionAvoidance,
    ConeCorridor as ConeCorridor,
    CubicBlend as CubicBlend,
    KeepOutSphere as KeepOutSphere,
)
