/* Bench setup (not timed): a string where every A is followed by a
   bracketed branch and then B, A[...]B, with branches at every scale:
   the outermost ones hold about two thirds of the whole string.
   Roughly triples each step; the homomorphism ends the buds. */
productions:
X -> A[FX+FX]BX

homomorphism:
X -> F

axiom:
X
