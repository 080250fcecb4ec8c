"""edmd: event-driven molecular dynamics of hard and soft spheres and disks."""

from .checkpoint import Checkpoint, CheckpointError, read_checkpoint
from .config import Config, ConfigError, load_config, parse_config
from .contact import ContactError, Hertz, LinearDashpot
from .dem import DEMSimulation
from .engine import CollapseError, EngineError, EngineOptions
from .initial import lattice, maxwell_boltzmann, radii, random_packing
from .observer import Callback, Observer, Totals
from .simulation import Simulation
from .state import State, StateError
from .sweeps import SweepError, SweepResult, SweepSpec, sweep, sweep_summary
from .thermo import Thermo, read_thermo
from .thermostats import Andersen, WhiteNoise
from .trajectory import Trajectory, read_state, write_state
from .updaters import Updater, VelocityRescale

__all__ = [
    "Andersen",
    "Callback",
    "Checkpoint",
    "CheckpointError",
    "CollapseError",
    "Config",
    "ConfigError",
    "ContactError",
    "DEMSimulation",
    "EngineError",
    "EngineOptions",
    "Hertz",
    "LinearDashpot",
    "Observer",
    "Simulation",
    "State",
    "StateError",
    "SweepError",
    "SweepResult",
    "SweepSpec",
    "Thermo",
    "Totals",
    "Trajectory",
    "Updater",
    "VelocityRescale",
    "WhiteNoise",
    "lattice",
    "load_config",
    "maxwell_boltzmann",
    "parse_config",
    "radii",
    "random_packing",
    "read_checkpoint",
    "read_state",
    "read_thermo",
    "sweep",
    "sweep_summary",
    "write_state",
]
__version__ = "0.1.0"
