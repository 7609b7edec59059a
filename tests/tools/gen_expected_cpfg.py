#!/usr/bin/env python3
"""Regenerate tests/expected/cpfg/ from tests/cpfg/*.l with cpfg_ref.py,
check that every tests/cpfg/refused/*.l is refused with a located error,
and check that the ABOP twins tests/cpfg/abop/*.l give the same strings as
examples/*.ls under tests/tools/ref.py (two independent references).

Usage (from the repository root):
    python3 tests/tools/gen_expected_cpfg.py          # write all files + README.md
    python3 tests/tools/gen_expected_cpfg.py --check  # only compare, exit 1 on any difference

Files:
    tests/expected/cpfg/NAME.nN.txt        tests/cpfg/NAME.l after N steps,
                                           homomorphism applied (if any)
    tests/expected/cpfg/NAME.nN.nohomo.txt the same without the homomorphism
                                           (what cpfg saves with -str), for
                                           models that have one
    tests/expected/cpfg/abop/NAME.nN.txt   tests/cpfg/abop/NAME.l after N steps

The twin check: each tests/cpfg/abop/NAME.l must give, module for module,
the string ref.py derives from examples/NAME.ls (same symbols; parameters
equal within a relative 1e-5, since cpfg stores parameters as 32-bit floats
and prints them with %g, while lsgen's .ls dialect uses 64-bit floats and
the shortest round-trip form).
"""

import io
import os
import re
import sys
from contextlib import redirect_stderr

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import cpfg_ref  # noqa: E402
import gen_expected  # noqa: E402
import ref  # noqa: E402

# model name (tests/cpfg/NAME.l) -> derivation lengths; None: the file's own
MANIFEST = {
    "block_formals": [1],
    "vlab_typical": [0, 1, 2, 3, 4],
    "vlab_stochastic": [1, 2, 3, 6],
    "preprocessor": [0, 1, 2],
    "layout": [0, 1, 2, 3],
    "null_star": [1, 2],
    "multi_pred": [1, 2, 3],
    "multi_sections": [0, 1, 2],
    "walked_multi_pred": [1, 2],
    "first_applicable": [1, 2],
    "expressions": [1],
    "float32": [1, 5, 30],
    "blocks": [1, 2, 3, 4],
    "stochastic": [1, 2, 5, 8],
    "stochastic_seed0": [1, 4],
    "stochastic_deterministic": [1, 2, 3],
    "stochastic_context": [1, 3, 6],
    "stochastic_plant": [1, 2, 5],
    "random_functions": [1, 2, 3],
    "context_branches": [1],
    "context_consider": [1],
    "context_equals": [1],
    "context_equals_long": [1],
    "cut": [1, 2, 3],
    "decomposition": [0, 1, 2, 3],
    "homomorphism": [1, 2],
    "backslash_define": [1, 3],
    "arrays": [0, 1, 2, 3],
}

# Strings derived by hand (the derivations are in the models' comments);
# the reference must agree with them.
HAND = {
    ("block_formals", 1): "K(0.95)Y(1)Q(2)W(1)",
    ("preprocessor", 1): "[+(45)F(1)]B(1.5)[[+(90)F(0.5)]]F(1)F(2)",
    ("layout", 1): "AxCAA,;",
    ("null_star", 1): "BBE",
    ("null_star", 2): "BBBBF",
    ("backslash_define", 1): "A(3)B(3)",
    ("backslash_define", 3): "C(7)B(8)B(5)",
    ("multi_pred", 1): "XD(2)D(12)A(5)A(6)",
    ("multi_pred", 2): "XD(2)B(7)A(6)",
    ("multi_sections", 0): "A(1)P(2)Q(3)RSTUh(3)H(5)H(3)pqr",
    ("multi_sections", 1): "G(6)eDk(5)YmYh(3)H(5)H(3)pqr",
    ("first_applicable", 1): "YZ(0)C(5)Y",
    ("expressions", 1): "a(4)b(64)c(19)d(0,-1,1)e(5,0.25)f(3,-2,2)g(0.5,0.5,1)h(90,90,45)"
    "i(0,45)j(1)k(1,3)l(1,0,0,1,1,0,1)m(0,1,1,0)n(10,3)o(-2,-1,3,-1,0)p(1,0,4,1.41421)"
    "q(0,1,-6)r(100,0.5,3)",
    ("float32", 1): "A(0.1)R(0)B(1.67772e+07)C(0.1)D(-0)N(1.49012e-09)",
    ("blocks", 1): "A(1,10,1)A(2,20,1)B(1)[A]",
    ("blocks", 2): "A(1,10,1)T(101,0,1)A(2,20,1)T(101,0,2)B(2)[A][A(3,30,2)]",
    ("stochastic", 1): "F(1)[-F(0)]",
    ("stochastic", 2): "F(2)[-F(0)][-F(1)]",  # draws 2-6: F(1) [ - F(0) ]
    ("stochastic_seed0", 1): "AB",
    # glibc's drand48 after seed48({42, 0, 155}): 0.519372 (P2), then for
    # F [ + F ] F: 0.004657 (P1) 0.020727 0.090408 0.806382 (P3) 0.251763
    # 0.971018 (P3)
    ("stochastic_plant", 1): "F[+F]F",
    ("stochastic_plant", 2): "F[+F]F[-F]F[+F[-F]F]F[-F]F",
    ("stochastic_deterministic", 2): "ABBB",
    ("context_branches", 1): "a2[X][BY]cd1[E]Fg[h1]Ii[k[l]M]nP[q]rS",
    ("context_consider", 1): "a[b]cFd[F[A]]B",
    ("context_equals", 1): "a[bC[D]E]FG[h]I",
    ("context_equals_long", 1): "[bbbb]F[b[B]b[DB]b]Fe[bb]F[BB]G[Be[C]F]G",
    ("cut", 1): "A[X]G",
    ("cut", 2): "A[X%Y]G",
    ("cut", 3): "A[X%Y]G",
    ("decomposition", 0): "K(3)CB",
    ("decomposition", 1): "FFFK(0)EFFFB",
    ("decomposition", 2): "FFFK(0)EFFFFFFB",
    ("homomorphism", 1): "pqS(3)R(0.52484)",
    ("vlab_typical", 1): "G(1)G(1)[+(30)A(0.5,1)]/(137.5)A(1,1)",
    ("arrays", 0): "A(0)B(1.5)",
    ("arrays", 1): "A(1)R(1,-5,-5,4,10,1,0)B(2.5)W(1,1.67772e+07,0)",
    ("arrays", 2): "A(2)R(4,-4,-5,4,10,2,1)R(1,-5,-5,4,10,1,0)B(2.5)W(1,1.67772e+07,1)",
    ("arrays", 3): "A(2)S(3,-40)S(3,-40)B(2.5)W(1,1.67772e+07,3)",
}

# ABOP twins: every example except those that cannot be twins (README.md)
TWIN_SKIP = {
    "stochastic_plant": "lsgen's .ls dialect draws from ChaCha8, cpfg from drand48",
    "context_brackets": "several sibling branches and context-first choice differ in cpfg",
    "monopodial_tree": "$ is cpfg's sub-L-system end marker",
    "sympodial_tree": "$ is cpfg's sub-L-system end marker",
}


def parse_out(s):
    mods = []
    for m in re.finditer(r"(.)(?:\(([^()]*)\))?", s.strip()):
        vals = [float(v) for v in m.group(2).split(",")] if m.group(2) else []
        mods.append((m.group(1), vals))
    return mods


def same_string(a, b):
    if a == b:
        return True
    ma, mb = parse_out(a), parse_out(b)
    if len(ma) != len(mb):
        return False
    for (sa, va), (sb, vb) in zip(ma, mb):
        if sa != sb or len(va) != len(vb):
            return False
        for x, y in zip(va, vb):
            if abs(x - y) > 1e-5 * max(1.0, abs(x), abs(y)):
                return False
    return True


def quiet(fn, *args):
    buf = io.StringIO()
    with redirect_stderr(buf):
        return fn(*args)


# tests/cpfg/func/NAME.l with --functions tests/cpfg/func/NAME.v: steps
# (func, and the curves of phyllotaxis_like).
FUNC = {
    "fset_macros": [1, 2, 3],
    "lilac_like": [1, 3, 5],
    "phyllotaxis_like": [1, 2],
}

# examples/cpfg/NAME.l with --cpfg-view examples/cpfg/NAME.v (turtle
# queries): steps.
EXAMPLES = {
    "clipped": [22],
}


def main(argv):
    check = "--check" in argv
    outdir = os.path.join(ROOT, "tests", "expected", "cpfg")
    os.makedirs(os.path.join(outdir, "abop"), exist_ok=True)
    rows = []
    bad = 0
    jobs = []
    for name in sorted(MANIFEST):
        src = "tests/cpfg/%s.l" % name
        has_homo = quiet(cpfg_ref.load, os.path.join(ROOT, src))[0].homo
        for n in MANIFEST[name]:
            jobs.append((src, n, True, "%s.n%d.txt" % (name, n)))
            if has_homo:
                jobs.append((src, n, False, "%s.n%d.nohomo.txt" % (name, n)))
    # The func models, each with its view file (--functions).
    os.makedirs(os.path.join(outdir, "func"), exist_ok=True)
    for name, ns in sorted(FUNC.items()):
        for n in ns:
            jobs.append(("tests/cpfg/func/%s.l" % name, n, True, "func/%s.n%d.txt" % (name, n),
                         "tests/cpfg/func/%s.v" % name))
    # The cpfg examples with queries, each with its view file (--cpfg-view).
    os.makedirs(os.path.join(outdir, "examples"), exist_ok=True)
    for name, ns in sorted(EXAMPLES.items()):
        for n in ns:
            jobs.append(("examples/cpfg/%s.l" % name, n, True, "examples/%s.n%d.txt" % (name, n),
                         None, "examples/cpfg/%s.v" % name))
    twins = sorted(f[:-2] for f in os.listdir(os.path.join(ROOT, "tests", "cpfg", "abop")) if f.endswith(".l"))
    for name in twins:
        for n in gen_expected.MANIFEST[name]:
            jobs.append(("tests/cpfg/abop/%s.l" % name, n, True, "abop/%s.n%d.txt" % (name, n)))
            want = ref.run_file(os.path.join(ROOT, "examples", name + ".ls"), n)
            got = quiet(cpfg_ref.run_file, os.path.join(ROOT, "tests/cpfg/abop/%s.l" % name), n)
            if not same_string(got, want):
                print("twin differs: %s n=%d" % (name, n))
                bad += 1
    for name in sorted(TWIN_SKIP):
        if name in twins:
            print("twin should be skipped: %s" % name)
            bad += 1
    for (name, n), want in sorted(HAND.items()):
        got = quiet(cpfg_ref.run_file, os.path.join(ROOT, "tests", "cpfg", name + ".l"), n)
        if got != want:
            print("differs from the hand derivation: %s n=%d: %s" % (name, n, got))
            bad += 1
    refused = os.path.join(ROOT, "tests", "cpfg", "refused")
    for f in sorted(os.listdir(refused)):
        try:
            quiet(cpfg_ref.run_file, os.path.join(refused, f))
        except cpfg_ref.CpfgError as e:
            if not e.where:
                print("refused without a location: %s" % f)
                bad += 1
            continue
        print("not refused: tests/cpfg/refused/%s" % f)
        bad += 1
    for job in jobs:
        src, n, homo, fname = job[:4]
        view = job[4] if len(job) > 4 else None
        cpfg_view = job[5] if len(job) > 5 else None
        functions = [os.path.join(ROOT, view)] if view else []
        turtle = os.path.join(ROOT, cpfg_view) if cpfg_view else None
        text = quiet(lambda: cpfg_ref.run_file(os.path.join(ROOT, src), n, homo, functions,
                                               view=turtle)) + "\n"
        path = os.path.join(outdir, fname)
        cmd = "python3 tests/tools/cpfg_ref.py %s -n %d%s%s%s > tests/expected/cpfg/%s" % (
            src, n, "" if homo else " --no-homomorphism",
            " --functions %s" % view if view else "",
            " --cpfg-view %s" % cpfg_view if cpfg_view else "", fname)
        rows.append("| `%s` | %d | `%s` |\n" % (fname, len(text), cmd))
        if check:
            try:
                with open(path, encoding="utf-8") as f:
                    old = f.read()
            except FileNotFoundError:
                old = None
            if old != text:
                print("differs: %s" % fname)
                bad += 1
        else:
            with open(path, "w", encoding="utf-8", newline="\n") as f:
                f.write(text)
    readme = README_HEAD + "".join(rows)
    readme_path = os.path.join(outdir, "README.md")
    if check:
        try:
            with open(readme_path, encoding="utf-8") as f:
                if f.read() != readme:
                    print("differs: README.md")
                    bad += 1
        except FileNotFoundError:
            print("missing: README.md")
            bad += 1
        print("%d expected files checked, %d problems" % (len(rows), bad))
        return 1 if bad else 0
    with open(readme_path, "w", encoding="utf-8", newline="\n") as f:
        f.write(readme)
    print("wrote %d expected files and README.md; %d twin problems" % (len(rows), bad))
    return 1 if bad else 0


README_HEAD = """\
# Expected outputs for the cpfg dialect

Produced by `tests/tools/cpfg_ref.py`, an independent Python reference for
cpfg `.l` files (it shares no code with lsgen).  See `tests/cpfg/README.md`
for what each model tests and what is uncertain.  Regenerate everything with

    python3 tests/tools/gen_expected_cpfg.py

or check with `--check`.  That script also checks strings derived by hand,
that every `tests/cpfg/refused/*.l` is refused with a located error, and
that every ABOP twin `tests/cpfg/abop/NAME.l` gives the same string as
`examples/NAME.ls` under `tests/tools/ref.py`.

- `NAME.nN.txt`: `tests/cpfg/NAME.l` after N steps, the homomorphism
  applied; one line, parameters printed with `%g`.
- `NAME.nN.nohomo.txt`: the same without the homomorphism (the derived
  string cpfg saves).
- `abop/NAME.nN.txt`: the twin `tests/cpfg/abop/NAME.l` after N steps.

| file | bytes | command |
| --- | --- | --- |
"""

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
