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

Usage:
    python3 tests/tools/ref.py FILE.ls [-n STEPS]

Prints the final string on one line.  Without -n the file's
`derivation length:` is used (0 if absent).  The homomorphism, if any, is
applied once to the result.
"""

import argparse
import math
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
        self.productions = []
        self.homomorphism = []
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


def parse_ls(text):
    ls = LSystem()
    text = _strip_comments(text)
    lines = text.split("\n")
    section = "settings"
    i = 0
    while i < len(lines):
        line = lines[i].strip()
        i += 1
        if not line:
            continue
        low = line.lower()
        if low == "productions:":
            section = "productions"
            continue
        if low == "homomorphism:":
            section = "homomorphism"
            continue
        if low.startswith("axiom:"):
            rest = line[len("axiom:") :] + "\n" + "\n".join(lines[i:])
            env = dict(ls.defines)
            ls.axiom = [
                (s, tuple(eval_expr(parse_expr(a), env) for a in args))
                for s, args in parse_module_list(rest)
            ]
            return ls
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
            else:
                raise LsError("unknown setting %r" % key)
        elif section == "productions":
            ls.productions.append(parse_production(line))
        else:
            ls.homomorphism.append(parse_production(line))
    raise LsError("missing 'axiom:'")


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

    def try_production(self, p, s, match, i):
        env = dict(self.ls.defines)
        if p.lc is not None and not self.match_left(s, match, i, p.lc, env):
            return None
        if not self.bind(p.pred, s[i], env):
            return None
        if p.rc is not None and not self.match_right(s, match, i + 1, p.rc, 0, env):
            return None
        if p.cond is not None and eval_expr(p.cond, env) == 0.0:
            return None
        return [(sym, tuple(eval_expr(a, env) for a in args)) for sym, args in p.succ]

    def rewrite(self, s, prods):
        if any(p.prob is not None for p in prods):
            raise LsError("stochastic productions are not supported by ref.py")
        match = self.bracket_map(s)
        with_ctx = [p for p in prods if p.has_context]
        without = [p for p in prods if not p.has_context]
        out = []
        for i, mod in enumerate(s):
            result = None
            for group in (with_ctx, without):
                for p in group:
                    if p.pred[0] != mod[0]:
                        continue
                    result = self.try_production(p, s, match, i)
                    if result is not None:
                        break
                if result is not None:
                    break
            if result is None:
                out.append(mod)
            else:
                out.extend(result)
        return out

    def derive(self, n):
        s = list(self.ls.axiom)
        for _ in range(n):
            s = self.rewrite(s, self.ls.productions)
        if self.ls.homomorphism:
            s = self.rewrite(s, self.ls.homomorphism)
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


def main(argv=None):
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
