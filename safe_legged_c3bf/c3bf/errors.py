"""Exception types raised by the C3BF core library."""


class InvalidInputError(ValueError):
    """An input is malformed: NaN/Inf values, wrong shape, non-positive radius, bad weights.

    Subclasses :class:`ValueError`, so ``except ValueError`` also catches it. The safety filter
    raises it *before* doing any work, so a caller can catch it and keep its previous command.
    Numerically hard but well-formed inputs never raise: they yield a RELAXED, EMERGENCY or
    FAILSAFE result instead.
    """
