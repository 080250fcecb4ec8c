"""Analysis of States, trajectories, thermo tables and collision logs (freud's style).

Every analysis is an object configured by its constructor; ``compute(...)`` returns the object
itself and leaves the results as attributes; ``plot(ax=None)`` draws them and returns the Axes.

Example:
    >>> import edmd
    >>> from edmd.analysis import RDF, VelocityDistribution
    >>> s = edmd.maxwell_boltzmann(edmd.lattice(500, 0.3), 1.0, seed=1)
    >>> g = RDF(bins=40, r_max=2.0).compute(s)
    >>> vd = VelocityDistribution().compute(s)
    >>> g.rdf.shape, abs(vd.a2) < 0.2
    ((40,), True)
"""

from ._common import compressibility_factor, contact_value, maxwell_speed_pdf
from .collisions import CollisionStatistics, ImpactPhases, impact_angle_pdf, impact_speed_pdf
from .dynamics import MSD, msd_window
from .packing import ContactNetwork, contact_pairs, rattlers
from .shear import ShearFlow, dilute_viscosity, usf_collision_frequency, usf_grad, usf_temperature
from .steady import Profile, SteadyState, blocking_errors
from .structure import RDF, pair_histogram
from .thermal import AlgebraicCooling, HaffLaw, Pressure, Temperature, VelocityDistribution, sonine_a2
from .transport import SelfDiffusion, ShearViscosity, ThermalConductivity, enskog_conductivity, enskog_diffusion, enskog_viscosity

__all__ = [
    "MSD",
    "AlgebraicCooling",
    "RDF",
    "CollisionStatistics",
    "ContactNetwork",
    "HaffLaw",
    "ImpactPhases",
    "Pressure",
    "Profile",
    "SelfDiffusion",
    "ShearFlow",
    "ShearViscosity",
    "SteadyState",
    "ThermalConductivity",
    "Temperature",
    "VelocityDistribution",
    "compressibility_factor",
    "blocking_errors",
    "contact_value",
    "contact_pairs",
    "enskog_conductivity",
    "enskog_diffusion",
    "enskog_viscosity",
    "dilute_viscosity",
    "usf_collision_frequency",
    "usf_grad",
    "usf_temperature",
    "rattlers",
    "impact_angle_pdf",
    "impact_speed_pdf",
    "maxwell_speed_pdf",
    "msd_window",
    "pair_histogram",
    "sonine_a2",
]
