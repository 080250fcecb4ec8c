"""Column layout of the hot particle rows and the codes shared by the compiled core.

Every particle is one C-order row of ``P`` (64 bytes, one cache line): position, velocity, the
particle's own time stamp (lazy update, physics.md §1.1) and its radius. Two-dimensional systems
use the same three components with ``z = v_z = 0`` exactly: a disk is a sphere confined to the
plane, so one compiled loop serves both dimensions (2D angular velocity is ``omega_z``).
"""

X, Y, Z, VX, VY, VZ, T, R = 0, 1, 2, 3, 4, 5, 6, 7
ROW = 8
#: runs with a vibrating wall have one more column: 1.0 while the particle rides on the wall
#: (the sticking solution, wallmotion.py), else 0.0
RIDE = 8

# auxiliary (single-particle) event kinds; pair events are stored separately.
AUX_NONE = 0
AUX_SHELL = 1  # particle leaves the shell of its neighbour list
AUX_CELL = 2  # cell crossing: AUX_CELL + 2 * axis + (0 lower face, 1 upper face)
AUX_WALL = 8  # hard wall: AUX_WALL + 2 * axis + (0 lower wall, 1 upper wall)
AUX_WALL_END = AUX_WALL + 6
AUX_B = 64  # eMD* type-B event (the particle takes its post-collisional velocity)
AUX_BATH = 65  # Andersen heat bath: the particle's velocity is drawn anew (see bath.py)
AUX_RIDE = 66  # a particle riding on the vibrating wall takes off (wallmotion.py)
# Dispatch is explicit: every kind the loop knows is tested for, and any other code stops the
# run with ST_BAD_EVENT (a new kind must be given its own branch, it can never fall into another's).

# kinds of pair events (Pairs.kind; only runs with a square well have kinds other than core)
PAIR_CORE = 0  # the hard cores touch: the collision rule
PAIR_CAPTURE = 1  # an outside pair reaches the well's edge (wells.py)
PAIR_EDGE = 2  # a captured pair reaches the edge from inside: released, or bounced back

# outcomes of a pair reaching contact under eMD* (emdstar.emd_contact)
CONTACT_LIST_FULL = -1  # a neighbour list ran out of capacity while re-binning the pair
CONTACT_DISCARDED = 0  # exception b) left the pair separating: nothing happens
CONTACT_SOFT = 1  # an A event: the pair was relocated, its B events are pending
CONTACT_INSTANT = 2  # the instantaneous rule (exception a, overlaps, a failed solve)
CONTACT_WELL = 3  # a square-well event (capture, release, bounce): no collision
CONTACT_GROWN = 4  # a collision of growing particles (growth.py)

# global timers: calendar entry N + TIMER_* (see forcing.py)
TIMER_KICK = 0  # white-noise forcing
N_TIMERS = 1

# neighbour structure
NB_LIST = 0
NB_CELLS = 1

#: a wall collision less than this fraction of the clock after the previous event does not count as
#: the clock advancing (2^-46: ~64 ulps; a particle resting on a wall bounces every ~10 ulps)
STALL_RESOLUTION = 2.0**-46

# loop status codes
ST_TIME = 0  # reached the stop time
ST_EVENTS = 1  # reached the event budget
ST_LIST_FULL = 2  # a neighbour list ran out of capacity
ST_LOG_FULL = 3  # the collision log buffer is full
ST_IDLE = 4  # no particle has a future event
ST_STALL = 5  # too many events at one instant (inelastic collapse / Zeno)
ST_OVERLAP = 6  # debug mode found an overlap or a contact away from sigma
ST_BAD_EVENT = 7  # an event of unknown kind (cnt[C_BAD_I] the particle, cnt[C_BAD_J] the kind)
ST_GROWN = 8  # (the engine's, not the loop's) growing radii have stopped growing

# Counters, accumulators and parameters are arrays indexed by the constants below. Each array
# has a tuple of names in index order: checkpoints store the names with the values, so a
# checkpoint migrates by name when entries are added (a missing entry loads as 0, its "off" or
# "none" value). Add new entries at the end of a tuple and its unpacking.

#: integer counters (``cnt`` array)
COUNTERS = (
    "events",  # events processed
    "collisions",  # binary collisions
    "stale",  # stale pair events re-predicted
    "aux",  # single-particle events
    "rebuilds",  # neighbour-list rebuilds
    "wall_collisions",
    "log_rows",  # rows in the collision log buffer
    "zeno_run",  # consecutive events without the clock advancing
    "bad_i",  # debug: offending pair
    "bad_j",
    "tc_elastic",  # collisions made elastic by the TC model
    "emd_contacts",  # eMD*: soft contacts handled by an A event (relocation) and two B events
    "emd_exceptions_a",  # eMD* exception a): the relocation would overlap a third particle or a wall
    "emd_exceptions_b",  # eMD* exception b): a particle with a pending B event reached a new contact (particle or wall)
    "emd_fallbacks",  # eMD*: contacts resolved by the instantaneous rule (exception a, overlapping pairs)
    "bath_events",  # Andersen heat bath: velocities drawn anew
    "kicks",  # white-noise forcing: kicks of the whole system
    "kick_next",  # index of the next kick (carried across reloads: a reload at a kick's time must not repeat it)
    "well_captures",  # square well: pairs entering the well
    "well_releases",  # captured pairs leaving it
    "well_bounces",  # captured pairs reflected at the edge (too slow to escape)
    "grow_next",  # growing radii: index k of the next segment end t0 + k segment (carried across reloads)
    "grow_events",  # growing radii: events at the start of the current segment (it ends early after Growth.events per particle)
    "grow_done",  # growing radii: 1 once they have stopped growing (Growth.end or Growth.pressure reached)
)
(
    C_EVENTS, C_COLL, C_STALE, C_AUX, C_REBUILD, C_WALL, C_LOG, C_ZENO_RUN, C_BAD_I, C_BAD_J,
    C_TC_ELASTIC, C_EMD_A, C_EMD_EXC_A, C_EMD_EXC_B, C_EMD_FALLBACK, C_BATH, C_KICKS, C_KICK_NEXT,
    C_WELL_IN, C_WELL_OUT, C_WELL_BOUNCE, C_GROW_NEXT, C_GROW_EVENTS, C_GROW_DONE,
) = range(len(COUNTERS))  # fmt: skip
N_COUNTERS = len(COUNTERS)

#: the symmetric tensor components of the stress accumulators, in their order
TENSOR = ("xx", "yy", "zz", "xy", "xz", "yz")
#: the axes ``(a, b)`` of each component of :data:`TENSOR`
TENSOR_AXES = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))

#: float accumulators (``acc`` array)
ACCUMULATORS = (
    "virial",  # sum of r_ij . J over collisions
    "dissipated",  # kinetic (translational + rotational) energy lost in collisions
    "kinetic",  # current translational kinetic energy (for the time integral)
    "kinetic_integral",  # time integral of the translational kinetic energy (local time)
    "kinetic_integral_time",  # local time up to which the integral runs
    "px",  # total momentum (changes only at walls)
    "py",
    "pz",
    "now",  # time of the last processed event (local)
    "bad_error",  # debug: relative contact error
    "emd_vn",  # eMD*: impact speeds of the last A event (for the collision log)
    "emd_vt",
    *(f"wall_{axis}_{face}" for axis in "xyz" for face in ("lower", "upper")),  # normal momentum given to each wall
    "energy_input",  # mechanical energy put in by updaters (thermostats, forcing) since the start
    "segment_virial",  # growing radii: the virial and the kinetic-energy integral at the start of the current segment
    "segment_kinetic_integral",
    "ride_mass",  # total mass of the particles riding on the vibrating wall (set at each load)
    # the stress tensor (stress.py), symmetric components in the order of TENSOR:
    *(f"kinetic_{c}" for c in TENSOR),  # running sum_i m_i v_ia v_ib (committed velocities; set at each load)
    *(f"kinetic_integral_{c}" for c in TENSOR),  # its time integral (local time, up to A_LAST_T)
    *(f"virial_{c}" for c in TENSOR),  # sum over collisions of (r_ij (x) J + J (x) r_ij) / 2
    # the energy current (stress.py):
    *(f"energy_current_{a}" for a in "xyz"),  # running sum_i e_i v_i (translational + rotational e_i)
    *(f"energy_current_integral_{a}" for a in "xyz"),  # its time integral
    *(f"energy_virial_{a}" for a in "xyz"),  # sum over collisions of r_ij (Delta E_i - Delta E_j) / 2
    "shear_work",  # Lees-Edwards: work of the sliding boundaries on the peculiar motion (shear.py)
)
(
    A_VIRIAL, A_DISSIPATED, A_KE, A_KE_INT, A_LAST_T, A_PX, A_PY, A_PZ, A_NOW, A_BAD, A_EMD_VN, A_EMD_VT,
) = range(12)  # fmt: skip
A_WALL = 12  # A_WALL + 2 * axis + face: normal momentum given to each wall (face 0 lower, 1 upper)
A_ENERGY_INPUT = ACCUMULATORS.index("energy_input")
A_SEG_VIRIAL, A_SEG_KE_INT = ACCUMULATORS.index("segment_virial"), ACCUMULATORS.index("segment_kinetic_integral")
A_RIDE_MASS = ACCUMULATORS.index("ride_mass")
A_KT, A_KT_INT, A_VT = (ACCUMULATORS.index(f"{name}_xx") for name in ("kinetic", "kinetic_integral", "virial"))
A_JE, A_JE_INT, A_QV = (ACCUMULATORS.index(f"{name}_x") for name in ("energy_current", "energy_current_integral", "energy_virial"))
A_SHEAR_WORK = ACCUMULATORS.index("shear_work")
N_ACC = len(ACCUMULATORS)

#: integer parameters (``ip`` array)
IPARAMS = (
    "neighbours",  # neighbour structure (NB_*)
    "log_capacity",  # collision log capacity (0: off)
    "max_stall",  # events allowed without the clock advancing
    "debug",
    "normal_law",  # normal law of particle collisions (NORMAL_*)
    "tangent_law",  # tangential law of particle collisions (TANGENT_*)
    "tc",  # TC model on
    "wall_normal_law",  # laws for wall collisions
    "wall_tangent_law",
    "walls",  # bit k set: axis k is closed by walls
    "emdstar",  # eMD* (physics.md §4.8) for particle pairs
    "soft_model",  # soft contact model of eMD* and of the NORMAL_SOFT law (contact.MODEL_*)
    "emd_tables",  # eMD*: interpolate the matrix of restitution (1) or always solve (0)
    "emd_communication",  # eMD*: post-collisional communication in exception b)
    "bath",  # Andersen heat bath on
    "bath_seed",  # its random seed
    "kick",  # white-noise forcing on
    "kick_seed",  # its random seed
    "log_walls",  # the collision log also records wall impacts
    "well",  # square-well attraction on (wells.py)
    "emd_friction",  # eMD*: the tangential law of frictional contacts (physics.friction.LAWS; 0: smooth)
)
(
    IP_MODE, IP_LOG_CAP, IP_MAXSTALL, IP_DEBUG, IP_NORMAL, IP_TANGENT, IP_TC, IP_WALL_NORMAL,
    IP_WALL_TANGENT, IP_WALLS, IP_EMD, IP_EMD_MODEL, IP_EMD_TABLE, IP_EMD_COMM, IP_BATH, IP_BATH_SEED,
    IP_KICK, IP_KICK_SEED, IP_LOG_WALLS, IP_WELL, IP_EMD_FRICTION,
) = range(len(IPARAMS))  # fmt: skip
N_IP = len(IPARAMS)
#: parameters of what the engine records, not of the physics (observers set them again on a restart)
OUTPUT_PARAMS = ("log_capacity", "log_walls")

#: float parameters (``fp`` array)
FPARAMS = (
    "skin",  # neighbour-list skin
    "debug_tolerance",
    "e_n",  # constant normal restitution
    "beta",  # tangential restitution (beta = -e_t)
    "mu",  # Coulomb friction coefficient (TANGENT_COULOMB)
    "tc_duration",  # TC model duration
    "visco_k",  # retired (the NORMAL_VISCO law's K = 2Y / (3 (1 - nu^2)), now soft_a): read from old checkpoints only
    "visco_a",  # retired (NORMAL_VISCO's A, now soft_b = 3A/2): read from old checkpoints only
    "visco_table_inv_step",  # 1 / grid step of the eps(s = sqrt(delta)) table
    "wall_e_n",
    "wall_beta",
    "wall_mu",
    "total_mass",
    "soft_a",  # soft contact law constants (a, b) of :mod:`.contact`
    "soft_b",
    "emd_rtol",  # eMD*: tolerance of the direct two-body solver
    "bath_kT",  # Andersen heat bath: temperature
    "bath_rate",  # and the rate of each particle's bath events
    "kick_xi0",  # white-noise forcing: strength (variance xi0^2 per unit time and component)
    "kick_interval",  # time between kicks
    "kick_start",  # absolute time of kick 0
    "well_width",  # square well: its edge is at (1 + well_width) sigma_ij (0: no well)
    "well_depth",  # and its depth epsilon (energy)
    "grow_rate",  # growing radii (growth.py): R(t) = R(t0) (1 + grow_rate (t - t0)) (0: no growth)
    "grow_start",  # t0, absolute
    "grow_segment",  # the engine reloads (and rescales velocities) at t0 + k grow_segment
    "grow_local",  # the rate relative to the radii of the last load, per unit local time (set at each load)
    "list_margin",  # neighbour lists reach (1 + list_margin) x their interaction range (set at each load)
    "friction_stiffness",  # eMD* frictional contacts: k_t (linear) or k_t0 (Mindlin)
    "friction_damping",  # x_t, the tangential damping as a multiple of the normal one
    "friction_mu",  # Coulomb friction coefficient of the contact law
)
(
    FP_SKIN, FP_DEBUG_TOL, FP_EN, FP_BETA, FP_MU, FP_TC, FP_VISCO_K, FP_VISCO_A, FP_ETAB_INV,
    FP_WALL_EN, FP_WALL_BETA, FP_WALL_MU, FP_MTOT, FP_SOFT_A, FP_SOFT_B, FP_EMD_RTOL, FP_BATH_KT,
    FP_BATH_RATE, FP_KICK_XI0, FP_KICK_INTERVAL, FP_KICK_START, FP_WELL_WIDTH, FP_WELL_DEPTH,
    FP_GROW_RATE, FP_GROW_START, FP_GROW_SEGMENT, FP_GROW_LOCAL, FP_LIST_MARGIN, FP_FRICTION_KT,
    FP_FRICTION_XT, FP_FRICTION_MU,
) = range(len(FPARAMS))  # fmt: skip
N_FP = len(FPARAMS)

#: the names of each array as stored in checkpoints
LAYOUT = {"counters": COUNTERS, "accumulators": ACCUMULATORS, "fp": FPARAMS, "ip": IPARAMS}
#: checkpoint format 1 stored the arrays without names (16, 18, 16, 16 slots): these were theirs
FORMAT1_LAYOUT = {"counters": COUNTERS[:15], "accumulators": ACCUMULATORS[:18], "fp": FPARAMS[:16], "ip": IPARAMS[:14]}

NORMAL_CONST = 0
NORMAL_VISCO = 1  # retired: the viscoelastic material is the Hertz law of NORMAL_SOFT (old checkpoints are migrated)
NORMAL_SOFT = 2  # central e_n(v_n) of the run's contact law (IP_EMD_MODEL, FP_SOFT_A/B)
TANGENT_SMOOTH, TANGENT_BETA, TANGENT_COULOMB = 0, 1, 2
#: the tangential law of smooth collisions: ``(code, beta, mu)``
SMOOTH = (TANGENT_SMOOTH, -1.0, 0.0)


def pack_laws(laws, fp, ip, wall=False):
    """Write a rule's ``((normal_code, e_n), (tangent_code, beta, mu))`` into the particle (or wall) slots."""
    (ncode, e_n), (tcode, beta, mu) = laws
    if wall:
        ip[IP_WALL_NORMAL], ip[IP_WALL_TANGENT] = ncode, tcode
        fp[FP_WALL_EN], fp[FP_WALL_BETA], fp[FP_WALL_MU] = e_n, beta, mu
    else:
        ip[IP_NORMAL], ip[IP_TANGENT] = ncode, tcode
        fp[FP_EN], fp[FP_BETA], fp[FP_MU] = e_n, beta, mu

# geometry scalars passed to the compiled core as one tuple of floats (no array references
# travel into hot helpers): box lengths, minimum-image half lengths (inf on open axes),
# gravity, a gravity flag and, only with a vibrating wall (walls.py), its axis, face (0 lower,
# 1 upper), waveform (WAVE_*), amplitude, angular frequency, phase at local time 0 and the
# rebound speed below which a particle pressed by it sticks (0: never; wallmotion.py). (A tuple
# of 16 floats in every run made cell-mode gases 1.8x slower, measured: the geometry of a run
# without a vibrating wall keeps its 10 entries, and walls.wall_params reads the wall's by type.)
G_LX, G_LY, G_LZ, G_HX, G_HY, G_HZ, G_GX, G_GY, G_GZ, G_ON = range(10)
G_WALL_AXIS, G_WALL_FACE, G_WALL_WAVE, G_WALL_A, G_WALL_OMEGA, G_WALL_PHASE, G_WALL_STICK = range(10, 17)
# Lees-Edwards boundaries (shear.py; never with a vibrating wall): the shear rate and the x offset of
# the image box above at local time 0. A sheared geometry has 12 entries, one with a vibrating wall 16 or 17.
G_SHEAR_RATE, G_SHEAR_OFFSET = 10, 11
N_GEO_SHEAR = 12

# waveforms of a vibrating wall (walls.py)
WAVE_SINE, WAVE_TRIANGLE, WAVE_SAWTOOTH = 0, 1, 2
#: no vibrating wall: what ``walls.wall_params`` gives for a 10-entry geometry
NO_MOVING_WALL = (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def make_geo(box, half, grav=None, wall=None, shear=None):
    """The ``geo`` tuple from 3-component box and half-length arrays, optional gravity, the
    vibrating wall's ``(axis, face, wave, amplitude, omega, phase at local time 0, stick speed)``
    or the Lees-Edwards ``(shear rate, image offset at local time 0)``."""
    g = [0.0, 0.0, 0.0] if grav is None else [float(x) for x in grav[:3]]
    on = float(any(x != 0.0 for x in g))
    geo = (*(float(x) for x in box), *(float(x) for x in half), *g, on)
    extra = wall if wall is not None else shear
    return geo if extra is None else (*geo, *(float(x) for x in extra))
