/* Bracketed OL-system plant, ABOP figure 1.24a (p. 25).
   n = 5, delta = 25.7 degrees. */
derivation length: 5
define: delta = 25.7

productions:
F -> F[+F]F[-F]F

axiom:
F
