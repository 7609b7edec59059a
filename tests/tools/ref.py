#!/usr/bin/env python3
"""Independent reference rewriter for lsgen's .ls language.

This is a deliberately simple, in-memory implementation written from the
language description (not from lsgen's Rust sources).  It is used to generate
the expected outputs in tests/expected/, so that those strings do not come
from the code under test.

Supported: settings (derivation length, define, seed, ignore, consider),
productions with left/right contexts (bracketed, ABOP/cpfg style),
parameters, conditions, homomorphism, and comments.  Stochastic productions
are parsed, but deriving with them is refused (the reference has no RNG that
matches lsgen's), except for n = 0.

Also the structural features of docs/structural.md (issue 11): production
groups (`productions N:`, `groups:` / `group:`), the built-in `step`,
decomposition (`decomposition:`, `maximum depth:`), homomorphism depth, and
the cut `%`.  `python3 tests/tools/ref.py --self-test` checks them against
hand-derived strings.

Usage:
    python3 tests/tools/ref.py FILE.ls [-n STEPS]
    python3 tests/tools/ref.py --self-test

Prints the final string on one line.  Without -n the file's
`derivation length:` is used (0 if absent).  The homomorphism, if any, is
applied once to the result.
"""

import argparse
import math
import re
import sys

# ---------------------------------------------------------------------------
# Number formatting (mimics Rust's `ryu` crate, minus the trailing ".0")
# ---------------------------------------------------------------------------


def _shortest_digits(x):
    """Return (digits, exponent) with x == int(digits) * 10**exponent, where
    digits is the shortest decimal string that round-trips x (x > 0, finite).
    Python's repr() produces the shortest round-tripping representation."""
    r = repr(x)
    if "e" in r:
        mant, e = r.split("e")
        exp = int(e)
    else:
        mant, exp = r, 0
    if "." in mant:
        ip, fp = mant.split(".")
    else:
        ip, fp = mant, ""
    exp -= len(fp)
    digits = (ip + fp).lstrip("0")
    stripped = digits.rstrip("0")
    exp += len(digits) - len(stripped)
    return stripped, exp


def fmt_num(x):
    """Format a float like ryu::Buffer::format_finite, dropping a trailing
    '.0': 2, 0.5, -3, 0.00001, 1e-7, 1.5e-6, 1e16, 1.2345e20, -0."""
    if math.isnan(x) or math.isinf(x):
        raise ValueError("non-finite parameter value: %r" % x)
    if x == 0.0:
        return "-0" if math.copysign(1.0, x) < 0 else "0"
    sign = "-" if x < 0 else ""
    digits, exp = _shortest_digits(abs(x))
    length = len(digits)
    kk = length + exp  # 10^(kk-1) <= |x| < 10^kk
    if 0 <= exp and kk <= 16:
        s = digits + "0" * exp
    elif 0 < kk <= 16:
        s = digits[:kk] + "." + digits[kk:]
    elif -5 < kk <= 0:
        s = "0." + "0" * (-kk) + digits
    elif length == 1:
        s = digits + "e" + str(kk - 1)
    else:
        s = digits[0] + "." + digits[1:] + "e" + str(kk - 1)
    return sign + s


# ---------------------------------------------------------------------------
# Expressions
# ---------------------------------------------------------------------------


class LsError(Exception):
    pass


def _no_random():
    raise LsError("ran/nran are not supported by ref.py")


def _deg_fn(f):
    return lambda x: f(math.radians(x))


FUNCTIONS = {
    "sin": (1, _deg_fn(math.sin)),
    "cos": (1, _deg_fn(math.cos)),
    "tan": (1, _deg_fn(math.tan)),
    "sqrt": (1, math.sqrt),
    "exp": (1, math.exp),
    "log": (1, math.log),
    "floor": (1, lambda x: float(math.floor(x))),
    "ceil": (1, lambda x: float(math.ceil(x))),
    "trunc": (1, lambda x: float(math.trunc(x))),
    "abs": (1, abs),
    "min": (2, min),
    "max": (2, max),
    "atan2": (2, lambda y, x: math.degrees(math.atan2(y, x))),
    "ran": (1, lambda x: _no_random()),
    "nran": (2, lambda m, sd: _no_random()),
}


def _tokenize_expr(text):
    toks = []
    i = 0
    n = len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
            continue
        if c.isdigit() or (c == "." and i + 1 < n and text[i + 1].isdigit()):
            j = i
            while j < n and (text[j].isdigit() or text[j] == "."):
                j += 1
            if j < n and text[j] in "eE":
                k = j + 1
                if k < n and text[k] in "+-":
                    k += 1
                if k < n and text[k].isdigit():
                    j = k
                    while j < n and text[j].isdigit():
                        j += 1
            toks.append(("num", float(text[i:j])))
            i = j
            continue
        if c.isalpha() or c == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            toks.append(("name", text[i:j]))
            i = j
            continue
        two = text[i : i + 2]
        if two in ("<=", ">=", "==", "!=", "&&", "||"):
            toks.append(("op", two))
            i += 2
            continue
        if c in "+-*/^%<>!(),":
            toks.append(("op", c))
            i += 1
            continue
        raise LsError("bad character %r in expression %r" % (c, text))
    toks.append(("end", None))
    return toks


class _ExprParser:
    """Precedence, lowest first: || ; && ; == != ; < <= > >= ; + - ;
    * / % ; unary - + ! ; ^ (right associative, so -2^2 == -4)."""

    def __init__(self, text):
        self.text = text
        self.toks = _tokenize_expr(text)
        self.pos = 0

    def peek(self):
        return self.toks[self.pos]

    def take(self):
        t = self.toks[self.pos]
        self.pos += 1
        return t

    def expect(self, op):
        t = self.take()
        if t != ("op", op):
            raise LsError("expected %r in expression %r" % (op, self.text))

    def parse(self):
        e = self.parse_or()
        if self.peek()[0] != "end":
            raise LsError("trailing input in expression %r" % self.text)
        return e

    def _binary(self, ops, sub):
        left = sub()
        while self.peek()[0] == "op" and self.peek()[1] in ops:
            op = self.take()[1]
            right = sub()
            left = ("bin", op, left, right)
        return left

    def parse_or(self):
        return self._binary(("||",), self.parse_and)

    def parse_and(self):
        return self._binary(("&&",), self.parse_eq)

    def parse_eq(self):
        return self._binary(("==", "!="), self.parse_rel)

    def parse_rel(self):
        return self._binary(("<", "<=", ">", ">="), self.parse_add)

    def parse_add(self):
        return self._binary(("+", "-"), self.parse_mul)

    def parse_mul(self):
        return self._binary(("*", "/", "%"), self.parse_unary)

    def parse_unary(self):
        t = self.peek()
        if t[0] == "op" and t[1] in ("-", "+", "!"):
            self.take()
            return ("un", t[1], self.parse_unary())
        return self.parse_pow()

    def parse_pow(self):
        base = self.parse_atom()
        if self.peek() == ("op", "^"):
            self.take()
            exp = self.parse_unary()  # right associative; allows 2^-1
            return ("bin", "^", base, exp)
        return base

    def parse_atom(self):
        t = self.take()
        if t[0] == "num":
            return ("num", t[1])
        if t[0] == "name":
            if self.peek() == ("op", "("):
                self.take()
                args = []
                if self.peek() != ("op", ")"):
                    args.append(self.parse_or())
                    while self.peek() == ("op", ","):
                        self.take()
                        args.append(self.parse_or())
                self.expect(")")
                if t[1] not in FUNCTIONS:
                    raise LsError("unknown function %r" % t[1])
                arity = FUNCTIONS[t[1]][0]
                if len(args) != arity:
                    raise LsError("%s takes %d argument(s)" % (t[1], arity))
                return ("call", t[1], args)
            return ("var", t[1])
        if t == ("op", "("):
            e = self.parse_or()
            self.expect(")")
            return e
        raise LsError("unexpected token %r in expression %r" % (t, self.text))


def parse_expr(text):
    return _ExprParser(text).parse()


def _truth(b):
    return 1.0 if b else 0.0


def eval_expr(e, env):
    kind = e[0]
    if kind == "num":
        return e[1]
    if kind == "var":
        try:
            return env[e[1]]
        except KeyError:
            raise LsError("unknown name %r" % e[1])
    if kind == "un":
        v = eval_expr(e[2], env)
        if e[1] == "-":
            return -v
        if e[1] == "+":
            return v
        return _truth(v == 0.0)
    if kind == "call":
        return float(FUNCTIONS[e[1]][1](*[eval_expr(a, env) for a in e[2]]))
    op = e[1]
    if op == "&&":
        return _truth(eval_expr(e[2], env) != 0.0 and eval_expr(e[3], env) != 0.0)
    if op == "||":
        return _truth(eval_expr(e[2], env) != 0.0 or eval_expr(e[3], env) != 0.0)
    a = eval_expr(e[2], env)
    b = eval_expr(e[3], env)
    if op == "+":
        return a + b
    if op == "-":
        return a - b
    if op == "*":
        return a * b
    if op == "/":
        if b == 0.0:
            raise LsError("division by zero")
        return a / b
    if op == "%":
        return math.fmod(a, b)
    if op == "^":
        return math.pow(a, b)
    if op == "<":
        return _truth(a < b)
    if op == "<=":
        return _truth(a <= b)
    if op == ">":
        return _truth(a > b)
    if op == ">=":
        return _truth(a >= b)
    if op == "==":
        return _truth(a == b)
    if op == "!=":
        return _truth(a != b)
    raise LsError("bad operator %r" % op)


# ---------------------------------------------------------------------------
# Modules and module lists
# ---------------------------------------------------------------------------

NOT_SYMBOLS = set("(),:<>")


def _split_top(text, sep):
    """Split text at sep characters that are not inside parentheses."""
    parts, depth, cur = [], 0, []
    for c in text:
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        if c == sep and depth == 0:
            parts.append("".join(cur))
            cur = []
        else:
            cur.append(c)
    parts.append("".join(cur))
    return parts


def parse_module_list(text):
    """Parse 'F(1,x+2)[+F]' into [(sym, [arg_text, ...]), ...]."""
    out = []
    i = 0
    n = len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
            continue
        if c in NOT_SYMBOLS:
            raise LsError("unexpected %r in module list %r" % (c, text))
        i += 1
        j = i
        while j < n and text[j].isspace():
            j += 1
        args = []
        if j < n and text[j] == "(":
            depth = 0
            k = j
            while k < n:
                if text[k] == "(":
                    depth += 1
                elif text[k] == ")":
                    depth -= 1
                    if depth == 0:
                        break
                k += 1
            if k >= n:
                raise LsError("unbalanced parentheses in %r" % text)
            inner = text[j + 1 : k]
            args = [a.strip() for a in _split_top(inner, ",")]
            if any(a == "" for a in args):
                raise LsError("empty parameter in %r" % text)
            i = k + 1
        out.append((c, args))
    return out


# ---------------------------------------------------------------------------
# .ls file parsing
# ---------------------------------------------------------------------------


class Production:
    def __init__(self, lc, pred, rc, cond, succ, prob, text):
        self.lc = lc  # list of (sym, [names]) or None
        self.pred = pred  # (sym, [names])
        self.rc = rc  # list of (sym, [names]) or None
        self.cond = cond  # expression AST or None
        self.succ = succ  # list of (sym, [expr ASTs])
        self.prob = prob  # float or None
        self.text = text

    @property
    def has_context(self):
        return self.lc is not None or self.rc is not None


class LSystem:
    def __init__(self):
        self.derivation_length = 0
        self.defines = {}
        self.seed = None
        self.ignore = None
        self.consider = None
        self.productions = []  # group 0
        self.groups = {0: self.productions}  # group number -> productions
        self.schedule = None  # list of group numbers (`groups:`)
        self.group_expr = None  # expression AST (`group:`)
        self.decomposition = None  # list of productions, or None
        self.decomposition_depth = 1
        self.homomorphism = []
        self.homomorphism_depth = 1
        self.homomorphism_seed = None
        self.axiom = []


def _strip_comments(text):
    out = []
    i = 0
    while True:
        j = text.find("/*", i)
        if j < 0:
            out.append(text[i:])
            break
        k = text.find("*/", j + 2)
        if k < 0:
            raise LsError("unterminated comment")
        out.append(text[i:j])
        # keep line structure
        out.append("\n" * text.count("\n", j, k + 2))
        i = k + 2
    return "".join(out)


def _find_arrow(line):
    depth = 0
    for i in range(len(line) - 1):
        c = line[i]
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        elif depth == 0 and line[i : i + 2] == "->":
            return i
    return -1


def _pattern(text):
    mods = parse_module_list(text)
    for sym, args in mods:
        for a in args:
            if not (a.replace("_", "a").isalnum() and not a[0].isdigit()):
                raise LsError("formal parameter must be a name: %r" % a)
    return mods


def parse_production(line):
    arrow = _find_arrow(line)
    if arrow < 0:
        raise LsError("production without '->': %r" % line)
    lhs, rhs = line[:arrow], line[arrow + 2 :]
    lhs_parts = _split_top(lhs, ":")
    if len(lhs_parts) > 2:
        raise LsError("too many ':' in %r" % line)
    strict = lhs_parts[0]
    cond = parse_expr(lhs_parts[1]) if len(lhs_parts) == 2 else None
    lc = rc = None
    if "<" in strict:
        lc_text, strict = strict.split("<", 1)
        lc = _pattern(lc_text)
        if any(s in "[]" for s, _ in lc):
            raise LsError("brackets in a left context are not supported: %r" % line)
    if ">" in strict:
        strict, rc_text = strict.split(">", 1)
        rc = _pattern(rc_text)
    pred = _pattern(strict)
    if len(pred) != 1:
        raise LsError("predecessor must be one module: %r" % line)
    rhs_parts = _split_top(rhs, ":")
    if len(rhs_parts) > 2:
        raise LsError("too many ':' in %r" % line)
    prob = float(rhs_parts[1]) if len(rhs_parts) == 2 else None
    succ = [(s, [parse_expr(a) for a in args]) for s, args in parse_module_list(rhs_parts[0])]
    return Production(lc, pred[0], rc, cond, succ, prob, line.strip())


_MAX_DEPTH = 10000
_MAX_GROUP = 65535


def _whole(text, lo, hi, what):
    t = text.strip()
    if not t.isdigit() or not lo <= int(t) <= hi:
        raise LsError("%s must be a whole number from %d to %d: %r" % (what, lo, hi, t))
    return int(t)


def _uses_random(e):
    if e[0] == "call":
        return e[1] in ("ran", "nran") or any(_uses_random(a) for a in e[2])
    if e[0] == "un":
        return _uses_random(e[2])
    if e[0] == "bin":
        return _uses_random(e[2]) or _uses_random(e[3])
    return False


_SECTION = re.compile(r"^(productions|decomposition|homomorphism)(?:\s+([^:\s][^:]*?))?\s*:\s*(.*)$")
_VIEW_LINE = re.compile(r"^view\s*:")
# Blanks (and comments, already blanked) may stand before a keyword's `:`.
_AXIOM_LINE = re.compile(r"^axiom\s*:")
_SETTING_IN_SECTION = re.compile(r"^(maximum\s+depth|seed)\s*:(.*)$")


def parse_ls(text):
    ls = LSystem()
    text = _strip_comments(text)
    lines = text.split("\n")
    section = "settings"
    current = None  # production list being filled
    in_head = False  # right after a decomposition/homomorphism keyword
    head_seen = set()
    seen = set()  # section names seen
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        i += 1
        if not line:
            continue
        low = line.lower()
        if _VIEW_LINE.match(low):
            # lsgen-turtle's view settings: lsgen checks and skips them on
            # any header line (README, "View settings"); so does this.
            continue
        m = _SECTION.match(low)
        if m and not (m.group(1) == "productions" and m.group(3)):
            name, num, rest = m.group(1), m.group(2), m.group(3).strip()
            if name == "productions":
                if "decomposition" in seen or "homomorphism" in seen:
                    raise LsError("productions after decomposition/homomorphism: %r" % line)
                g = 0 if num is None else _whole(num, 0, _MAX_GROUP, "a production group")
                if g != 0 and g not in ls.groups:
                    ls.groups[g] = []
                elif ("productions", g) in seen:
                    raise LsError("group %d is declared twice" % g)
                seen.add(("productions", g))
                section, current, in_head = "productions", ls.groups[g], False
                continue
            if num is not None:
                raise LsError("%s has no groups" % name)
            if rest not in ("", "warnings", "no warnings"):
                raise LsError("expected `warnings` or `no warnings` after %s:" % name)
            if name in seen:
                raise LsError("second `%s:` section" % name)
            if name == "decomposition" and "homomorphism" in seen:
                raise LsError("`decomposition:` comes before `homomorphism:`")
            seen.add(name)
            if name == "decomposition":
                ls.decomposition = []
                current = ls.decomposition
            else:
                current = ls.homomorphism
            section, in_head, head_seen = name, True, set()
            continue
        ax = _AXIOM_LINE.match(low)
        if ax:
            rest = line[ax.end() :] + "\n" + "\n".join(lines[i:])
            env = dict(ls.defines)
            ls.axiom = [
                (s, tuple(eval_expr(parse_expr(a), env) for a in args))
                for s, args in parse_module_list(rest)
            ]
            _check_groups(ls)
            return ls
        hm = _SETTING_IN_SECTION.match(low)
        if hm and section in ("decomposition", "homomorphism"):
            key = " ".join(hm.group(1).split())
            if not in_head or key in head_seen:
                raise LsError("`%s:` comes once, right after the section keyword" % key)
            head_seen.add(key)
            value = line[line.index(":") + 1 :]
            if key == "maximum depth":
                depth = _whole(value, 1, _MAX_DEPTH, "maximum depth")
                if section == "decomposition":
                    ls.decomposition_depth = depth
                else:
                    ls.homomorphism_depth = depth
            elif section == "decomposition":
                raise LsError("decomposition uses the main random generator: no `seed:` here")
            else:
                ls.homomorphism_seed = _whole(value, 0, 2**53, "seed")
            continue
        if section == "settings":
            key, sep, value = line.partition(":")
            if not sep:
                raise LsError("bad setting line %r" % line)
            key = " ".join(key.lower().split())
            value = value.strip()
            if key == "derivation length":
                ls.derivation_length = int(value)
            elif key == "define":
                name, eq, expr = value.partition("=")
                if not eq:
                    raise LsError("bad define %r" % line)
                ls.defines[name.strip()] = eval_expr(parse_expr(expr), ls.defines)
            elif key == "seed":
                ls.seed = int(value)
            elif key == "ignore":
                ls.ignore = set(value.replace(" ", ""))
            elif key == "consider":
                ls.consider = set(value.replace(" ", ""))
            elif key in ("groups", "group"):
                if ls.schedule is not None or ls.group_expr is not None:
                    raise LsError("use either `groups:` or `group:`, not both")
                if key == "groups":
                    nums = value.split()
                    if not nums or not all(x.isdigit() for x in nums):
                        raise LsError("`groups:` takes whole group numbers separated by blanks")
                    ls.schedule = [int(x) for x in nums]
                else:
                    ls.group_expr = parse_expr(value)
                    if _uses_random(ls.group_expr):
                        raise LsError("`group:` cannot use ran or nran")
            elif key == "maximum depth":
                raise LsError("`maximum depth:` belongs to `decomposition:` or `homomorphism:`")
            else:
                raise LsError("unknown setting %r" % key)
        else:
            if _SETTING_IN_SECTION.match(low) and section == "productions":
                raise LsError("`maximum depth:` belongs to `decomposition:` or `homomorphism:`")
            p = parse_production(line)
            if section == "decomposition" and p.has_context:
                raise LsError("a decomposition production has no context: %r" % line)
            in_head = False
            current.append(p)
    raise LsError("missing 'axiom:'")


def _check_groups(ls):
    for g in ls.schedule or []:
        if g not in ls.groups:
            raise LsError("unknown group %d: there is no `productions %d:` section" % (g, g))
    if ls.schedule is None and ls.group_expr is None:
        for g in sorted(ls.groups):
            if g != 0:
                raise LsError("group %d is never used: add a `groups:` or `group:` setting" % g)


# ---------------------------------------------------------------------------
# Rewriting
# ---------------------------------------------------------------------------


class Rewriter:
    def __init__(self, ls):
        self.ls = ls

    def skipped(self, sym):
        """Symbols that context matching steps over (brackets never are)."""
        if sym in "[]":
            return False
        if self.ls.consider is not None:
            return sym not in self.ls.consider
        if self.ls.ignore is not None:
            return sym in self.ls.ignore
        return False

    @staticmethod
    def bracket_map(s):
        match = [-1] * len(s)
        stack = []
        for i, (sym, _) in enumerate(s):
            if sym == "[":
                stack.append(i)
            elif sym == "]":
                if stack:
                    j = stack.pop()
                    match[i] = j
                    match[j] = i
        return match

    @staticmethod
    def bind(pat, mod, env):
        psym, names = pat
        sym, vals = mod
        if psym != sym or len(names) != len(vals):
            return False
        for name, v in zip(names, vals):
            env[name] = v
        return True

    # Left context: walk left from i-1, matching the pattern from its end.
    def match_left(self, s, match, i, lc, env):
        pos = i - 1
        for pat in reversed(lc):
            while True:
                if pos < 0:
                    return False
                sym = s[pos][0]
                if sym == "[":
                    pos -= 1  # the branch's parent is the left neighbour
                elif sym == "]":
                    if match[pos] < 0:
                        return False
                    pos = match[pos] - 1  # skip a whole branch
                elif self.skipped(sym):
                    pos -= 1
                else:
                    break
            if not self.bind(pat, s[pos], env):
                return False
            pos -= 1
        return True

    # Right context: recursive, so that '[' can try several sibling branches.
    def match_right(self, s, match, pos, rc, j, env):
        if j == len(rc):
            return True
        pat = rc[j]
        n = len(s)
        if pat[0] == "[":
            while pos < n and self.skipped(s[pos][0]):
                pos += 1
            while pos < n and s[pos][0] == "[":
                trial = dict(env)
                if self.match_right(s, match, pos + 1, rc, j + 1, trial):
                    env.update(trial)
                    return True
                if match[pos] < 0:
                    return False
                pos = match[pos] + 1
                while pos < n and self.skipped(s[pos][0]):
                    pos += 1
            return False
        if pat[0] == "]":
            # skip the rest of the current branch
            while pos < n:
                sym = s[pos][0]
                if sym == "[":
                    if match[pos] < 0:
                        return False
                    pos = match[pos] + 1
                elif sym == "]":
                    return self.match_right(s, match, pos + 1, rc, j + 1, env)
                else:
                    pos += 1
            return False
        while True:
            if pos >= n:
                return False
            sym = s[pos][0]
            if sym == "[":
                if match[pos] < 0:
                    return False
                pos = match[pos] + 1  # a branch the pattern does not ask for
            elif sym == "]":
                return False  # end of the branch: no right neighbour
            elif self.skipped(sym):
                pos += 1
            else:
                break
        if not self.bind(pat, s[pos], env):
            return False
        return self.match_right(s, match, pos + 1, rc, j + 1, env)

    def env(self, step):
        """Names every expression sees: the built-in `step`, hidden by a
        `define:` constant of that name (and, in a production, by a formal
        parameter of that name, bound later)."""
        env = {"step": float(step)}
        env.update(self.ls.defines)
        return env

    def try_production(self, p, s, match, i, base, mod=None):
        """Does p apply to `mod` (default s[i]), with contexts taken around
        position i of s? The successor if so."""
        env = dict(base)
        if p.lc is not None and not self.match_left(s, match, i, p.lc, env):
            return None
        if not self.bind(p.pred, s[i] if mod is None else mod, env):
            return None
        if p.rc is not None and not self.match_right(s, match, i + 1, p.rc, 0, env):
            return None
        if p.cond is not None and eval_expr(p.cond, env) == 0.0:
            return None
        return [(sym, tuple(eval_expr(a, env) for a in args)) for sym, args in p.succ]

    def choose(self, prods, s, match, i, base, mod=None):
        """The successor the first applicable production gives (context
        productions first), or None."""
        if any(p.prob is not None for p in prods):
            raise LsError("stochastic productions are not supported by ref.py")
        sym = (s[i] if mod is None else mod)[0]
        for group in ([p for p in prods if p.has_context], [p for p in prods if not p.has_context]):
            for p in group:
                if p.pred[0] != sym:
                    continue
                result = self.try_production(p, s, match, i, base, mod)
                if result is not None:
                    return result
        return None

    def rewrite(self, s, prods):
        """One pass of prods over s, without cut or decomposition (kept for
        check_ref.py and callers of the old interface)."""
        match = self.bracket_map(s)
        base = self.env(0)
        out = []
        for i, mod in enumerate(s):
            result = self.choose(prods, s, match, i, base)
            out.extend([mod] if result is None else result)
        return out

    def group_for(self, k):
        ls = self.ls
        if ls.schedule is not None:
            return ls.schedule[(k - 1) % len(ls.schedule)]
        if ls.group_expr is not None:
            v = eval_expr(ls.group_expr, self.env(k))
            if v != math.floor(v) or int(v) not in ls.groups:
                raise LsError("group: gives %s in step %d, not a declared group" % (fmt_num(v), k))
            return int(v)
        return 0

    def decompose(self, mod, depth, base):
        """mod (of depth `depth`) after decomposition, depth first."""
        prods = self.ls.decomposition
        if not prods or depth >= self.ls.decomposition_depth:
            return [mod]
        result = self.choose(prods, [mod], None, 0, base)
        if result is None:
            return [mod]
        out = []
        for m in result:
            out.extend(self.decompose(m, depth + 1, base))
        return out

    @staticmethod
    def cut_end(s, i):
        """Index of the closest unmatched ']' after i, or len(s)."""
        depth = 0
        j = i + 1
        while j < len(s):
            if s[j][0] == "[":
                depth += 1
            elif s[j][0] == "]":
                if depth == 0:
                    return j
                depth -= 1
            j += 1
        return j

    def step(self, s, k):
        """Derivation step k (1-based): the step's group with fallback to
        group 0, the cut, and decomposition of every result."""
        g = self.group_for(k)
        base = self.env(k)
        match = self.bracket_map(s)
        out = []
        i = 0
        while i < len(s):
            mod = s[i]
            result = self.choose(self.ls.groups[g], s, match, i, base)
            if result is None and g != 0:
                result = self.choose(self.ls.groups[0], s, match, i, base)
            if result is None:
                if mod == ("%", ()) and (
                    not self.ls.decomposition
                    or self.choose(self.ls.decomposition, [mod], None, 0, base) is None
                ):
                    i = self.cut_end(s, i)
                    continue
                result = [mod]
            for m in result:
                out.extend(self.decompose(m, 0, base))
            i += 1
        return out

    def homomorphism(self, s, n):
        """The homomorphism, recursively up to its maximum depth; contexts
        always in s around the original module."""
        match = self.bracket_map(s)
        base = self.env(n)
        out = []

        def expand(mod, i, depth):
            if depth >= self.ls.homomorphism_depth:
                out.append(mod)
                return
            result = self.choose(self.ls.homomorphism, s, match, i, base, mod)
            if result is None:
                out.append(mod)
                return
            for m in result:
                expand(m, i, depth + 1)

        for i, mod in enumerate(s):
            expand(mod, i, 0)
        return out

    def derive(self, n, homomorphism=True):
        s = list(self.ls.axiom)
        for k in range(1, n + 1):
            s = self.step(s, k)
        if self.ls.homomorphism and homomorphism:
            s = self.homomorphism(s, n)
        return s


def format_string(s):
    parts = []
    for sym, vals in s:
        if vals:
            parts.append(sym + "(" + ",".join(fmt_num(v) for v in vals) + ")")
        else:
            parts.append(sym)
    return "".join(parts)


def run_file(path, n=None):
    with open(path, encoding="utf-8") as f:
        ls = parse_ls(f.read())
    if n is None:
        n = ls.derivation_length
    return format_string(Rewriter(ls).derive(n))


# ---------------------------------------------------------------------------
# Self-test of the structural features (docs/structural.md), hand-derived
# ---------------------------------------------------------------------------

# (label, .ls text, steps, expected string)
SELF_TESTS = [
    # Groups: the list cycles; a module with nothing in the step's group
    # falls back to group 0 (here: nothing there either for B in group 1).
    ("groups cycle", "groups: 1 1 2\nproductions:\nA -> A\nproductions 1:\nA -> AB\n"
     "productions 2:\nA -> A[+B]\nB -> BB\naxiom: A\n", 1, "AB"),
    ("groups cycle 2", None, 2, "ABB"),
    ("groups cycle 3", None, 3, "A[+B]BBBB"),
    ("groups cycle 4", None, 4, "AB[+B]BBBB"),
    ("groups fallback", "groups: 1\nproductions:\nA -> X\nB -> Y\nproductions 1:\nA -> Z\n"
     "axiom: AB\n", 1, "ZY"),
    ("groups fallback on a failed condition", "groups: 1\nproductions:\nA(x) -> A(x+1)\n"
     "productions 1:\nA(x) : x > 1 -> Z(x)\naxiom: A(0)A(2)\n", 2, "A(2)Z(2)"),
    ("group expression", "group: 1 + (step > 2)\nproductions 1:\nA -> AB\n"
     "productions 2:\nA -> AC\naxiom: A\n", 3, "ACBB"),
    ("productions 0 is group 0", "productions 0:\nA -> AB\naxiom: A\n", 2, "ABB"),
    # The step number.
    ("step", "productions:\nA(x) -> A(x+step)\naxiom: A(0)\n", 3, "A(6)"),
    ("step in a condition", "productions:\nB : step == 2 -> C\naxiom: BB\n", 2, "CC"),
    ("step in a condition, other step", None, 1, "BB"),
    ("a constant hides step", "define: step = 10\nproductions:\nA(x) -> A(x+step)\n"
     "axiom: A(0)\n", 2, "A(20)"),
    ("a formal parameter hides step", "productions:\nA(step) -> A(step*2)\naxiom: A(3)\n",
     2, "A(12)"),
    ("step in the homomorphism is n", "productions:\nA(x) -> A(x+step)\nhomomorphism:\n"
     "A(x) -> B(x,step)\naxiom: A(0)\n", 2, "B(3,2)"),
    ("step in the homomorphism, n = 0", None, 0, "B(0,0)"),
    # Decomposition: not applied to the axiom; after every step, on
    # rewritten and copied modules alike.
    ("decomposition, axiom untouched", "productions:\nA -> IA\ndecomposition:\nI -> FF\n"
     "axiom: IA\n", 0, "IA"),
    ("decomposition step 1", None, 1, "FFFFA"),
    ("decomposition step 2", None, 2, "FFFFFFA"),
    ("decomposition depth 1", "productions:\nA -> LA\ndecomposition:\nL -> [+P][-P]\n"
     "P -> [F]\naxiom: A\n", 1, "[+P][-P]A"),
    ("decomposition depth 1, next step", None, 2, "[+[F]][-[F]][+P][-P]A"),
    ("decomposition depth 2", "productions:\nA -> LA\ndecomposition:\nmaximum depth: 2\n"
     "L -> [+P][-P]\nP -> [F]\naxiom: A\n", 1, "[+[F]][-[F]]A"),
    ("decomposition limit", "productions:\nZ -> X\ndecomposition: warnings\n"
     "maximum depth: 3\nX -> XY\naxiom: Z\n", 1, "XYYY"),
    # step 1 keeps L (step > 1 fails); in step 2 the new L and the copied
    # old L are both decomposed.
    ("decomposition with step, step 1", "productions:\nA -> AL\ndecomposition:\n"
     "L : step > 1 -> F(step)\naxiom: A\n", 1, "AL"),
    ("decomposition with step, step 2", None, 2, "AF(2)F(2)"),
    # Cut.
    ("cut: manual 6.4, step 1", "productions:\nD(a) : a < 20 -> D(a+1)\n"
     "D(a) : a >= 20 -> %\naxiom: A[+D(19)F]B\n", 1, "A[+D(20)F]B"),
    ("cut: % produced in step 2", None, 2, "A[+%F]B"),
    ("cut: % cuts in step 3", None, 3, "A[+]B"),
    ("cut at top level", "axiom: AB%C[D]E\n", 1, "AB"),
    ("cut in a branch", "axiom: A[B%C[D]E]F\n", 1, "A[B]F"),
    ("cut: n = 0 cuts nothing", "axiom: A[B%C[D]E]F\n", 0, "A[B%C[D]E]F"),
    ("a rewritten % is no cut", "productions:\n% -> X\naxiom: A%B\n", 1, "AXB"),
    ("%(x) is no cut", "axiom: A%(1)B\n", 1, "A%(1)B"),
    ("contexts see the cut part", "productions:\nB > %C -> Y\naxiom: AB%C\n", 1, "AY"),
    ("cut modules are not evaluated", "productions:\nC(x) -> D(1/x)\naxiom: %C(0)\n", 1, ""),
    ("decomposition of % prevents the cut", "decomposition:\n% -> G\naxiom: A%B\n", 1, "AGB"),
    ("% from decomposition cuts next step", "productions:\nA -> K\ndecomposition:\nK -> %\n"
     "axiom: [AE]B\n", 1, "[%E]B"),
    ("% from decomposition cuts next step 2", None, 2, "[]B"),
    ("the homomorphism never cuts", "homomorphism:\nA -> F\nB -> %C\naxiom: A%B\n", 0, "F%%C"),
    # Homomorphism depth; contexts in the original string (manual 4.3.2).
    ("homomorphism depth 2", "homomorphism:\nmaximum depth: 2\nF -> G P(0,0)\n"
     "G > P(x,y) : y > 3 -> f\naxiom: F P(1,5) F P(1,2)\n", 0, "fP(0,0)P(1,5)GP(0,0)P(1,2)"),
    ("homomorphism depth 1", "homomorphism:\nF -> G P(0,0)\nG > P(x,y) : y > 3 -> f\n"
     "axiom: F P(1,5) F P(1,2)\n", 0, "GP(0,0)P(1,5)GP(0,0)P(1,2)"),
    ("homomorphism limit", "homomorphism: no warnings\nseed: 4\nmaximum depth: 3\n"
     "X -> XY\naxiom: X\n", 0, "XYYY"),
]

# (label, .ls text, part of the message): each must be refused when loaded
SELF_TEST_ERRORS = [
    ("decomposition with a left context", "decomposition:\nA < L -> X\naxiom: L\n", 'has no context'),
    ("decomposition with a right context", "decomposition:\nL > A -> X\naxiom: L\n", 'has no context'),
    ("decomposition after homomorphism", "homomorphism:\nA -> B\ndecomposition:\nL -> X\naxiom: L\n", 'comes before `homomorphism:`'),
    ("productions after decomposition", "decomposition:\nL -> X\nproductions:\nA -> B\naxiom: L\n", 'productions after decomposition'),
    ("second decomposition", "decomposition:\nL -> X\ndecomposition:\nK -> X\naxiom: L\n", 'second `decomposition:`'),
    ("maximum depth 0", "decomposition:\nmaximum depth: 0\nL -> X\naxiom: L\n", 'maximum depth must be'),
    ("negative maximum depth", "homomorphism:\nmaximum depth: -1\nL -> X\naxiom: L\n", 'maximum depth must be'),
    ("fractional maximum depth", "homomorphism:\nmaximum depth: 2.5\nL -> X\naxiom: L\n", 'maximum depth must be'),
    ("maximum depth too large", "homomorphism:\nmaximum depth: 10001\nL -> X\naxiom: L\n", 'maximum depth must be'),
    ("maximum depth twice", "homomorphism:\nmaximum depth: 2\nmaximum depth: 2\naxiom: L\n", 'comes once'),
    ("maximum depth after a production", "homomorphism:\nL -> X\nmaximum depth: 2\naxiom: L\n", 'comes once'),
    ("maximum depth in the settings", "maximum depth: 2\naxiom: L\n", 'belongs to'),
    ("maximum depth in productions", "productions:\nmaximum depth: 2\naxiom: L\n", 'belongs to'),
    ("seed in decomposition", "decomposition:\nseed: 2\nL -> X\naxiom: L\n", 'no `seed:` here'),
    ("bad warnings word", "homomorphism: maybe\nL -> X\naxiom: L\n", 'expected `warnings`'),
    ("negative group", "groups: 1\nproductions -1:\nA -> B\naxiom: A\n", 'production group must be'),
    ("fractional group", "groups: 1\nproductions 1.5:\nA -> B\naxiom: A\n", 'production group must be'),
    ("group too large", "groups: 70000\nproductions 70000:\nA -> B\naxiom: A\n", 'production group must be'),
    ("group declared twice", "groups: 2\nproductions 2:\nA -> B\nproductions 2:\nA -> C\naxiom: A\n", 'group 2 is declared twice'),
    ("group 0 declared twice", "productions:\nA -> B\nproductions 0:\nA -> C\naxiom: A\n", 'group 0 is declared twice'),
    ("decomposition group", "decomposition 1:\nL -> X\naxiom: L\n", 'has no groups'),
    ("unknown group in a schedule", "groups: 1 3\nproductions 1:\nA -> B\naxiom: A\n", 'unknown group 3'),
    ("empty schedule", "groups:\nproductions:\nA -> B\naxiom: A\n", '`groups:` takes'),
    ("schedule with a name", "groups: 1 x\nproductions 1:\nA -> B\naxiom: A\n", '`groups:` takes'),
    ("both schedules", "groups: 1\ngroup: 1\nproductions 1:\nA -> B\naxiom: A\n", 'not both'),
    ("random group", "group: ran(3)\nproductions 1:\nA -> B\naxiom: A\n", 'cannot use ran'),
    ("unused group", "productions 1:\nA -> B\naxiom: A\n", 'never used'),
    ("step in define", "define: x = step\naxiom: A\n", "unknown name 'step'"),
    ("step in the axiom", "axiom: A(step)\n", "unknown name 'step'"),
]

# (label, .ls text, steps): refused while deriving
SELF_TEST_RUNTIME_ERRORS = [
    ("group expression names no group", "group: step\nproductions 1:\nA -> B\naxiom: A\n", 2),
    ("group expression not whole", "group: step / 2\nproductions 1:\nA -> B\naxiom: A\n", 1),
]


def self_test():
    """Run the hand-derived checks; return the number of failures."""
    failures = 0
    text = None
    for label, src, n, want in SELF_TESTS:
        text = src if src is not None else text
        try:
            got = format_string(Rewriter(parse_ls(text)).derive(n))
        except LsError as e:
            got = "error: %s" % e
        if got != want:
            failures += 1
            print("FAIL %s (n=%d)\n  got:  %s\n  want: %s" % (label, n, got, want))
    for label, src, fragment in SELF_TEST_ERRORS:
        try:
            parse_ls(src)
        except LsError as e:
            if fragment in str(e):
                continue
            print("FAIL %s: wrong error: %s" % (label, e))
        else:
            print("FAIL %s: accepted" % label)
        failures += 1
    for label, src, n in SELF_TEST_RUNTIME_ERRORS:
        ls = parse_ls(src)
        try:
            Rewriter(ls).derive(n)
        except LsError as e:
            if "group: gives" in str(e):
                continue
            print("FAIL %s: wrong error: %s" % (label, e))
        else:
            print("FAIL %s: derived" % label)
        failures += 1
    total = len(SELF_TESTS) + len(SELF_TEST_ERRORS) + len(SELF_TEST_RUNTIME_ERRORS)
    print("self-test: %d passed, %d failed" % (total - failures, failures))
    return failures


def main(argv=None):
    if argv is None:
        argv = sys.argv[1:]
    if argv == ["--self-test"]:
        return 1 if self_test() else 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("file")
    ap.add_argument("-n", type=int, default=None, help="number of derivation steps")
    args = ap.parse_args(argv)
    try:
        out = run_file(args.file, args.n)
    except LsError as e:
        print("ref.py: %s: %s" % (args.file, e), file=sys.stderr)
        return 1
    sys.stdout.write(out + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
