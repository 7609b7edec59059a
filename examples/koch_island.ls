/* Quadratic Koch island, ABOP figure 1.6 (p. 8).
   The book shows derivation lengths n = 0..3; delta = 90 degrees. */
view: angle = 90
view: width = 0.35
view: palette = #0d47a1
derivation length: 3
define: delta = 90

productions:
F -> F-F+F+FF-F-F+F

axiom:
F-F-F-F
