#!/usr/bin/env python3
"""Writes scenes/room.json and its OBJ meshes under scenes/meshes/room/.

A living room of 6 m (x) by 4.5 m (z), 2.7 m high (y), in millimetres, closed, with a glossy
wooden floor, a framed mirror on the wall x = 0, a window-like emitter in the wall z = 4500,
three ceiling panels and two glowing lamp shades, and furniture made of boxes and prisms. The
walls' names: west x = 0, east x = 6000, south z = 0, north z = 4500. No two solids overlap,
so that no coincident faces are left to a renderer's tie-breaking: main() checks the boxes and
the prisms' bounding boxes.

Every face is written counter-clockwise seen from its front (the side light comes from): the
room's shell faces inwards, furniture faces outwards. Faces that would lie against the floor or
a wall are left out (nothing sees them). The output is deterministic: the same bytes each run.

    python3 scripts/make_room.py [ROOT]     # ROOT: the repository (default: this script's ..)
"""
import json
import math
import os
import sys

ROOT = os.path.normpath(sys.argv[1] if len(sys.argv) > 1
                        else os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SCENE = os.path.join(ROOT, "scenes", "room.json")
MESH_DIR = os.path.join(ROOT, "scenes", "meshes", "room")

W, H, D = 6000.0, 2700.0, 4500.0  # room: x in [0, W], y in [0, H], z in [0, D]


# ---- geometry helpers --------------------------------------------------------------------

def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def oriented(poly, normal):
    """The polygon's corners in the order whose right-hand normal points along `normal`."""
    n = cross(sub(poly[1], poly[0]), sub(poly[2], poly[0]))
    if dot(n, normal) < 0:
        poly = list(reversed(poly))
    return [tuple(float(c) for c in p) for p in poly]


AXES = {"-x": (-1, 0, 0), "+x": (1, 0, 0), "-y": (0, -1, 0), "+y": (0, 1, 0),
        "-z": (0, 0, -1), "+z": (0, 0, 1)}


SOLIDS = []  # (x0, x1, y0, y1, z0, z1) of every box and prism made, for the overlap check


def box(x0, x1, y0, y1, z0, z1, omit=(), trim=None):
    """The faces of an axis-aligned box, normals outwards; `omit` names faces left out; `trim`
    maps a face to (axis, lo, hi): that face keeps only its part with lo <= axis <= hi."""
    SOLIDS.append((x0, x1, y0, y1, z0, z1))
    faces = {
        "-x": [(x0, y0, z0), (x0, y1, z0), (x0, y1, z1), (x0, y0, z1)],
        "+x": [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)],
        "-y": [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)],
        "+y": [(x0, y1, z0), (x1, y1, z0), (x1, y1, z1), (x0, y1, z1)],
        "-z": [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)],
        "+z": [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)],
    }
    for side, (axis, lo, hi) in (trim or {}).items():
        k = "xyz".index(axis)
        faces[side] = [tuple(min(max(c, lo), hi) if i == k else c for i, c in enumerate(p))
                       for p in faces[side]]
    return [oriented(faces[k], AXES[k]) for k in ("-x", "+x", "-y", "+y", "-z", "+z")
            if k not in omit]


def frustum(cx, cz, y0, y1, r0, r1, sides, phase=0.0, omit=()):
    """A vertical prism / frustum with `sides` sides: radius r0 at y0, r1 at y1; normals
    outwards. `omit` may hold "bottom" and "top"."""
    r = max(r0, r1)
    SOLIDS.append((cx - r, cx + r, y0, y1, cz - r, cz + r))
    ang = [phase + 2 * math.pi * k / sides for k in range(sides)]
    lo = [(cx + r0 * math.cos(a), y0, cz + r0 * math.sin(a)) for a in ang]
    hi = [(cx + r1 * math.cos(a), y1, cz + r1 * math.sin(a)) for a in ang]
    faces = []
    for k in range(sides):
        k1 = (k + 1) % sides
        quad = [lo[k], lo[k1], hi[k1], hi[k]]
        mid = 0.5 * (ang[k] + ang[k] + 2 * math.pi / sides)
        faces.append(oriented(quad, (math.cos(mid), 0, math.sin(mid))))
    if "bottom" not in omit:
        faces.append(oriented(lo, (0, -1, 0)))
    if "top" not in omit:
        faces.append(oriented(hi, (0, 1, 0)))
    return faces


def rect(axis, at, a0, a1, b0, b1, facing):
    """A rectangle in the plane axis = at, spanning the other two axes (in x, y, z order) over
    [a0, a1] x [b0, b1], facing the direction `facing` ("+x", "-z", ...)."""
    if axis == "x":
        p = [(at, a0, b0), (at, a1, b0), (at, a1, b1), (at, a0, b1)]
    elif axis == "y":
        p = [(a0, at, b0), (a1, at, b0), (a1, at, b1), (a0, at, b1)]
    else:
        p = [(a0, b0, at), (a1, b0, at), (a1, b1, at), (a0, b1, at)]
    return oriented(p, AXES[facing])


def frame_on_wall(wall, lo_a, hi_a, lo_y, hi_y, width, depth, proud=0.0, on_sill=False):
    """Four boxes framing the rectangle [lo_a, hi_a] x [lo_y, hi_y] on a wall; `wall` is one of
    "x0", "x1", "z0", "z1". The faces against the wall are left out. With a panel `proud` of
    the wall inside the frame, the faces toward the opening begin at the panel: the gap behind
    it is sealed, so that no face reaches both into it and into the room (one patch lit on one
    side and dark on the other would average the two). `on_sill`: the bottom rail rests on a
    sill, and its underside is left out."""
    boxes = [(lo_a - width, hi_a + width, lo_y - width, lo_y, "+y"),   # bottom rail
             (lo_a - width, hi_a + width, hi_y, hi_y + width, "-y"),   # top rail
             (lo_a - width, lo_a, lo_y, hi_y, "+a"),                   # left stile
             (hi_a, hi_a + width, lo_y, hi_y, "-a")]                   # right stile
    faces = []
    for a0, a1, y0, y1, inner in boxes:
        across = "z" if wall in ("x0", "x1") else "x"  # the wall's horizontal axis
        side = inner.replace("a", across)
        rest = ("-y",) if on_sill and inner == "+y" else ()
        if wall == "x0":
            faces += box(0, depth, y0, y1, a0, a1, omit=("-x",) + rest,
                         trim={side: ("x", proud, depth)})
        elif wall == "x1":
            faces += box(W - depth, W, y0, y1, a0, a1, omit=("+x",) + rest,
                         trim={side: ("x", W - depth, W - proud)})
        elif wall == "z0":
            faces += box(a0, a1, y0, y1, 0, depth, omit=("-z",) + rest,
                         trim={side: ("z", proud, depth)})
        else:
            faces += box(a0, a1, y0, y1, D - depth, D, omit=("+z",) + rest,
                         trim={side: ("z", D - depth, D - proud)})
    return faces


# ---- the furniture -----------------------------------------------------------------------

def table(x0, x1, z0, z1, height, top=40, leg=60, inset=50):
    faces = box(x0, x1, height - top, height, z0, z1)
    for lx, lz in ((x0 + inset, z0 + inset), (x1 - inset - leg, z0 + inset),
                   (x0 + inset, z1 - inset - leg), (x1 - inset - leg, z1 - inset - leg)):
        faces += box(lx, lx + leg, 0, height - top, lz, lz + leg, omit=("-y", "+y"))
    return faces


def chair(cx, cz, facing):
    """A chair of seat 450 x 450 at height 450, its back on the side away from `facing`
    ("+x", "-x", "+z", "-z": the direction a sitter looks)."""
    s, seat_h, seat_t, leg, back_h, back_t = 450.0, 450.0, 40.0, 40.0, 900.0, 40.0
    x0, x1, z0, z1 = cx - s / 2, cx + s / 2, cz - s / 2, cz + s / 2
    faces = box(x0, x1, seat_h - seat_t, seat_h, z0, z1)
    for lx, lz in ((x0, z0), (x1 - leg, z0), (x0, z1 - leg), (x1 - leg, z1 - leg)):
        faces += box(lx, lx + leg, 0, seat_h - seat_t, lz, lz + leg, omit=("-y", "+y"))
    if facing == "+z":
        faces += box(x0, x1, seat_h, back_h, z0, z0 + back_t, omit=("-y",))
    elif facing == "-z":
        faces += box(x0, x1, seat_h, back_h, z1 - back_t, z1, omit=("-y",))
    elif facing == "+x":
        faces += box(x0, x0 + back_t, seat_h, back_h, z0, z1, omit=("-y",))
    else:
        faces += box(x1 - back_t, x1, seat_h, back_h, z0, z1, omit=("-y",))
    return faces


def bookcase(x0, x1, z1, depth, height, board=25, shelves=5):
    """Open shelves against the north wall (z = z1): sides, top, bottom, shelves."""
    z0 = z1 - depth
    # The sides' inner faces begin above the plinth: below it they would face its inside.
    faces = box(x0, x0 + board, 0, height, z0, z1, omit=("-y", "+z"),
                trim={"+x": ("y", 80, height)})                             # left side
    faces += box(x1 - board, x1, 0, height, z0, z1, omit=("-y", "+z"),
                 trim={"-x": ("y", 80, height)})                            # right side
    faces += box(x0 + board, x1 - board, height - board, height, z0, z1, omit=("+z", "-x", "+x"))
    faces += box(x0 + board, x1 - board, 0, 80, z0, z1, omit=("-y", "+z", "-x", "+x"))  # plinth
    step = (height - board - 80) / shelves
    for k in range(1, shelves):
        y = 80 + k * step
        faces += box(x0 + board, x1 - board, y - board, y, z0, z1, omit=("+z", "-x", "+x"))
    return faces, [80 + k * step for k in range(shelves)]


def books(x0, x1, z1, shelf_ys, colour_index, depth=240):
    """Rows of books on the shelves in one deterministic layout; keeps every third book, those
    of the given colour index (0, 1, 2), so that three objects share the shelves without
    overlapping."""
    faces = []
    k = 0
    for row, y in enumerate(shelf_ys):
        x = x0 + 40
        while True:
            w = 25 + ((k * 37 + row * 11) % 5) * 9
            h = 170 + ((k * 53 + row * 7) % 6) * 22
            if x + w > x1 - 40:
                break
            if (k + row) % 3 == colour_index:
                faces += box(x, x + w, y, y + h, z1 - depth, z1, omit=("-y", "+z"))
            x += w + 2
            k += 1
    return faces


def sofa(x0, x1, z0, depth, seat_h=420, back_h=850, arm_w=200, arm_h=620, back_t=220):
    """A sofa against the south wall (back at z0), facing +z: the outer surface of two arms and
    an L-shaped body between them, with no face inside it (a face that ran from the room into
    the sofa's inside would carry light in)."""
    z1, xa, xb, zb = z0 + depth, x0 + arm_w, x1 - arm_w, z0 + back_t
    SOLIDS.extend([(x0, xa, 0, arm_h, z0, z1), (xb, x1, 0, arm_h, z0, z1),
                   (xa, xb, 0, seat_h, zb, z1), (xa, xb, 0, back_h, z0, zb)])
    faces = []
    for ax0, ax1, inner in ((x0, xa, "+x"), (xb, x1, "-x")):  # arms
        outer = "-x" if inner == "+x" else "+x"
        faces.append(rect("x", ax0 if outer == "-x" else ax1, 0, arm_h, z0, z1, outer))
        faces.append(rect("y", arm_h, ax0, ax1, z0, z1, "+y"))
        faces.append(rect("z", z1, ax0, ax1, 0, arm_h, "+z"))
        # The inner side shows only above the seat and in front of the back.
        faces.append(rect("x", ax1 if inner == "+x" else ax0, seat_h, arm_h, zb, z1, inner))
    faces.append(rect("y", seat_h, xa, xb, zb, z1, "+y"))       # seat top
    faces.append(rect("z", z1, xa, xb, 0, seat_h, "+z"))        # seat front
    faces.append(rect("y", back_h, xa, xb, z0, zb, "+y"))       # back top
    faces.append(rect("z", zb, xa, xb, seat_h, back_h, "+z"))   # back, above the seat
    faces.append(rect("x", xa, arm_h, back_h, z0, zb, "-x"))    # back's ends above the arms
    faces.append(rect("x", xb, arm_h, back_h, z0, zb, "+x"))
    return faces


def cushions(x0, x1, z0, seat_h=420, back_t=220, arm_w=200):
    faces = []
    n = 3
    inner0, inner1 = x0 + arm_w + 30, x1 - arm_w - 30
    wseg = (inner1 - inner0) / n
    for k in range(n):
        a = inner0 + k * wseg + 15
        b = inner0 + (k + 1) * wseg - 15
        faces += box(a, b, seat_h, seat_h + 400, z0 + back_t, z0 + back_t + 140,
                     omit=("-y", "-z"))
    return faces


def cabinet(x0, depth, z0, z1, height):
    """A sideboard against the west wall (x = x0 = 0), doors facing +x."""
    faces = box(x0, x0 + depth, 80, height, z0, z1, omit=("-x", "-y"))
    faces += box(x0, x0 + depth - 40, 0, 80, z0 + 40, z1 - 40, omit=("-x", "-y", "+y"))  # plinth
    # The underside only where it overhangs the plinth: over the plinth it would face into
    # the plinth's inside.
    faces.append(rect("y", 80, x0 + depth - 40, x0 + depth, z0, z1, "-y"))
    faces.append(rect("y", 80, x0, x0 + depth - 40, z0, z0 + 40, "-y"))
    faces.append(rect("y", 80, x0, x0 + depth - 40, z1 - 40, z1, "-y"))
    return faces


def handles(x, ys, zs):
    faces = []
    for y in ys:
        for z in zs:
            faces += box(x, x + 25, y - 10, y + 10, z - 60, z + 60, omit=("-x",))
    return faces


# ---- the scene ---------------------------------------------------------------------------

def build():
    objs = []   # (name, material, faces or polygon, extra)

    def mesh(name, material, faces, **extra):
        objs.append((name, material, faces, extra))

    def poly(name, material, polygon, **extra):
        objs.append((name, material, polygon, dict(extra, polygon=True)))

    # Shell, facing inwards.
    poly("floor", "oak_floor", rect("y", 0, 0, W, 0, D, "+y"))
    poly("ceiling", "ceiling_white", rect("y", H, 0, W, 0, D, "-y"))
    poly("wall_west", "wall_sage", rect("x", 0, 0, H, 0, D, "+x"))
    poly("wall_east", "wall_cream", rect("x", W, 0, H, 0, D, "-x"))
    poly("wall_south", "wall_cream", rect("z", 0, 0, W, 0, H, "+z"))
    poly("wall_north", "wall_cream", rect("z", D, 0, W, 0, H, "-z"))

    # Lights: three ceiling panels, 5 mm below the ceiling, facing down.
    for k, cx in enumerate((1500.0, 3000.0, 4500.0)):
        poly("ceiling_panel_%d" % (k + 1), "panel_diffuser",
             rect("y", H - 5, cx - 300, cx + 300, 1950, 2550, "-y"),
             emission=[9.0, 8.6, 7.8])
    # The window: a glowing pane in the north wall, 5 mm proud of it, with frame and sill.
    wx0, wx1, wy0, wy1 = 2500.0, 3900.0, 950.0, 2250.0
    poly("window", "window_pane", rect("z", D - 5, wx0, wx1, wy0, wy1, "-z"),
         emission=[2.2, 2.9, 4.0])
    mesh("window_frame", "frame_white", frame_on_wall("z1", wx0, wx1, wy0, wy1, 70, 60,
                                                           proud=5, on_sill=True))
    mesh("window_sill", "frame_white", box(wx0 - 150, wx1 + 150, wy0 - 110, wy0 - 70,
                                           D - 200, D, omit=("+z",)))

    # The mirror on the west wall, 10 mm proud, in a dark frame; the sideboard under it.
    mz0, mz1, my0, my1 = 1650.0, 2850.0, 1150.0, 2250.0
    poly("mirror", "mirror", rect("x", 10, my0, my1, mz0, mz1, "+x"))
    mesh("mirror_frame", "walnut", frame_on_wall("x0", mz0, mz1, my0, my1, 60, 40,
                                                     proud=10))
    mesh("sideboard", "walnut", cabinet(0.0, 450.0, 1400.0, 3100.0, 800.0))
    mesh("sideboard_handles", "brass", handles(450.0, (650.0,), (1800.0, 2250.0, 2700.0)))
    mesh("vase", "glazed_blue", frustum(250.0, 2700.0, 800.0, 1100.0, 90.0, 60.0, 8,
                                       omit=("bottom",)))
    # A table lamp on the sideboard: a brass base and a glowing shade.
    mesh("table_lamp_base", "brass", frustum(240.0, 1750.0, 800.0, 1130.0, 70.0, 25.0, 6,
                                             omit=("bottom", "top")))
    mesh("table_lamp_shade", "shade_linen", frustum(240.0, 1750.0, 1130.0, 1330.0, 180.0,
                                                    120.0, 8),
         emission=[6.0, 4.6, 2.8])

    # The dining table and four chairs in the middle of the room.
    tx0, tx1, tz0, tz1 = 2300.0, 3900.0, 2450.0, 3350.0
    mesh("dining_table", "oak", table(tx0, tx1, tz0, tz1, 750.0))
    mesh("chair_1", "chair_paint", chair(2750.0, 2150.0, "+z"))
    mesh("chair_2", "chair_paint", chair(3450.0, 2150.0, "+z"))
    mesh("chair_3", "chair_paint", chair(2750.0, 3650.0, "-z"))
    mesh("chair_4", "chair_paint", chair(3450.0, 3650.0, "-z"))
    mesh("fruit_bowl", "glazed_white", frustum(3100.0, 2900.0, 750.0, 850.0, 110.0, 170.0, 8,
                                               omit=("bottom",)))

    # Bookcase against the north wall, west end, with books in three colours.
    bx0, bx1 = 300.0, 1400.0
    bc, shelf_ys = bookcase(bx0, bx1, D, 350.0, 2000.0)
    mesh("bookcase", "walnut", bc)
    mesh("books_red", "book_red", books(bx0, bx1, D, shelf_ys, 0))
    mesh("books_blue", "book_blue", books(bx0, bx1, D, shelf_ys, 1))
    mesh("books_ochre", "book_ochre", books(bx0, bx1, D, shelf_ys, 2))

    # Sofa against the south wall, cushions, coffee table and rug in front of it.
    sx0, sx1 = 1300.0, 3500.0
    mesh("sofa", "sofa_fabric", sofa(sx0, sx1, 0.0, 900.0))
    mesh("sofa_cushions", "cushion_rust", cushions(sx0, sx1, 0.0))
    poly("rug", "rug_wool", rect("y", 3, 1100, 3700, 700, 2300, "+y"))
    mesh("coffee_table", "walnut", table(1800.0, 3000.0, 1250.0, 1850.0, 420.0, top=50, leg=50))
    mesh("coffee_table_tray", "brass", box(2200.0, 2600.0, 420.0, 440.0, 1400.0, 1700.0,
                                          omit=("-y",)))

    # Floor lamp by the sofa: a brass stand and a glowing shade.
    mesh("floor_lamp_stand", "brass",
         box(880.0, 920.0, 30.0, 1500.0, 480.0, 520.0, omit=("-y", "+y"))
         + frustum(900.0, 500.0, 0.0, 30.0, 170.0, 170.0, 8, omit=("bottom",)))
    mesh("floor_lamp_shade", "shade_linen", frustum(900.0, 500.0, 1500.0, 1800.0, 230.0, 170.0,
                                                    10),
         emission=[5.0, 3.9, 2.4])

    # East wall: a cabinet with a plant beside it; a tall cupboard in the north-east corner.
    mesh("cabinet_east", "cabinet_paint", box(W - 500.0, W, 0.0, 900.0, 1700.0, 2900.0,
                                               omit=("+x", "-y")))
    mesh("cabinet_east_handles", "brass", box(W - 525.0, W - 500.0, 700.0, 720.0, 2000.0,
                                               2600.0, omit=("+x",)))
    mesh("cupboard", "frame_white", box(W - 650.0, W, 0.0, 2200.0, D - 800.0, D,
                                        omit=("+x", "-y", "+z")))
    mesh("plant_pot", "terracotta", frustum(W - 350.0, 1200.0, 0.0, 450.0, 160.0, 220.0, 8,
                                            omit=("bottom",)))
    mesh("plant", "leaf_green", frustum(W - 350.0, 1200.0, 450.0, 1350.0, 320.0, 90.0, 6,
                                        phase=0.3, omit=("bottom",)))

    # Pictures: a canvas 5 mm proud of the wall in a frame 30 mm deep.
    def picture(name, colour, wall, a0, a1, y0, y1):
        if wall == "z0":
            canvas = rect("z", 5, a0, a1, y0, y1, "+z")
        elif wall == "z1":
            canvas = rect("z", D - 5, a0, a1, y0, y1, "-z")
        elif wall == "x1":
            canvas = rect("x", W - 5, y0, y1, a0, a1, "-x")
        else:
            canvas = rect("x", 5, y0, y1, a0, a1, "+x")
        poly(name, colour, canvas)
        mesh(name + "_frame", "frame_black", frame_on_wall(wall, a0, a1, y0, y1, 40, 30,
                                                                  proud=5))

    picture("picture_sofa", "canvas_blue", "z0", 1900.0, 2900.0, 1250.0, 1900.0)
    picture("picture_north", "canvas_ochre", "z1", 4400.0, 5000.0, 1300.0, 2000.0)
    picture("picture_east_1", "canvas_red", "x1", 3000.0, 3550.0, 1250.0, 1750.0)
    picture("picture_east_2", "canvas_green", "x1", 1900.0, 2500.0, 1250.0, 1750.0)

    # The door in the south wall's east end, 10 mm proud, with its frame.
    poly("door", "oak", rect("z", 10, 4600.0, 5500.0, 0.0, 2050.0, "+z"))
    mesh("door_frame", "frame_white",
         box(4540.0, 4600.0, 0.0, 2110.0, 0.0, 40.0, omit=("-z", "-y"),
             trim={"+x": ("z", 10.0, 40.0)})
         + box(5500.0, 5560.0, 0.0, 2110.0, 0.0, 40.0, omit=("-z", "-y"),
               trim={"-x": ("z", 10.0, 40.0)})
         + box(4600.0, 5500.0, 2050.0, 2110.0, 0.0, 40.0, omit=("-z",),
               trim={"-y": ("z", 10.0, 40.0)}))
    return objs


MATERIALS = {
    "oak_floor":     {"type": "glossy", "diffuse": [0.3, 0.19, 0.1],
                      "specular": [0.3, 0.3, 0.3], "roughness": 0.25},
    "ceiling_white": {"type": "diffuse", "reflectance": [0.8, 0.8, 0.78]},
    "wall_cream":    {"type": "diffuse", "reflectance": [0.75, 0.7, 0.6]},
    "wall_sage":     {"type": "diffuse", "reflectance": [0.45, 0.55, 0.45]},
    "panel_diffuser": {"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]},
    "window_pane":   {"type": "diffuse", "reflectance": [0.1, 0.1, 0.1]},
    "frame_white":   {"type": "diffuse", "reflectance": [0.8, 0.8, 0.8]},
    "frame_black":   {"type": "diffuse", "reflectance": [0.04, 0.04, 0.04]},
    "mirror":        {"type": "mirror", "reflectance": [0.9, 0.9, 0.9]},
    "walnut":        {"type": "diffuse", "reflectance": [0.25, 0.14, 0.08]},
    "oak":           {"type": "diffuse", "reflectance": [0.5, 0.35, 0.2]},
    "brass":         {"type": "glossy", "diffuse": [0.05, 0.04, 0.02],
                      "specular": [0.7, 0.55, 0.3], "roughness": 0.3},
    "glazed_blue":   {"type": "glossy", "diffuse": [0.08, 0.15, 0.45],
                      "specular": [0.3, 0.3, 0.3], "roughness": 0.1},
    "glazed_white":  {"type": "glossy", "diffuse": [0.7, 0.7, 0.68],
                      "specular": [0.25, 0.25, 0.25], "roughness": 0.15},
    "shade_linen":   {"type": "diffuse", "reflectance": [0.8, 0.75, 0.65]},
    "chair_paint":   {"type": "diffuse", "reflectance": [0.15, 0.3, 0.35]},
    "book_red":      {"type": "diffuse", "reflectance": [0.55, 0.08, 0.06]},
    "book_blue":     {"type": "diffuse", "reflectance": [0.08, 0.15, 0.45]},
    "book_ochre":    {"type": "diffuse", "reflectance": [0.65, 0.45, 0.12]},
    "sofa_fabric":   {"type": "diffuse", "reflectance": [0.2, 0.25, 0.45]},
    "cushion_rust":  {"type": "diffuse", "reflectance": [0.6, 0.25, 0.1]},
    "rug_wool":      {"type": "diffuse", "reflectance": [0.6, 0.55, 0.45]},
    "cabinet_paint": {"type": "diffuse", "reflectance": [0.7, 0.3, 0.2]},
    "terracotta":    {"type": "diffuse", "reflectance": [0.6, 0.3, 0.18]},
    "leaf_green":    {"type": "diffuse", "reflectance": [0.1, 0.35, 0.08]},
    "canvas_blue":   {"type": "diffuse", "reflectance": [0.15, 0.3, 0.6]},
    "canvas_ochre":  {"type": "diffuse", "reflectance": [0.7, 0.5, 0.15]},
    "canvas_red":    {"type": "diffuse", "reflectance": [0.6, 0.12, 0.1]},
    "canvas_green":  {"type": "diffuse", "reflectance": [0.2, 0.5, 0.3]},
}

CAMERA = {"position": [5500, 1500, 650], "look_at": [1500, 1050, 2900], "up": [0, 1, 0],
          "fov_deg": 55, "width": 320, "height": 240}
PATCH_SIZE = 300


def fmt(x):
    s = ("%.3f" % x).rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def write_obj(path, name, faces):
    verts, index, lines = [], {}, []
    for f in faces:
        ids = []
        for p in f:
            key = tuple(fmt(c) for c in p)
            if key not in index:
                index[key] = len(verts) + 1
                verts.append(key)
            ids.append(index[key])
        lines.append("f " + " ".join(str(i) for i in ids))
    with open(path, "w", newline="\n") as out:
        out.write("# %s: written by scripts/make_room.py (millimetres, faces counter-clockwise\n"
                  "# seen from their front)\n" % name)
        for v in verts:
            out.write("v %s %s %s\n" % v)
        out.write("\n".join(lines) + "\n")


def check_overlaps():
    eps = 1e-6
    for i, a in enumerate(SOLIDS):
        for b in SOLIDS[i + 1:]:
            if all(min(a[2 * k + 1], b[2 * k + 1]) - max(a[2 * k], b[2 * k]) > eps
                   for k in range(3)):
                raise SystemExit("make_room.py: solids overlap: %s and %s" % (a, b))


def main():
    os.makedirs(MESH_DIR, exist_ok=True)
    objs = build()
    check_overlaps()
    used = set()
    lines = []
    for name, material, geom, extra in objs:
        used.add(material)
        rec = '{"name": "%s", "material": "%s"' % (name, material)
        if "emission" in extra:
            rec += ', "emission": [%s]' % ", ".join(fmt(e) for e in extra["emission"])
        if extra.get("polygon"):
            rec += ',\n     "polygon": [%s]}' % ", ".join(
                "[%s]" % ", ".join(fmt(c) for c in p) for p in geom)
        else:
            write_obj(os.path.join(MESH_DIR, name + ".obj"), name, geom)
            rec += ', "mesh": "meshes/room/%s.obj"}' % name
        lines.append("    " + rec)
    assert used == set(MATERIALS), sorted(set(MATERIALS) ^ used)
    cam = ", ".join('"%s": %s' % (k, json.dumps(v)) for k, v in CAMERA.items())
    mats = ",\n".join('    "%s": %s' % (k, json.dumps(v)) for k, v in MATERIALS.items())
    text = ('{\n  "camera": {%s},\n  "patch_size": %s,\n  "materials": {\n%s\n  },\n'
            '  "objects": [\n%s\n  ]\n}\n' % (cam, PATCH_SIZE, mats, ",\n".join(lines)))
    json.loads(text)  # well-formed
    with open(SCENE, "w", newline="\n") as out:
        out.write(text)
    print("wrote %s: %d objects, %d materials" % (SCENE, len(objs), len(MATERIALS)))


if __name__ == "__main__":
    main()
