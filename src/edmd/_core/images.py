r"""Periodic images: the minimum image, box shifts and Lees-Edwards sliding images (physics.md §5.7).

**Lees-Edwards boundaries** (uniform shear flow): flow along x, gradient along y, shear rate
:math:`\dot\gamma`. The periodic images above the box (:math:`y + L_y`) slide along x by the offset

.. math::
    \delta(t) = \delta_0 + \dot\gamma L_y t \pmod{L_x}

and move with the extra velocity :math:`\dot\gamma L_y\,\hat{\mathbf x}` (the images below by the
opposite). A particle crossing the y face is replaced by its image: :math:`y \mp L_y`,
:math:`x \mp \delta(t)`, :math:`v_x \mp \dot\gamma L_y`. Velocities are stored as lab velocities;
the peculiar velocity :math:`\mathbf c = \mathbf v - \dot\gamma y\,\hat{\mathbf x}` is the same for a
particle and all its images (the accumulators keep peculiar sums, :mod:`.stress`).

The sheared code reaches the event loop through hooks that are Numba overloads on the type of
``geo`` (a sheared geometry has :data:`.layout.N_GEO_SHEAR` entries): other runs compile none of it.
"""

import math

from numba import types
from numba.extending import overload

from .jit import leaf
from .layout import G_HX, G_HY, G_HZ, G_LX, G_LY, G_LZ, G_SHEAR_OFFSET, G_SHEAR_RATE, N_GEO_SHEAR, VX, X, Y

INF = math.inf


@leaf
def wrap_delta(d, length, half):
    """Minimum-image shift of one separation component (``half = inf`` on open axes)."""
    if d > half:
        return d - length
    if d < -half:
        return d + length
    return d


@leaf
def box_shift(x, length, half):
    """Periodic images a coordinate is beyond the box ``[-half, half)`` (``half = inf``: open axis), -1, 0 or 1."""
    if half < INF:
        if x >= half:
            return 1
        if x < -half:
            return -1
    return 0


@leaf
def wrap3(dx, dy, dz, geo):
    """Minimum image of a separation vector in a box without shear (see :func:`edmd._core.layout.make_geo`)."""
    return (
        wrap_delta(dx, geo[G_LX], geo[G_HX]),
        wrap_delta(dy, geo[G_LY], geo[G_HY]),
        wrap_delta(dz, geo[G_LZ], geo[G_HZ]),
    )


def sheared(geo):
    """Whether a geometry (:func:`.layout.make_geo`) has Lees-Edwards boundaries.

    Example:
        >>> sheared((1.0,) * 10), sheared((1.0,) * 12)
        (False, True)
    """
    return len(geo) == N_GEO_SHEAR


def sheared_type(geo):
    """Whether the Numba type of a geometry is that of a sheared run (typing time)."""
    return isinstance(geo, types.BaseTuple) and len(geo) == N_GEO_SHEAR


@leaf
def image_offset(t, geo):
    r"""The offset :math:`\delta(t)` of the image box above at local time ``t``, in :math:`[-L_x/2, L_x/2)`."""
    d = geo[G_SHEAR_OFFSET] + geo[G_SHEAR_RATE] * geo[G_LY] * t
    return d - geo[G_LX] * math.floor(d / geo[G_LX] + 0.5)


@leaf
def _sheared_image(dx, dy, dz, t, geo):
    uj = 0.0
    if dy > geo[G_HY]:  # j's image above
        dy -= geo[G_LY]
        dx -= image_offset(t, geo)
        uj = geo[G_SHEAR_RATE] * geo[G_LY]
    elif dy < -geo[G_HY]:  # j's image below
        dy += geo[G_LY]
        dx += image_offset(t, geo)
        uj = -geo[G_SHEAR_RATE] * geo[G_LY]
    return wrap_delta(dx, geo[G_LX], geo[G_HX]), dy, wrap_delta(dz, geo[G_LZ], geo[G_HZ]), uj


def shear_image(dx, dy, dz, t, geo):
    """Minimum image of the separation ``r_i - r_j`` at local time ``t`` and the x velocity ``u_j``
    that the image of ``j`` moves with besides ``v_j`` (0 in an unsheared box): the relative
    velocity is ``v_i - v_j - u_j`` (a subtraction, so that ``u_j = 0`` folds away).

    Example:
        >>> geo = (10.0, 10.0, 10.0, 5.0, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.1, 2.0)  # rate 0.1, offset 2
        >>> [round(v, 12) for v in shear_image(0.5, 9.0, 0.0, 0.0, geo)]   # j seen through the image above
        [-1.5, -1.0, 0.0, 1.0]
    """
    if sheared(geo):
        return _sheared_image(dx, dy, dz, t, geo)
    return (*wrap3(dx, dy, dz, geo), 0.0)


@overload(shear_image, inline="always")
def _shear_image_hook(dx, dy, dz, t, geo):
    if sheared_type(geo):
        return lambda dx, dy, dz, t, geo: _sheared_image(dx, dy, dz, t, geo)

    def plain(dx, dy, dz, t, geo):
        x, y, z = wrap3(dx, dy, dz, geo)
        return x, y, z, 0.0

    return plain


def flow_speed(y, geo):
    r"""The velocity of the linear profile at height ``y``, :math:`\dot\gamma y` (0 in an unsheared box)."""
    return geo[G_SHEAR_RATE] * y if sheared(geo) else 0.0


@overload(flow_speed, inline="always")
def _flow_speed_hook(y, geo):
    if sheared_type(geo):
        return lambda y, geo: geo[G_SHEAR_RATE] * y
    return lambda y, geo: 0.0


@leaf
def face_image(x, y, vx, shift, t, geo):
    r"""Position ``(x, y)`` and x velocity of the image ``shift`` of a point at local time ``t`` across
    the sliding y face (+1: the image below, -1: above): :math:`y - sL_y`, :math:`x - s\delta(t)`,
    :math:`v_x - s\dot\gamma L_y` (x not wrapped)."""
    return x - shift * image_offset(t, geo), y - shift * geo[G_LY], vx - shift * geo[G_SHEAR_RATE] * geo[G_LY]


@leaf
def cross_y_face(P, image, i, shift, t, geo):
    """Replace particle ``i`` (streamed to local time ``t``) by its image ``shift`` across the sliding y
    face (:func:`face_image`), its x wrapped into the box."""
    P[i, X], P[i, Y], P[i, VX] = face_image(P[i, X], P[i, Y], P[i, VX], shift, t, geo)
    image[i, 1] += shift
    m = box_shift(P[i, X], geo[G_LX], geo[G_HX])  # (x and the reduced offset are both within half a box)
    P[i, X] -= m * geo[G_LX]
    image[i, 0] += m


@leaf
def _fold_face(x, y, vx, t, geo):
    across = 0
    while y >= geo[G_HY] or y < -geo[G_HY]:
        s = 1 if y > 0.0 else -1
        x, y, vx = face_image(x, y, vx, s, t, geo)
        across += s
    return x, y, vx, across


def fold_face(x, y, vx, t, geo):
    """The image of a point at local time ``t`` whose y is in the box, through the sliding y face
    of a sheared box (:func:`face_image`; x not wrapped), and the images moved by (the point
    itself and 0 in an unsheared box).

    Example:
        >>> geo = (10.0, 10.0, 10.0, 5.0, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.1, 2.0)
        >>> fold_face(0.0, 6.0, 1.0, 0.0, geo)
        (-2.0, -4.0, 0.0, 1)
    """
    return _fold_face(x, y, vx, t, geo) if sheared(geo) else (x, y, vx, 0)


@overload(fold_face, inline="always")
def _fold_face_hook(x, y, vx, t, geo):
    if sheared_type(geo):
        return lambda x, y, vx, t, geo: _fold_face(x, y, vx, t, geo)
    return lambda x, y, vx, t, geo: (x, y, vx, 0)


@leaf
def _distance2(dx, dy, dz, geo):
    x, y, z = wrap3(dx, dy, dz, geo)
    return x * x + y * y + z * z


@leaf
def _sheared_listing_distance2(dx, dy, dz, geo):
    if dy > geo[G_HY] or dy < -geo[G_HY]:  # across the sliding face: never listed
        return INF
    return _distance2(dx, dy, dz, geo)


def listing_distance2(dx, dy, dz, geo):
    r"""The squared distance that decides whether two neighbour-list centres ``d = c_i - c_j``
    (both in the box) are listed: the minimum-image distance, but infinite across a sliding
    Lees-Edwards face, whose pairs are never listed: their images slide past, so predictions find
    them through the centre grid instead (:func:`.schedule.sliding_partners`, physics.md §5.7).

    Example:
        >>> geo = (10.0, 10.0, 10.0, 5.0, 5.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.1, 2.0)
        >>> listing_distance2(4.0, 9.5, 0.0, geo), listing_distance2(4.0, 0.5, 0.0, geo)
        (inf, 16.25)
    """
    return _sheared_listing_distance2(dx, dy, dz, geo) if sheared(geo) else _distance2(dx, dy, dz, geo)


@overload(listing_distance2, inline="always")
def _listing_distance2_hook(dx, dy, dz, geo):
    if sheared_type(geo):
        return lambda dx, dy, dz, geo: _sheared_listing_distance2(dx, dy, dz, geo)
    return lambda dx, dy, dz, geo: _distance2(dx, dy, dz, geo)


@leaf
def _fold_into_box(P, image, i, t, geo):
    shift = box_shift(P[i, Y], geo[G_LY], geo[G_HY])
    if shift != 0:
        cross_y_face(P, image, i, shift, t, geo)


def fold_into_box(P, image, i, t, geo):
    """Bring particle ``i`` (streamed to local time ``t``) back through a sliding y face, as its
    image (:func:`cross_y_face`), if it has left the box that way: exact at any time after the
    crossing, since the image's x and x velocity follow the offset (nothing in an unsheared box)."""
    if sheared(geo):
        _fold_into_box(P, image, i, t, geo)


@overload(fold_into_box, inline="always")
def _fold_into_box_hook(P, image, i, t, geo):
    if sheared_type(geo):
        return lambda P, image, i, t, geo: _fold_into_box(P, image, i, t, geo)
    return lambda P, image, i, t, geo: None
