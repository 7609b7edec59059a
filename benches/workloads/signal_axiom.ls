/* Bench setup (not timed): a large bracketed string of 0, 1, F, +, -
   to serve as the axiom (--axiom) of context_signal.ls. Roughly triples
   each step; the homomorphism turns the remaining buds into 1. */
productions:
X -> F1[+X]F0[-X]+X

homomorphism:
X -> 1

axiom:
X
