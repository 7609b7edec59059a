/* Quadratic Koch curve variant, ABOP figure 1.9c (p. 10).
   n = 3, delta = 90 degrees. */
view: angle = 90
view: width = 0.07
view: palette = #1a237e
derivation length: 3
define: delta = 90

productions:
F -> FF-F+F-F-FF

axiom:
F-F-F-F
