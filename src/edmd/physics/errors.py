"""The error of an unphysical or inconsistent collision-rule or contact-law parameter."""


class RuleError(ValueError):
    """An unphysical or inconsistent collision-rule parameter (the message names it)."""
