#!/usr/bin/env python3
"""A second look at the query values of the random cpfg cases: the final
string of each case of tests/expected/cpfg/random/cases.txt that has a
`--cpfg-view` file is interpreted again by a turtle written differently
from cpfg_ref.py's QueryTurtle (a frame matrix whose columns are H, L, U,
turned by multiplying it by plane rotations, the tropism's bends as
rotations by asin of their sines, plain doubles, cpfg's float roundings
left out), and every value a query holds must agree with it to 1e-4
(relative above 1). It checks the reference's turtle against the same
reading of cpfg (which vector a module turns, which way, the bends, `@v`,
`@M`, `[ ]`, `%` with `interpretation past %: off`, the view's settings),
not cpfg's bits. Only the cases whose saved string cpfg fills (no `box:`,
or `environment display: before`) are checked. The saved string is the
one after the homomorphism: in the thirteenth and fourteenth batches,
interpreting it directly must give the values the reference's turtle got
by reading the string through the homomorphism, but where a homomorphism
that moves the turtle has a context or a condition (the image it makes
of the filled string may differ from the one the turtle read). The
cases with cpfg's movements (`tropism:`, `torque:`, `@T`; the fifteenth
batch) are left out: this turtle does not have them.

Usage: python3 tests/tools/check_queries.py   (exit 1 on a difference)
"""

import math
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CASES = os.path.join(ROOT, "tests", "expected", "cpfg", "random", "cases.txt")

TURNS = {"+": (0, 1, 1), "-": (0, 1, -1), "&": (0, 2, 1), "^": (0, 2, -1),
         "/": (1, 2, 1), "\\": (1, 2, -1)}


def view_settings(text):
    v = {"angle": 45.0, "T": (0.0, 1.0, 0.0), "e": 0.0, "inc": 0.0, "scale": 1.0,
         "past": True, "box": False, "before": False}
    for line in text.split("\n"):
        if ":" not in line or line.lstrip().startswith("/*"):
            continue
        label, rest = line.split(":", 1)
        label, rest = " ".join(label.split()), rest.strip()
        if label == "angle factor":
            v["angle"] = 360.0 / float(rest)
        elif label == "angle increment":
            v["angle"] = float(rest)
        elif label == "tropism direction":
            x, y, z = (float(t) for t in rest.split(","))
            n = math.sqrt(x * x + y * y + z * z)
            v["T"] = (x / n, y / n, z / n)
        elif label == "initial elasticity":
            v["e"] = float(rest)
        elif label == "elasticity increment":
            v["inc"] = float(rest)
        elif label == "initial scale":
            v["scale"] = float(rest) or 1.0
        elif label == "interpretation past %":
            v["past"] = not rest.startswith("off")
        elif label == "box":
            v["box"] = True
        elif label == "environment display":
            v["before"] = rest.startswith("before")
    return v


def modules(s):
    out = []
    i = 0
    while i < len(s):
        c = s[i]
        i += 1
        params = []
        if i < len(s) and s[i] == "(":
            j = s.index(")", i)
            params = [float(t) for t in s[i + 1:j].split(",")]
            i = j + 1
        out.append((c, params))
    return out


def column(M, k):
    return [M[0][k], M[1][k], M[2][k]]


def times(M, R):
    return [[sum(M[i][k] * R[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def plane(a, b, angle):
    """Column a turns toward column b by angle (b away from a)."""
    R = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    c, s = math.cos(angle), math.sin(angle)
    R[a][a], R[b][a], R[a][b], R[b][b] = c, s, -s, c
    return R


def compare(S, v):
    """(values that differ, values compared) in the string S."""
    M = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]  # columns H L U
    P = [0.0, 0.0, 0.0]
    e = v["e"]
    stack = []
    bad = seen = 0
    i = 0
    while i < len(S):
        c, p = S[i]
        i += 1
        if c == "|":
            M = times(M, plane(0, 1, math.pi))
        elif c in TURNS:
            a, b, sign = TURNS[c]
            M = times(M, plane(a, b, sign * math.radians(p[0] if p else v["angle"])))
        elif c in "FfGg":
            d = (p[0] if p else 1.0) * v["scale"]
            P = [P[k] + d * M[k][0] for k in range(3)]
            if e:
                for other in (2, 1):
                    s = e * sum(v["T"][k] * column(M, other)[k] for k in range(3))
                    M = times(M, plane(0, other, math.asin(s)))
        elif c == "_":
            e = p[0] if p else e + v["inc"]
        elif c == "[":
            stack.append((list(P), [list(r) for r in M], e))
        elif c == "]":
            P, M, e = stack.pop()
        elif c == "%" and not v["past"]:
            level = 1
            while i < len(S):
                if S[i][0] == "[":
                    level += 1
                elif S[i][0] == "]":
                    level -= 1
                    if level == 0:
                        break
                i += 1
        elif c == "@":
            f, fp = S[i]
            i += 1
            H = column(M, 0)
            if f == "v" and -1 < H[1] < 1:
                # L horizontal (perpendicular to H and to the y axis), U = L x H
                n = math.hypot(H[2], H[0])
                L = [H[2] / n, 0.0, -H[0] / n]
                U = [L[1] * H[2] - L[2] * H[1], L[2] * H[0] - L[0] * H[2],
                     L[0] * H[1] - L[1] * H[0]]
                M = [[H[k], L[k], U[k]] for k in range(3)]
            elif f == "M" and len(fp) >= 2:
                P = [fp[0], fp[1], fp[2] if len(fp) > 2 else 0.0]
        elif c == "?":
            q, qp = S[i]
            i += 1
            want = {"P": P, "H": column(M, 0), "L": column(M, 1), "U": column(M, 2)}[q]
            for k in range(min(3, len(qp))):
                seen += 1
                if abs(want[k] - qp[k]) > 1e-4 * max(1.0, abs(want[k])):
                    bad += 1
    return bad, seen


MOVING = set("FfGg+-&^/\\|_")


def reads_its_string(body):
    """A homomorphism that moves the turtle and whose productions read the
    string (a context or a condition, which may read a query): the
    turtle read the string through the homomorphism's image of it before
    the fill, and the saved string is the image of it after the fill,
    which may differ; its values cannot be checked on the saved string."""
    if "\nhomomorphism\n" not in body:
        return False
    section = body.split("\nhomomorphism\n")[1].split("\nendlsystem")[0]
    prods = [line.split("-->") for line in section.split("\n") if "-->" in line]
    reads = moves = False
    for lhs, rhs in prods:
        reads |= any(c in lhs for c in "<>:")
        pred = lhs.split(":")[0]
        pred = pred.split("<")[-1].split(">")[0]
        depth = paren = 0
        for c in rhs:
            # (a module's parameters hold no module)
            paren += (c == "(") - (c == ")")
            if paren or c == ")":
                continue
            if c == "[":
                depth += 1
            elif c == "]":
                depth -= 1
            elif depth == 0 and c in MOVING:
                moves = True
        moves |= any(c in MOVING for c in pred)
    return reads and moves


def main():
    with open(CASES, encoding="utf-8") as f:
        text = f.read()
    cases = checked = values = failed = 0
    for n, case in enumerate(text.split("=== ")[1:]):
        body, out = case.split("--- expected\n")
        if "--cpfg-view case.v" not in body:
            continue
        cases += 1
        view_text = body.split("--- file case.v\n")[1].split("--- ")[0]
        view = view_settings(view_text)
        if view["box"] and not view["before"]:
            # (cpfg does not fill the saved string's queries then: they
            # hold the values of the fill before the last step)
            continue
        if "tropism:" in view_text or "torque:" in view_text or "@T" in body:
            # (cpfg's movements: this turtle does not have them)
            continue
        if reads_its_string(body):
            # (its image changes with the values the fill gives, so the
            # saved string is not the image the turtle read)
            continue
        bad, seen = compare(modules(out.strip()), view)
        checked += 1
        values += seen
        if bad:
            failed += 1
            print("case %d: %d of %d query values differ" % (n + 1, bad, seen))
    print("%d cases with queries, %d with their saved string filled (no `box:`, or "
          "`environment display: before`), %d values compared, %d cases differ"
          % (cases, checked, values, failed))
    return 1 if failed or not cases else 0


if __name__ == "__main__":
    sys.exit(main())
