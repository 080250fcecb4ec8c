"""edmd: event-driven molecular dynamics of hard and soft spheres and disks.

Subpackages by role: :mod:`edmd.physics` (rules, contact laws, eMD*, thermostats),
:mod:`edmd.run` (simulation, engine, observers), :mod:`edmd.files` (checkpoints, trajectories,
thermo tables), :mod:`edmd.app` (configuration, runner, CLI, plots, sweeps), :mod:`edmd.analysis`;
the compiled core is ``edmd._core``. The names users need are importable from ``edmd`` itself,
and so is the module of collision rules, ``edmd.collide``.
"""

from .files.checkpoint import Checkpoint, CheckpointError, read_checkpoint
from .app.config import Config, ConfigError, load_config, parse_config
from .physics import collide
from .physics.contact import ContactError, Hertz, LinearDashpot
from .physics.friction import Friction
from .run.dem import DEMSimulation
from .run.engine import CollapseError, EngineError, EngineOptions
from .initial import lattice, maxwell_boltzmann, radii, random_packing, replicate
from .run.observer import Callback, Observer, Totals
from .run.simulation import Simulation
from .state import State, StateError
from .app.sweeps import SweepError, SweepResult, SweepSpec, sweep, sweep_summary
from .files.thermo import Thermo, read_thermo
from .physics.thermostats import Andersen, WhiteNoise
from .physics.vibration import VibratingWall
from .physics.wells import SquareWell
from .physics.shear import Shear
from .physics.growth import Growth
from .run.compress import Compression, compress, compress_film, compression
from .files.trajectory import Trajectory, read_state, write_state
from .run.updaters import Updater, VelocityRescale

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
    "Friction",
    "Hertz",
    "LinearDashpot",
    "Observer",
    "Shear",
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
    "VibratingWall",
    "SquareWell",
    "Growth",
    "compress",
    "compress_film",
    "compression",
    "Compression",
    "WhiteNoise",
    "collide",
    "lattice",
    "load_config",
    "maxwell_boltzmann",
    "parse_config",
    "radii",
    "random_packing",
    "replicate",
    "read_checkpoint",
    "read_state",
    "read_thermo",
    "sweep",
    "sweep_summary",
    "write_state",
]
__version__ = "0.1.0"
