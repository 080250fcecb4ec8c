"""The compiled core: plain ``@njit`` functions over arrays (see ARCHITECTURE.md)."""
