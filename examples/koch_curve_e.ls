/* Quadratic Koch curve variant, ABOP figure 1.9e (p. 10).
   n = 5, delta = 90 degrees. */
view: angle = 90
view: width = 0.28
view: palette = #1a237e
derivation length: 5
define: delta = 90

productions:
F -> F-FF--F-F

axiom:
F-F-F-F
