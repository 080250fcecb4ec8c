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
AUX_WALL = 8  # hard wall: AUX_WALL + 2 * axis + (0 lower wall, 1 upper wall)
AUX_B = 64  # eMD* type-B event (the particle takes its post-collisional velocity)

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
(
    C_EVENTS,  # events processed
    C_COLL,  # binary collisions
    C_STALE,  # stale pair events re-predicted
    C_AUX,  # single-particle events
    C_REBUILD,  # neighbour-list rebuilds
    C_WALL,  # wall collisions
    C_LOG,  # rows in the collision log buffer
    C_ZENO_RUN,  # consecutive events without the clock advancing
    C_BAD_I,  # debug: offending pair
    C_BAD_J,
    C_TC_ELASTIC,  # collisions made elastic by the TC model
    C_EMD_A,  # eMD*: soft contacts handled by an A event (relocation) and two B events
    C_EMD_EXC_A,  # eMD* exception a): the relocation would overlap a third particle or a wall
    C_EMD_EXC_B,  # eMD* exception b): a particle with a pending B event reached a new contact (particle or wall)
    C_EMD_FALLBACK,  # eMD*: contacts resolved by the instantaneous rule (exception a, overlapping pairs)
) = range(15)
N_COUNTERS = 16

# float accumulators (acc array)
(
    A_VIRIAL,  # sum of r_ij . J over collisions
    A_DISSIPATED,  # kinetic (translational + rotational) energy lost in collisions
    A_KE,  # current translational kinetic energy (for the time integral)
    A_KE_INT,  # time integral of the translational kinetic energy (local time)
    A_LAST_T,  # local time up to which A_KE_INT is integrated
    A_PX,  # total momentum (changes only at walls)
    A_PY,
    A_PZ,
    A_NOW,  # time of the last processed event (local)
    A_BAD,  # debug: relative contact error
    A_EMD_VN,  # eMD*: impact speeds of the last A event (for the collision log)
    A_EMD_VT,
) = range(12)
A_WALL = 12  # A_WALL + 2 * axis + face: normal momentum given to each wall (face 0 lower, 1 upper)
N_ACC = 18

# integer parameters (ip array)
(
    IP_MODE,  # neighbour structure
    IP_LOG_CAP,  # collision log capacity (0: off)
    IP_MAXSTALL,  # events allowed without the clock advancing
    IP_DEBUG,
    IP_NORMAL,  # normal law of particle collisions (NORMAL_*)
    IP_TANGENT,  # tangential law of particle collisions (TANGENT_*)
    IP_TC,  # TC model on
    IP_WALL_NORMAL,  # laws for wall collisions
    IP_WALL_TANGENT,
    IP_WALLS,  # bit k set: axis k is closed by walls
    IP_EMD,  # eMD* (physics.md §4.8) for particle pairs
    IP_EMD_MODEL,  # soft contact model of eMD* and of the NORMAL_SOFT law (contact.MODEL_*)
    IP_EMD_TABLE,  # eMD*: interpolate the matrix of restitution (1) or always solve (0)
    IP_EMD_COMM,  # eMD*: post-collisional communication in exception b)
) = range(14)
N_IP = 16

# float parameters (fp array)
(
    FP_SKIN,  # neighbour-list skin
    FP_DEBUG_TOL,
    FP_EN,  # constant normal restitution
    FP_BETA,  # tangential restitution (beta = -e_t)
    FP_MU,  # Coulomb friction coefficient (TANGENT_COULOMB)
    FP_TC,  # TC model duration
    FP_VISCO_K,  # viscoelastic: rho = K sqrt(R_eff), K = 2Y / (3 (1 - nu^2))
    FP_VISCO_A,  # viscoelastic dissipative time constant A
    FP_ETAB_INV,  # 1 / grid step of the eps(s = sqrt(delta)) table
    FP_WALL_EN,
    FP_WALL_BETA,
    FP_WALL_MU,
    FP_MTOT,  # total mass
    FP_SOFT_A,  # soft contact law constants (a, b) of :mod:`.contact`
    FP_SOFT_B,
    FP_EMD_RTOL,  # eMD*: tolerance of the direct two-body solver
) = range(16)
N_FP = 16

NORMAL_CONST, NORMAL_VISCO = 0, 1
NORMAL_SOFT = 2  # central e_n(v_n) of the soft contact law (IP_EMD_MODEL, FP_SOFT_A/B)
TANGENT_SMOOTH, TANGENT_BETA, TANGENT_COULOMB = 0, 1, 2

# geometry scalars passed to the compiled core as one tuple of floats (no array references
# travel into hot helpers): box lengths, minimum-image half lengths (inf on open axes),
# gravity, and a gravity flag.
G_LX, G_LY, G_LZ, G_HX, G_HY, G_HZ, G_GX, G_GY, G_GZ, G_ON = range(10)


def make_geo(box, half, grav=None):
    """The ``geo`` tuple from 3-component box and half-length arrays and optional gravity."""
    g = [0.0, 0.0, 0.0] if grav is None else [float(x) for x in grav[:3]]
    return (*(float(x) for x in box), *(float(x) for x in half), *g, float(any(x != 0.0 for x in g)))
