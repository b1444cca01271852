#!/usr/bin/env python3
"""The exact image of scenes/stability/facing-mirrors-black.json, and images judged against it.

Between the corridor's two mirrors (reflectance 0.99, at x = 0 and 0.2) the floor (0.9) is the
only surface that reflects; its radiance is the sum over the lamp's images, the k-th at x + 0.2 k
after |k| reflections: L(x) = 0.9 sum_k 0.99^|k| F(x -> lamp_k) (tests/test_support.h,
facing_mirrors_black). Each pixel's 4 x 4 rays are reflected by the mirrors analytically until
they meet the floor (L from a table of the sum, bilinear), the lamp (1) or a black face.

  facing_mirrors_exact.py exact EXACT.pfm MASK.json    the image, and which pixels see the lamp
  facing_mirrors_exact.py compare A.pfm EXACT.pfm MASK.json
      A's mean and relative RMSE (eps 1 percent of the exact mean) over the pixels that show no
      lamp, nor border one that does (the lamp's edges are the emission grid's, not the floor's)

Python alone, no packages: about 6 s.
"""
import json
import math
import struct
import sys

W = H = 64
FOV = 60.0
EYE = (0.1, 0.5, 0.01)  # looking along +z
LAMP = (0.05, 0.15, 0.45, 0.55, 0.999)  # x0, x1, z0, z1, height
IMAGES = 120  # a term there is 3e-7 of the first


def polygon_ff(p, poly):
    """Form factor from a point with normal +y to a polygon (the contour integral)."""
    s = 0.0
    for i in range(len(poly)):
        a = [poly[i][j] - p[j] for j in range(3)]
        b = [poly[(i + 1) % len(poly)][j] - p[j] for j in range(3)]
        c = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
        cn = math.sqrt(sum(t * t for t in c))
        if cn == 0.0:
            continue
        la = math.sqrt(sum(t * t for t in a))
        lb = math.sqrt(sum(t * t for t in b))
        cos = sum(a[j] * b[j] for j in range(3)) / (la * lb)
        s += math.acos(max(-1.0, min(1.0, cos))) * c[1] / cn
    return abs(s) / (2.0 * math.pi)


def floor_table(nx=21, nz=101):
    x0, x1, z0, z1, y = LAMP
    table = [[0.0] * nz for _ in range(nx)]
    for i in range(nx):
        for j in range(nz):
            p = (0.2 * i / (nx - 1), 0.0, j / (nz - 1))
            total = 0.0
            for k in range(-IMAGES, IMAGES + 1):
                a, b = x0 + 0.2 * k, x1 + 0.2 * k
                total += 0.99 ** abs(k) * polygon_ff(p, [(a, y, z0), (b, y, z0), (b, y, z1), (a, y, z1)])
            table[i][j] = 0.9 * total
    return table


def bilinear(table, x, z):
    nx, nz = len(table), len(table[0])
    u = min(max(x / 0.2, 0.0), 1.0) * (nx - 1)
    v = min(max(z, 0.0), 1.0) * (nz - 1)
    i, j = min(int(u), nx - 2), min(int(v), nz - 2)
    fu, fv = u - i, v - j
    return (table[i][j] * (1 - fu) * (1 - fv) + table[i + 1][j] * fu * (1 - fv) +
            table[i][j + 1] * (1 - fu) * fv + table[i + 1][j + 1] * fu * fv)


def trace(table, d):
    """Radiance along direction d from the eye, and whether the ray ends on the lamp."""
    o, w = list(EYE), 1.0
    x0, x1, z0, z1, lamp_y = LAMP
    while True:
        hits = []
        if d[0] != 0.0:
            hits.append((((0.2 if d[0] > 0 else 0.0) - o[0]) / d[0], "mirror"))
        if d[1] != 0.0:
            hits.append((((lamp_y if d[1] > 0 else 0.0) - o[1]) / d[1], "up" if d[1] > 0 else "floor"))
        hits.append((((1.0 if d[2] > 0 else 0.0) - o[2]) / d[2], "black"))
        t, what = min(hits)
        p = [o[k] + t * d[k] for k in range(3)]
        if what == "mirror":
            w *= 0.99
            d = [-d[0], d[1], d[2]]
            o = p
            continue
        if what == "floor":
            return w * bilinear(table, p[0], p[2]), False
        if what == "up" and x0 <= p[0] <= x1 and z0 <= p[2] <= z1:
            return w, True
        return 0.0, False


def exact(image_path, mask_path):
    table = floor_table()
    scale = math.tan(0.5 * math.radians(FOV)) / (0.5 * min(W, H))
    img = [[0.0] * W for _ in range(H)]
    mask = [[0] * W for _ in range(H)]
    n = 4
    for py in range(H):
        for px in range(W):
            total = 0.0
            for sy in range(n):
                for sx in range(n):
                    d = [(px + (sx + 0.5) / n - 0.5 * W) * scale,
                         (0.5 * H - (py + (sy + 0.5) / n)) * scale, 1.0]
                    norm = math.sqrt(sum(t * t for t in d))
                    value, lamp = trace(table, [t / norm for t in d])
                    total += value
                    mask[py][px] |= lamp
            img[py][px] = total / (n * n)
    write_pfm(image_path, img)
    with open(mask_path, "w") as f:
        json.dump(mask, f)


def write_pfm(path, img):
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
        for y in range(H - 1, -1, -1):
            for x in range(W):
                f.write(struct.pack("<3f", img[y][x], img[y][x], img[y][x]))


def read_pfm(path):
    """The green channel, top row first."""
    data = open(path, "rb").read()
    parts = data.split(b"\n", 3)
    w, h = map(int, parts[1].split())
    pixels = parts[3]
    return [[struct.unpack_from("<3f", pixels, 12 * ((h - 1 - row) * w + x))[1] for x in range(w)]
            for row in range(h)]


def compare(a_path, exact_path, mask_path):
    a, e = read_pfm(a_path), read_pfm(exact_path)
    mask = json.load(open(mask_path))
    near_lamp = lambda y, x: any(mask[j][i] for j in range(max(0, y - 1), min(H, y + 2))
                                 for i in range(max(0, x - 1), min(W, x + 2)))
    pixels = [(y, x) for y in range(H) for x in range(W) if not near_lamp(y, x) and e[y][x] > 0]
    sa = sum(a[y][x] for y, x in pixels)
    se = sum(e[y][x] for y, x in pixels)
    eps = 0.01 * se / len(pixels)
    rmse = math.sqrt(sum(((a[y][x] - e[y][x]) / (e[y][x] + eps)) ** 2 for y, x in pixels) / len(pixels))
    print("mean %+.2f%%, relative RMSE %.4f (%d pixels)" % (100.0 * (sa / se - 1.0), rmse, len(pixels)))
    return sa / se - 1.0, rmse


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "exact":
        exact(sys.argv[2], sys.argv[3])
    elif len(sys.argv) == 5 and sys.argv[1] == "compare":
        compare(sys.argv[2], sys.argv[3], sys.argv[4])
    else:
        sys.exit(__doc__)
