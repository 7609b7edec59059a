/* Quadratic Koch curve variant, ABOP figure 1.9a (p. 10).
   n = 4, delta = 90 degrees. */
view: angle = 90
view: width = 0.47
view: palette = #1a237e
derivation length: 4
define: delta = 90

productions:
F -> FF-F-F-F-F-F+F

axiom:
F-F-F-F
