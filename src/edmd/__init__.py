"""edmd: event-driven molecular dynamics of hard and soft spheres and disks."""

from .initial import lattice, maxwell_boltzmann, radii, random_packing
from .state import State, StateError

__all__ = ["State", "StateError", "lattice", "maxwell_boltzmann", "radii", "random_packing"]
__version__ = "0.1.0"
