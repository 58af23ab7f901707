"""Earth constants (SI)."""

MU_EARTH = 3.986004418e14
"""Earth's gravitational parameter [m^3/s^2] (WGS-84 / EGM-96)."""

R_EARTH = 6378137.0
"""Earth's equatorial radius [m] (WGS-84)."""

J2_EARTH = 1.08262668e-3
"""Earth's second zonal harmonic (EGM-96, unnormalised)."""
