"""The natural logarithm of the exported FMU, evaluated with NumPy bit for bit as the C code does.

The FMU's C source carries its own ``log`` (musl's, from FreeBSD's msun ``e_log.c``: argument
reduction by bit manipulation, a degree-14 odd polynomial, accurate to < 1 ulp) so that its
binary needs no libm. Only +, -, * and / in a fixed order are used, which NumPy repeats exactly
(NumPy never fuses a multiply and an add), so the ROM component and the FMU agree to the bit.
"""

from __future__ import annotations

import numpy as np

LN2_HI = 6.93147180369123816490e-01
LN2_LO = 1.90821492927058770002e-10
LG1, LG2, LG3, LG4 = 6.666666666666735130e-01, 3.999999999940941908e-01, 2.857142874366239149e-01, \
    2.222219843214978396e-01
LG5, LG6, LG7 = 1.818357216161805012e-01, 1.531383769920937332e-01, 1.479819860511658591e-01
_SUBNORMAL_HIGH_WORD = 0x00100000
_SQRT_HALF_HIGH_WORD = 0x3FE6A09E


_BOUNDARY = np.array([_SQRT_HALF_HIGH_WORD << 32], dtype=np.uint64).view(np.float64)[0]  # ~0.7071066


def portable_log(x: np.ndarray) -> np.ndarray:
    """log(x) for positive finite ``x`` (normal or subnormal), as ``rom_log`` in ``native/solid_rom.c``.

    The C code reduces x to f + 1 in [0.7071066, 1.4142132) by bit manipulation; ``np.frexp``
    and one doubling give the same f exactly (scaling by powers of two is exact).
    """
    m, e = np.frexp(np.asarray(x, dtype=np.float64))     # x = m 2^e, m in [0.5, 1), subnormals included
    low = m < _BOUNDARY
    m += m * low                                            # doubles m below the boundary: exact
    e -= low
    f = m - 1.0
    hfsq = 0.5 * f
    hfsq *= f
    s = 2.0 + f
    np.divide(f, s, out=s)
    z = s * s
    w = z * z
    t1 = w * LG6
    t1 += LG4
    t1 *= w
    t1 += LG2
    t1 *= w
    t2 = w * LG7
    t2 += LG5
    t2 *= w
    t2 += LG3
    t2 *= w
    t2 += LG1
    t2 *= z
    t2 += t1                                                # R
    t2 += hfsq
    s *= t2                                                 # s (hfsq + R)
    dk = e.astype(np.float64)
    s += dk * LN2_LO
    s -= hfsq
    s += f
    s += dk * LN2_HI
    return s


def thin_plate_terms(d2: np.ndarray) -> np.ndarray:
    """d2 log d2 (0 at d2 = 0) with ``portable_log``: the kernel values of the online path."""
    positive = d2 > 0.0
    return np.where(positive, d2 * portable_log(np.where(positive, d2, 1.0)), 0.0)
