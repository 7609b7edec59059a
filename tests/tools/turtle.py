#!/usr/bin/env python3
"""Independent reference turtle for lsgen-turtle's segment list.

It shares no code with lsgen-turtle: it reads a module string (lsgen's
output) and the `view:` lines of an .ls file, and prints what the turtle
draws, in lsgen-turtle's `-f segments` format:

    x1 y1 z1 x2 y2 z2 width colour        one line per drawn segment (F, G)
    polygon colour x y z x y z ...        a filled polygon ({ ... })
    dot x y z diameter colour             @o   (sphere ... for @O)

The turtle is the one README.md documents (cpfg's): frame H, L, U starting
at H = (0,1,0), L = (-1,0,0), U = (0,0,-1).  Here every rotation is written
as a rotation of two frame vectors about the third axis (Rodrigues'
formula), not as cpfg's sine/cosine mix, so the two programs only agree if
the documented semantics are followed.

Usage:
    python3 tests/tools/turtle.py MODEL.ls < STRING > SEGMENTS
    python3 tests/tools/gen_turtle.py        # regenerate tests/expected/turtle/
"""

import math
import re
import sys


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dotp(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def unit(a):
    n = math.sqrt(dotp(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def rodrigues(v, k, t):
    """Rotate v by angle t (radians) about the unit axis k."""
    c, s = math.cos(t), math.sin(t)
    kv = cross(k, v)
    kd = dotp(k, v) * (1 - c)
    return tuple(v[i] * c + kv[i] * s + k[i] * kd for i in range(3))


def view_settings(path):
    v = {
        "angle": 45.0, "step": 1.0, "width": 1.0, "width increment": 0.0,
        "width scale": 1.0, "colour": 0.0, "colour increment": 1.0,
        "tropism": (0.0, 1.0, 0.0), "elasticity": 0.0,
        "elasticity increment": 0.0, "tropism model": "abop",
    }
    text = open(path, encoding="utf-8").read()
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    for line in text.split("\n"):
        s = line.strip()
        if s.lower().startswith("axiom:"):
            break
        m = re.match(r"(?i)view:\s*([a-z ]+?)\s*=\s*(.*)$", s)
        if not m:
            continue
        name = m.group(1).lower().replace("color", "colour")
        name = " ".join(name.split())
        val = m.group(2).split()
        if name == "tropism":
            v[name] = tuple(float(x) for x in val)
        elif name == "tropism model":
            v[name] = val[0].lower()
        elif name in v:
            v[name] = float(val[0])
    return v


def modules(text):
    """(symbol, [params]) for each module of lsgen's output."""
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
            continue
        i += 1
        params = []
        if i < n and text[i] == "(":
            j = text.index(")", i)
            params = [float(x) for x in text[i + 1:j].split(",")]
            i = j + 1
        yield c, params


def fmt(x):
    return repr(float(x))


def interpret(text, v, out):
    pos = (0.0, 0.0, 0.0)
    H, L, U = (0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, -1.0)
    width, colour = v["width"], v["colour"]
    stack, polys = [], []
    T, e = v["tropism"], v["elasticity"]
    cpfg = v["tropism model"] == "cpfg"
    if cpfg:
        T = unit(T)
    pending_at = False

    def colour_index():
        return int(math.floor(colour + 0.5)) if colour >= 0 else -int(math.floor(-colour + 0.5))

    for sym, p in modules(text):
        ang = math.radians(p[0]) if p else math.radians(v["angle"])
        if pending_at:
            pending_at = False
            if sym in "oO":
                d = p[0] if p else width * v["width scale"]
                kind = "sphere" if sym == "O" else "dot"
                out.append("%s %s %s %s %s %d" % (kind, fmt(pos[0]), fmt(pos[1]), fmt(pos[2]), fmt(d), colour_index()))
            elif sym == "v":
                H, L, U = level(H, L, U)
            elif sym == "M" and len(p) >= 3:
                pos = (p[0], p[1], p[2])
            continue
        if sym in "FGfg":
            d = p[0] if p else v["step"]
            new = tuple(pos[i] + d * H[i] for i in range(3))
            if sym in "FG":
                out.append(" ".join(fmt(x) for x in pos + new) + " %s %d" % (fmt(width * v["width scale"]), colour_index()))
            if sym in "Ff" and polys:
                polys[-1].append(new)
            pos = new
            if cpfg and e != 0:
                # cpfg's bend (interpret.c), after F G f g: H turns towards
                # U by the angle whose sine is e (T . U), then towards L by
                # the angle whose sine is e (T . L), both in the plane of
                # the two vectors.
                for toward in ("U", "L"):
                    W = U if toward == "U" else L
                    t = math.asin(e * dotp(T, W))
                    k = unit(cross(H, W))
                    H, W = rodrigues(H, k, t), rodrigues(W, k, t)
                    if toward == "U":
                        U = W
                    else:
                        L = W
            elif sym in "FG" and e != 0:
                a = cross(H, T)
                na = math.sqrt(dotp(a, a))
                if na >= 1e-12:
                    k = unit(a)
                    t = e * na
                    H, L, U = rodrigues(H, k, t), rodrigues(L, k, t), rodrigues(U, k, t)
        elif sym in "+-":
            t = ang if sym == "+" else -ang
            k = unit(cross(H, L))  # turning H towards L
            H, L = rodrigues(H, k, t), rodrigues(L, k, t)
        elif sym in "&^":
            t = ang if sym == "&" else -ang
            k = unit(cross(H, U))  # pitching H towards U
            H, U = rodrigues(H, k, t), rodrigues(U, k, t)
        elif sym in "/\\":
            t = ang if sym == "/" else -ang
            k = unit(cross(L, U))  # rolling L towards U
            L, U = rodrigues(L, k, t), rodrigues(U, k, t)
        elif sym == "|":
            k = unit(cross(H, L))
            H, L = rodrigues(H, k, math.pi), rodrigues(L, k, math.pi)
        elif sym == "$":
            H, L, U = level(H, L, U)
        elif sym == "[":
            stack.append((pos, H, L, U, width, colour, e))
        elif sym == "]":
            pos, H, L, U, width, colour, e = stack.pop()
        elif sym == "_":
            e = p[0] if p else e + v["elasticity increment"]
        elif sym == "{":
            polys.append([])
        elif sym == "}":
            poly = polys.pop()
            if len(poly) >= 3:
                out.append("polygon %d " % colour_index() + " ".join(fmt(x) for pt in poly for x in pt))
        elif sym == ".":
            if polys:
                polys[-1].append(pos)
        elif sym in "!#":
            if p:
                width = p[0]
            else:
                width += v["width increment"] if sym == "#" else -v["width increment"]
        elif sym in "';,":
            if p:
                colour = p[0]
            else:
                colour += -v["colour increment"] if sym == "," else v["colour increment"]
        elif sym == "@":
            pending_at = not p
    return out


def level(H, L, U):
    # ABOP p. 57: L = V x H (V = +Y, against gravity); cpfg's @v (blackbox.c)
    # computes the same L and then U = L x H, its frame's handedness.
    a = cross((0.0, 1.0, 0.0), H)
    n = math.sqrt(dotp(a, a))
    if n < 1e-12:
        return H, L, U
    L = unit(a)
    return H, L, cross(L, H)


def main():
    v = view_settings(sys.argv[1])
    out = interpret(sys.stdin.read(), v, [])
    sys.stdout.write("".join(line + "\n" for line in out))


if __name__ == "__main__":
    main()
