#!/usr/bin/env python3
"""The exact image of scenes/stability/mirrored-room.json, and images judged against it.

A room 0.4 x 0.4 x 1 whose four walls are mirrors of 0.9, its floor white (0.9) and its ceiling
black but for a lamp 0.1 square in the middle, seen from above. Unfolded through the walls the
lamp's images fill a lattice, the (i, j)-th moved by (0.4 i, 0.4 j) after |i| + |j| reflections
(the lamp is centred, so an image mirrored in place is the same square), and the floor's radiance
is L(x) = 0.9 sum_ij 0.9^(|i| + |j|) F(x -> lamp_ij) (the test
FinalGather.MirroredRoomDrawsItsChainsThroughEveryWall sums the same). Every pixel sees the
floor; its 4 x 4 points read L from a table (one eighth of the floor, by symmetry, bilinear).

  mirrored_room_exact.py exact EXACT.pfm MASK.json    the image (and an empty lamp mask)
  mirrored_room_exact.py compare A.pfm EXACT.pfm MASK.json
      A's mean and relative RMSE (eps 1 percent of the exact mean) over every pixel

Python alone, no packages: about 20 s.
"""
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import facing_mirrors_exact as fm  # noqa: E402 (polygon_ff, write_pfm, compare)

W = H = 64
FOV = 30.0
EYE_HEIGHT = 0.5  # above the floor's centre (0.2, 0, 0.2)
IMAGES = 40  # |i| + |j| <= 40: a term there is 0.9^40 / 40^4 of the first, 1e-8
N = 15  # table nodes over [0.2, 0.2 + HALF] on each axis
HALF = 0.14  # past the view's half-width, 0.5 tan(15 deg) = 0.134


def radiance(x, z):
    total = 0.0
    for i in range(-IMAGES, IMAGES + 1):
        for j in range(-IMAGES + abs(i), IMAGES - abs(i) + 1):
            a, b = 0.15 + 0.4 * i, 0.15 + 0.4 * j
            lamp = [(a, 0.999, b), (a + 0.1, 0.999, b), (a + 0.1, 0.999, b + 0.1), (a, 0.999, b + 0.1)]
            total += 0.9 ** (abs(i) + abs(j)) * fm.polygon_ff((x, 0.0, z), lamp)
    return 0.9 * total


def table():
    t = [[0.0] * N for _ in range(N)]
    for i in range(N):
        for j in range(i + 1):  # L(x, z) = L(z, x)
            t[i][j] = t[j][i] = radiance(0.2 + HALF * i / (N - 1), 0.2 + HALF * j / (N - 1))
    return t


def lookup(t, x, z):
    u = min(abs(x - 0.2) / HALF, 1.0) * (N - 1)
    v = min(abs(z - 0.2) / HALF, 1.0) * (N - 1)
    i, j = min(int(u), N - 2), min(int(v), N - 2)
    fu, fv = u - i, v - j
    return (t[i][j] * (1 - fu) * (1 - fv) + t[i + 1][j] * fu * (1 - fv) +
            t[i][j + 1] * (1 - fu) * fv + t[i + 1][j + 1] * fu * fv)


def exact(image_path, mask_path):
    t = table()
    scale = math.tan(0.5 * math.radians(FOV)) / (0.5 * min(W, H))
    n = 4
    img = [[0.0] * W for _ in range(H)]
    for py in range(H):
        for px in range(W):
            total = 0.0
            for sy in range(n):
                for sx in range(n):
                    dx = (px + (sx + 0.5) / n - 0.5 * W) * scale
                    dz = (0.5 * H - (py + (sy + 0.5) / n)) * scale
                    total += lookup(t, 0.2 + EYE_HEIGHT * dx, 0.2 + EYE_HEIGHT * dz)
            img[py][px] = total / (n * n)
    fm.W, fm.H = W, H
    fm.write_pfm(image_path, img)
    with open(mask_path, "w") as f:
        json.dump([[0] * W for _ in range(H)], f)


if __name__ == "__main__":
    fm.W, fm.H = W, H
    if len(sys.argv) == 4 and sys.argv[1] == "exact":
        exact(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 5 and sys.argv[1] == "compare":
        fm.compare(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        sys.exit(__doc__)
