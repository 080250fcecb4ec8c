"""Column layout of the hot particle rows and the codes shared by the compiled core.

Every particle is one C-order row of ``P`` (64 bytes, one cache line): position, velocity, the
particle's own time stamp (lazy update, physics.md §1.1) and its radius. Two-dimensional systems
use the same three components with ``z = v_z = 0`` exactly: a disk is a sphere confined to the
plane, so one compiled loop serves both dimensions (2D angular velocity is ``omega_z``).
"""

X, Y, Z, VX, VY, VZ, T, R = 0, 1, 2, 3, 4, 5, 6, 7
ROW = 8

# auxiliary (single-particle) event kinds; pair events are stored separately.
AUX_NONE = 0
AUX_SHELL = 1  # particle leaves the shell of its neighbour list
AUX_CELL = 2  # cell crossing: AUX_CELL + 2 * axis + (0 lower face, 1 upper face)
AUX_WALL = 8  # hard wall w: AUX_WALL + w
AUX_B = 64  # eMD* type-B event

# neighbour structure
NB_LIST = 0
NB_CELLS = 1

# loop status codes
ST_TIME = 0  # reached the stop time
ST_EVENTS = 1  # reached the event budget
ST_LIST_FULL = 2  # a neighbour list ran out of capacity
ST_LOG_FULL = 3  # the collision log buffer is full
ST_IDLE = 4  # no particle has a future event
ST_STALL = 5  # too many events at one instant (inelastic collapse / Zeno)
ST_OVERLAP = 6  # debug mode found an overlap or a contact away from sigma

# integer counters (cnt array)
C_EVENTS, C_COLL, C_STALE, C_AUX, C_REBUILD, C_WALL, C_LOG, C_ZENO_RUN, C_BAD_I, C_BAD_J = range(10)
N_COUNTERS = 16

# float accumulators (acc array)
A_VIRIAL, A_DISSIPATED, A_KE, A_KE_INT, A_LAST_T, A_WALL_IMPULSE, A_NOW, A_BAD = range(8)
N_ACC = 16

# integer parameters (ip array)
IP_MODE, IP_RULE, IP_LOG_CAP, IP_MAXSTALL, IP_DEBUG = range(5)
N_IP = 8

# float parameters (fp array)
FP_SKIN, FP_EN, FP_DEBUG_TOL = 0, 1, 2
N_FP = 16

# geometry scalars passed to the compiled core as one tuple of floats (no array references
# travel into hot helpers): box lengths, minimum-image half lengths (inf on open axes),
# gravity, and a gravity flag.
G_LX, G_LY, G_LZ, G_HX, G_HY, G_HZ, G_GX, G_GY, G_GZ, G_ON = range(10)


def make_geo(box, half, grav=None):
    """The ``geo`` tuple from 3-component box and half-length arrays and optional gravity."""
    g = [0.0, 0.0, 0.0] if grav is None else [float(x) for x in grav[:3]]
    return (*(float(x) for x in box), *(float(x) for x in half), *g, float(any(x != 0.0 for x in g)))
