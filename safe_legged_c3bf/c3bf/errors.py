"""Exception types raised by the C3BF core library."""


class InvalidInputError(ValueError):
    """An input is malformed or outside the numeric domain (see ``domain``).

    NaN/Inf values, magnitudes beyond ``domain.MAX_MAGNITUDE`` (1e9), wrong shape,
    non-positive radius, bad weights, or a reference too far beyond the input limits for an
    exact answer (``domain.REF_RATIO_MAX``).

    Subclasses :class:`ValueError`, so ``except ValueError`` also catches it. The message names
    the argument, the entry and the value. The safety filter raises it *before* producing a
    command, so a caller can catch it and keep (or brake from) its previous command.
    Numerically hard inputs within the domain never raise: they yield a RELAXED, EMERGENCY or
    FAILSAFE result instead.
    """
