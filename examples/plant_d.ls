/* Bracketed OL-system plant, ABOP figure 1.24d (p. 25).
   n = 7, delta = 20 degrees. */
derivation length: 7
define: delta = 20

productions:
X -> F[+X]F[-X]+X
F -> FF

axiom:
X
